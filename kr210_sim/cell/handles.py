"""Indices into a compiled cell model, looked up once by name (the names the builder gives).

The runtime reads a model only through these handles and :mod:`kr210_sim.cell.layout`; the names
are the contract with :mod:`kr210_sim.cell.mjcf`, which imports :func:`target_name` and
:data:`ENV_PARTS` from here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import SceneError
from kr210_sim.robot.description import ARM_JOINTS, ARM_LINKS, FINGER_JOINTS

import mujoco  # isort: skip  (after kr210_sim so MUJOCO_GL is chosen first)

#: The cell parts the contact monitor watches, in the order of ``env_contact_sensors``.
ENV_PARTS = ("shelf", "bin", "obstacles", "floor")


def target_name(index: int) -> str:
    """Body (and geom) name of target cylinder ``index`` (0-based)."""
    return f"target_{index}"


@dataclass(frozen=True, slots=True)
class CellHandles:
    """Indices into a compiled cell model, looked up once by name.

    Attributes:
        arm_qpos: qpos addresses of joint_1..joint_6.
        arm_dof: dof addresses of joint_1..joint_6.
        arm_act: Actuator ids of joint_1..joint_6.
        finger_qpos: qpos addresses of the right and left finger joints.
        grip_act: Actuator id of the gripper.
        gripper_body: Body id of gripper_link.
        grip_site: Site id of the grasp centre between the fingers.
        finger_geoms: Geom ids of the right and left finger pads.
        lip_geoms: Geom ids of the right and left fingertip lips.
        robot_geoms: Collision geom ids of the robot.
        shelf_geoms: Geom ids of the shelf.
        bin_geoms: Geom ids of the bin.
        env_geoms: Geom ids of every cell part the robot must not touch (shelf, bin, obstacles,
            floor).
        target_bodies: Body ids of the targets.
        target_geoms: Geom ids of the targets.
        target_qpos: qpos address of each target's free joint.
        target_dof: dof address of each target's free joint.
        env_contact_sensors: sensordata addresses of the robot's contact counts with each cell
            part (:data:`ENV_PARTS` that the model has).
    """

    arm_qpos: npt.NDArray[np.int_]
    arm_dof: npt.NDArray[np.int_]
    arm_act: npt.NDArray[np.int_]
    finger_qpos: npt.NDArray[np.int_]
    grip_act: int
    gripper_body: int
    grip_site: int
    finger_geoms: tuple[int, int]
    lip_geoms: tuple[int, int]
    robot_geoms: frozenset[int]
    shelf_geoms: frozenset[int]
    bin_geoms: frozenset[int]
    env_geoms: frozenset[int]
    target_bodies: npt.NDArray[np.int_]
    target_geoms: npt.NDArray[np.int_]
    target_qpos: npt.NDArray[np.int_]
    target_dof: npt.NDArray[np.int_]
    env_contact_sensors: tuple[int, ...]

    @classmethod
    def from_model(cls, model: mujoco.MjModel) -> CellHandles:
        """Look up every handle by name.

        Raises:
            SceneError: When a named element is missing (lists what exists).
        """

        def jid(name: str) -> int:
            i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
            if i < 0:
                names = [model.joint(k).name for k in range(model.njnt)]
                raise SceneError(
                    f"scene is not a kr210_sim cell: it has no joint {name!r} (joints: {names})"
                )
            return int(i)

        def oid(kind: mujoco.mjtObj, name: str) -> int:
            i = mujoco.mj_name2id(model, kind, name)
            if i < 0:
                raise SceneError(
                    f"scene is not a kr210_sim cell: it has no {kind.name[6:].lower()} {name!r}"
                )
            return int(i)

        arm = [jid(n) for n in ARM_JOINTS]
        fingers = [jid(n) for n in FINGER_JOINTS]
        robot_bodies = {oid(mujoco.mjtObj.mjOBJ_BODY, n) for n in ARM_LINKS} | {
            oid(mujoco.mjtObj.mjOBJ_BODY, n)
            for n in ("right_gripper_finger_link", "left_gripper_finger_link")
        }
        shelf = oid(mujoco.mjtObj.mjOBJ_BODY, "shelf")
        bin_ = oid(mujoco.mjtObj.mjOBJ_BODY, "bin")
        targets = []
        k = 0
        while mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, target_name(k)) >= 0:
            targets.append(oid(mujoco.mjtObj.mjOBJ_BODY, target_name(k)))
            k += 1
        if not targets:
            raise SceneError("scene has no target cylinders (target_0 ...)")
        target_joints = [jid(f"{target_name(i)}_joint") for i in range(len(targets))]
        gb = model.geom_bodyid
        env_bodies = {shelf, bin_}
        obstacles = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "obstacles")
        if obstacles >= 0:
            env_bodies.add(int(obstacles))
        floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        sensors = []
        for env in ENV_PARTS:
            i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, f"robot_{env}_contacts")
            if i >= 0:
                sensors.append(int(model.sensor_adr[i]))
            elif env in ("shelf", "bin"):
                oid(mujoco.mjtObj.mjOBJ_SENSOR, f"robot_{env}_contacts")  # raises
        return cls(
            arm_qpos=np.array([model.jnt_qposadr[j] for j in arm]),
            arm_dof=np.array([model.jnt_dofadr[j] for j in arm]),
            arm_act=np.array([oid(mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in ARM_JOINTS]),
            finger_qpos=np.array([model.jnt_qposadr[j] for j in fingers]),
            grip_act=oid(mujoco.mjtObj.mjOBJ_ACTUATOR, "gripper"),
            gripper_body=oid(mujoco.mjtObj.mjOBJ_BODY, "gripper_link"),
            grip_site=oid(mujoco.mjtObj.mjOBJ_SITE, "gripper"),
            finger_geoms=(
                oid(mujoco.mjtObj.mjOBJ_GEOM, "right_finger_pad"),
                oid(mujoco.mjtObj.mjOBJ_GEOM, "left_finger_pad"),
            ),
            lip_geoms=(
                oid(mujoco.mjtObj.mjOBJ_GEOM, "right_finger_lip"),
                oid(mujoco.mjtObj.mjOBJ_GEOM, "left_finger_lip"),
            ),
            robot_geoms=frozenset(
                g
                for g in range(model.ngeom)
                if gb[g] in robot_bodies and model.geom_contype[g] != 0
            ),
            shelf_geoms=frozenset(g for g in range(model.ngeom) if gb[g] == shelf),
            bin_geoms=frozenset(g for g in range(model.ngeom) if gb[g] == bin_),
            env_geoms=frozenset(g for g in range(model.ngeom) if gb[g] in env_bodies or g == floor),
            target_bodies=np.array(targets),
            target_geoms=np.array(
                [oid(mujoco.mjtObj.mjOBJ_GEOM, target_name(i)) for i in range(len(targets))]
            ),
            target_qpos=np.array([model.jnt_qposadr[j] for j in target_joints]),
            target_dof=np.array([model.jnt_dofadr[j] for j in target_joints]),
            env_contact_sensors=tuple(sensors),
        )
