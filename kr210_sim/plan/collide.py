"""Collision checks of planned moves on kinematic configurations (no physics stepping).

A move is sampled at most 1 cm of gripper travel and 1 deg per joint apart; at each sample the
arm (and the held target) are placed on a scratch :class:`mujoco.MjData` of a copy of the cell
model, and MuJoCo's own collision detection (``mj_kinematics`` + ``mj_collision``) reports any
contact between a robot collider (primitives and hulls) or the held target and a cell part
(shelf, bin, obstacles, floor). The live simulation is never touched.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.handles import CellHandles
from kr210_sim.cell.spec import TargetSpec
from kr210_sim.plan.trajectory import Trajectory
from kr210_sim.robot.kinematics import Kinematics

import mujoco  # isort: skip

FloatArray = npt.NDArray[np.float64]

#: Largest gripper travel between two checked samples [m].
SAMPLE_TRAVEL = 0.01
#: Largest joint move between two checked samples [rad].
SAMPLE_ANGLE = math.radians(1.0)
#: Clearance a robot collider must keep from the cell [m] (contacts closer than this count).
CLEARANCE = 0.005
#: Time step of the dense pass that picks the checked samples [s].
_DENSE_DT = 0.002


@dataclass(frozen=True, slots=True)
class Hit:
    """The first collision found along a move.

    Attributes:
        sample: Index of the colliding sample.
        q: Joint state there [rad].
        robot: Name of the robot collider (or the held target).
        cell: Name of the cell part's geom.
    """

    sample: int
    q: FloatArray
    robot: str
    cell: str

    def describe(self) -> str:
        """``link_3_hull against obstacle_1 at q [...]``."""
        return f"{self.robot} against {self.cell} at q {np.round(self.q, 3).tolist()}"


def check_samples(traj: Trajectory, kin: Kinematics) -> FloatArray:
    """Joint states along ``traj`` at most :data:`SAMPLE_TRAVEL` of gripper travel (by ``kin``'s
    forward kinematics) and :data:`SAMPLE_ANGLE` per joint apart (both ends included), shape
    (n, 6)."""
    n = max(2, math.ceil(traj.duration / _DENSE_DT) + 1)
    while True:  # dense enough that every dense step is below 0.9 of a unit
        ts = np.linspace(0.0, traj.duration, n)
        q = traj.sample_many(ts)[0]
        p = kin.forward(q)[:, :3, 3]
        step = np.maximum(
            np.abs(np.diff(q, axis=0)).max(axis=1) / SAMPLE_ANGLE,
            np.linalg.norm(np.diff(p, axis=0), axis=1) / SAMPLE_TRAVEL,
        )
        worst = float(step.max(initial=0.0))
        if worst < 0.9:
            break
        n = math.ceil((n - 1) * worst / 0.5) + 1
    cum = np.concatenate([[0.0], np.cumsum(step)])
    # keep the last dense sample before the travel since the previous kept one passes one unit
    keep, last = [0], 0.0
    for i in range(1, n):
        if cum[i] - last > 1.0 and keep[-1] != i - 1:
            keep.append(i - 1)
            last = float(cum[i - 1])
    if keep[-1] != n - 1:
        keep.append(n - 1)
    return np.asarray(q[keep])


class CollisionChecker:
    """Checks joint states of the arm, gripper open or holding a target, against the cell.

    Args:
        model: The cell model (copied: the copy's floor is made to touch the hull colliders,
            sleeping is off, cell geoms get a margin of :data:`CLEARANCE`).
        kin: The kinematics of the arm in ``model`` (places a held target at the gripper).
    """

    def __init__(self, model: mujoco.MjModel, kin: Kinematics) -> None:
        self.kin = kin
        m = copy.copy(model)
        m.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
        self.model = m
        self.data = mujoco.MjData(m)
        h = CellHandles.from_model(m)
        self.handles = h
        mujoco.mj_resetDataKeyframe(m, self.data, 0)
        env = np.array(sorted(h.env_geoms))
        robot_bodies = {int(m.geom_bodyid[g]) for g in h.robot_geoms}
        self._is_robot = np.zeros(m.ngeom, dtype=bool)
        for g in range(m.ngeom):
            if m.geom_bodyid[g] in robot_bodies and m.geom_contype[g] != 0:
                self._is_robot[g] = True
        self._is_env = np.zeros(m.ngeom, dtype=bool)
        self._is_env[env] = True
        # Only robot-cell and held target-cell pairs pass the contact filter: the robot's
        # colliders (primitives and hulls) and the held target have contype 2 only, the cell's
        # parts (the floor too) conaffinity 2 only, everything else neither. Spare targets are
        # parked out of reach; target_0 stands in for the held one.
        m.geom_contype[:] = 0
        m.geom_conaffinity[:] = 0
        m.geom_contype[self._is_robot] = 2
        m.geom_conaffinity[env] = 2
        m.geom_margin[env] = CLEARANCE
        self._held_geom = int(h.target_geoms[0])
        self._held_qpos = int(h.target_qpos[0])
        # the broadphase filters bodies by the union of their geoms' bits: recompute it
        m.geom_contype[self._held_geom] = 2
        m.body_contype[:] = 0
        m.body_conaffinity[:] = 0
        for g in range(m.ngeom):
            m.body_contype[m.geom_bodyid[g]] |= m.geom_contype[g]
            m.body_conaffinity[m.geom_bodyid[g]] |= m.geom_conaffinity[g]
        m.geom_contype[self._held_geom] = 0
        self._finger_open = float(m.actuator_ctrlrange[h.grip_act, 0])
        self.checks = 0

    def _hold(self, target: TargetSpec | None, offset: FloatArray | None) -> None:
        m, g = self.model, self._held_geom
        if target is None or offset is None:
            m.geom_contype[g] = 0
            return
        m.geom_contype[g] = 2
        m.geom_size[g, :2] = (target.radius, target.length / 2.0)
        r, half = target.radius, target.length / 2.0
        m.geom_rbound[g] = math.hypot(r, half)
        m.geom_aabb[g] = (0, 0, 0, r, r, half)
        # the broadphase reads the body's bounding box, a compiled copy of the geom's
        m.bvh_aabb[m.body_bvhadr[m.geom_bodyid[g]]] = (0, 0, 0, r, r, half)

    def first_hit(
        self,
        qs: FloatArray,
        target: TargetSpec | None = None,
        offset: npt.ArrayLike | None = None,
        finger_q: float | None = None,
    ) -> Hit | None:
        """The first of the joint states ``qs`` (n, 6) where the robot or the held target
        touches the cell, or None.

        Args:
            qs: Arm joint states [rad].
            target: The held target (None: nothing held).
            offset: The held target's centre in the gripper_link frame [m] (upright).
            finger_q: Finger joint position [m] (default: fully open).
        """
        m, d, h = self.model, self.data, self.handles
        off = None if offset is None else np.asarray(offset, dtype=np.float64)
        self._hold(target, off)
        d.qpos[h.finger_qpos] = self._finger_open if finger_q is None else finger_q
        a = self._held_qpos
        held_pose = None
        if off is not None:  # upright at the offset, turned with the gripper's heading
            T = self.kin.forward(np.asarray(qs))
            yaw = np.arctan2(T[:, 1, 0], T[:, 0, 0])
            held_pose = np.column_stack(
                [
                    np.einsum("nij,j->ni", T[:, :3, :3], off) + T[:, :3, 3],
                    np.cos(yaw / 2),
                    np.zeros((len(yaw), 2)),
                    np.sin(yaw / 2),
                ]
            )
        arm_qpos = slice(int(h.arm_qpos[0]), int(h.arm_qpos[-1]) + 1)
        kin, collide = mujoco.mj_kinematics, mujoco.mj_collision
        for i, q in enumerate(qs):
            d.qpos[arm_qpos] = q
            if held_pose is not None:
                d.qpos[a : a + 7] = held_pose[i]
            kin(m, d)
            collide(m, d)
            self.checks += 1
            if d.ncon:  # only robot-cell and held-cell pairs pass the filter
                g1, g2 = (int(g) for g in d.contact.geom[0])
                mover, other = (g2, g1) if self._is_env[g1] else (g1, g2)
                name = "the held target" if mover == self._held_geom else m.geom(mover).name
                return Hit(i, np.array(q, dtype=np.float64), name, m.geom(other).name)
        return None
