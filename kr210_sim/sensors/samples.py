"""Rendered samples of a cluttered shelf with their truth: what a classifier is trained and
tested on.

Each sample is a pure function of ``(seed, i)``: a target of a kind from the cell's pick list
stands in a random slot (offset and turned as ``--randomize`` draws it), every bay is cluttered
as :mod:`kr210_sim.sim.clutter` clutters it at the start of a cycle, the arm waits in its
ready pose, and each world-mounted sensor (or the ones named) takes one look; a sensor on the
gripper looks from the target's wrist-look pose (:func:`~kr210_sim.sensors.looks.wrist_look_q`),
the arm put there without moving (a second look as the runner would take it). With each look come
the objects on the shelf (:func:`~kr210_sim.sensors.truth.shelf_truth`) and, per pixel, which of
them it shows (MuJoCo's segmentation render): labels for training, never a pipeline's input.
"""

from __future__ import annotations

import copy
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.layout import CellLayout, ready_pose
from kr210_sim.cell.load import model_at
from kr210_sim.cell.sensing_layout import pick_list_of
from kr210_sim.perception.camera import Observation
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sensors.looks import wrist_look_q
from kr210_sim.sensors.render import SensorRig
from kr210_sim.sensors.truth import TruthObject, shelf_truth
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.clutter import Clutter, pick_target
from kr210_sim.sim.targets import place_upright, set_target_spec

import mujoco  # isort: skip


@dataclass(frozen=True)
class Sample:
    """One look at a cluttered shelf, with the truth.

    Attributes:
        index: The sample's number (its scene is drawn from ``(seed, index)``).
        observation: What the sensor saw (noisy unless asked otherwise).
        truth: The objects on the shelf (labels, poses, sizes).
        labels: (H, W) int32: the index into ``truth`` of the object each pixel shows, -1 for
            anything else (shelf, floor, robot, objects elsewhere).
        target: The index into ``truth`` of the target cylinder.
        slot: The target's slot.
    """

    index: int
    observation: Observation
    truth: tuple[TruthObject, ...]
    labels: npt.NDArray[np.int32]
    target: int
    slot: int


def render_samples(
    cell: Path | str | mujoco.MjModel,
    n: int,
    seed: int = 0,
    sensors: tuple[str, ...] | None = None,
    noise: bool = True,
) -> Iterator[Sample]:
    """Render ``n`` seeded scenes of a cluttered shelf, one :class:`Sample` per scene and sensor.

    Args:
        cell: A cell file (``.toml``), an MJCF scene, or a compiled cell model (not changed:
            the samples use a copy).
        n: Number of scenes.
        seed: The seed every scene is drawn from (scene i from ``(seed, i)``).
        sensors: The sensors that look (default: every world-mounted one).
        noise: Apply each sensor's noise model.

    Yields:
        The samples, scene by scene.

    Raises:
        ConfigError: When the cell is bad, has no sensors, or names an unknown sensor.
    """
    # a copy: the samples resize and recolour the target
    model = copy.copy(cell) if isinstance(cell, mujoco.MjModel) else model_at(Path(cell))
    layout = CellLayout.from_model(model)
    sim = Cell(model)
    q_ready = ready_pose(model)
    sim.reset(q_ready)
    robot = load_robot()
    kin = Kinematics(robot)
    rig = SensorRig(model)
    names = sensors or tuple(s.name for s in rig.sensors.values() if s.mount == "world")
    for name in names:
        rig.sensor(name)  # raises for an unknown one
    clutter = Clutter(model, layout)
    picks = pick_list_of(model)
    r = layout.randomization
    try:
        for i in range(n):
            rng = np.random.default_rng([seed, i])
            slot = int(rng.integers(1, layout.n_slots + 1))
            kind = picks[int(rng.integers(len(picks)))]
            spec, rgb = pick_target(kind, layout, clutter.kinds, rng)
            set_target_spec(model, sim, 0, spec, rgb)
            board = layout.slots[slot - 1]
            xy = board[:2] + rng.uniform(-r.xy_offset, r.xy_offset, size=2)
            position = (float(xy[0]), float(xy[1]), float(board[2] + spec.length / 2.0))
            place_upright(sim, 0, position, float(rng.uniform(*r.yaw)))
            clutter.place(sim.data, clutter.draw(rng, slot, xy, spec.radius, kind))
            mujoco.mj_forward(model, sim.data)
            truth = tuple(shelf_truth(model, sim.data, layout))
            by_geom = np.full(model.ngeom + 1, -1, dtype=np.int32)
            for j, obj in enumerate(truth):
                by_geom[obj.geom] = j
            target = next(j for j, o in enumerate(truth) if o.body == sim.handles.target_bodies[0])
            for name in names:
                on_gripper = rig.sensor(name).mount == "gripper"
                q = (
                    wrist_look_q(kin, robot, position, q_ready, spec.radius)
                    if on_gripper
                    else q_ready
                )
                sim.data.qpos[sim.handles.arm_qpos] = q
                mujoco.mj_forward(model, sim.data)
                obs, seg = rig.look_with_truth(sim.data, name, rng, noise)
                labels = by_geom[np.where(seg >= 0, seg, model.ngeom)]
                yield Sample(i, obs, truth, labels, target, slot)
    finally:
        rig.close()
