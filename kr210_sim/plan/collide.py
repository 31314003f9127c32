"""Collision checks of planned moves on kinematic configurations (no physics stepping).

A move is sampled at most 1 cm of gripper travel and 1 deg per joint apart; at each sample the
arm (and the held target) are placed on a scratch :class:`mujoco.MjData` of a copy of the cell
model, and MuJoCo's own collision detection (``mj_kinematics`` + ``mj_collision``) reports any
contact. The live simulation is never touched. What counts as a collision:

* **the cell**: a robot collider (primitives and hulls) or the held target closer than
  :data:`CLEARANCE` to a cell part (shelf, bin, obstacles, floor). In the copy the cell's boxes
  grow by that much on every face (MuJoCo's box-box collider ignores margins, and margins make
  mesh pairs several times dearer); the floor becomes a slab that thick, and the bin's cage
  meshes keep it as a margin. Measured with ``mj_geomDistance``, no accepted state comes
  closer than 5.0 mm.
* **the arm itself**: the wrist and gripper against the base, link 1 and link 2, the gripper
  against link 3, and the held target against the base and links 1 to 4 (touching, no margin).
  Adjacent links (parent and child) never count: MuJoCo filters them.
* **the held target as held**: it is carried in the gripper's frame (its axis along the
  gripper's z axis), so a tilted gripper tilts it; and while holding, the gripper's z axis must
  stay within :data:`HOLD_TILT_DEG` of vertical, or the part would slip out of a real grip.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
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
#: Clearance a robot collider and the held target keep from the cell [m].
CLEARANCE = 0.005
#: Largest angle between the gripper's z axis and the vertical while holding [deg].
HOLD_TILT_DEG = 30.0
#: Half the extent of the floor slab that stands in for the floor plane [m].
_FLOOR_HALF = 50.0
#: Convergence tolerance of the convex collider in the copy [m] (MuJoCo's default is 1e-6).
_CCD_TOLERANCE = 1e-4
#: Time step of the dense pass that picks the checked samples [s].
_DENSE_DT = 0.002

#: Contact-filter bits of the copy: robot and held target against the cell, and three kinds
#: of self-collision (movers' contype against the bodies' conaffinity).
_CELL_BIT = 2
_SELF = (
    (
        4,
        ("link_4", "link_5", "link_6", "gripper_link", "*finger"),
        ("base_link", "link_1", "link_2"),
    ),
    (8, ("gripper_link", "*finger"), ("link_3",)),
)
_HELD_BIT = 16
_HELD_AGAINST = ("base_link", "link_1", "link_2", "link_3", "link_4")


@dataclass(frozen=True, slots=True)
class Hit:
    """The first collision found along a move.

    Attributes:
        sample: Index of the colliding sample.
        q: Joint state there [rad].
        robot: Name of the robot collider (or "the held target").
        cell: Name of what it touches: a cell part's geom, another robot collider, or a
            description of a broken constraint ("a tilt of 41 deg ...").
        kind: "cell", "self" or "tilt".
    """

    sample: int
    q: FloatArray
    robot: str
    cell: str
    kind: str = "cell"

    def describe(self) -> str:
        """``link_3_hull against obstacle_1 at q [...]``."""
        where = f"at q {np.round(self.q, 3).tolist()}"
        if self.kind == "tilt":
            return f"{self.robot} tilts {self.cell} {where}"
        if self.kind == "self":
            return f"{self.robot} against the arm's own {self.cell} {where}"
        return f"{self.robot} against {self.cell} {where}"


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


def held_poses(T: FloatArray, offset: FloatArray) -> FloatArray:
    """Free-joint poses (x, y, z, qw, qx, qy, qz) of a target held at ``offset`` [m] in the
    gripper_link frame, its axis along the gripper's z axis, for gripper_link poses ``T``
    (n, 4, 4)."""
    out = np.empty((len(T), 7))
    out[:, :3] = np.einsum("nij,j->ni", T[:, :3, :3], offset) + T[:, :3, 3]
    for i, R in enumerate(T[:, :3, :3]):
        mujoco.mju_mat2Quat(out[i, 3:], R.ravel())
    return out


def _inflate(m: mujoco.MjModel, geoms: list[int], by: float) -> None:
    """Grow box geoms by ``by`` [m] on every face, with their bounding volumes."""
    bodies = set()
    for g in geoms:
        m.geom_size[g] += by
        m.geom_rbound[g] = float(np.linalg.norm(m.geom_size[g]))
        m.geom_aabb[g, 3:] += by
        bodies.add(int(m.geom_bodyid[g]))
    for b in bodies:  # the midphase reads the body's bounding-volume tree
        adr, n = int(m.body_bvhadr[b]), int(m.body_bvhnum[b])
        if adr >= 0:
            m.bvh_aabb[adr : adr + n, 3:] += by


class CollisionChecker:
    """Checks joint states of the arm, gripper open or holding a target, against the cell and
    itself (see the module doc).

    Args:
        model: The cell model (copied and changed: contact filter bits, margins, inflated box
            colliders, sleeping off).
        kin: The kinematics of the arm in ``model`` (places a held target at the gripper).
    """

    def __init__(self, model: mujoco.MjModel, kin: Kinematics) -> None:
        self.kin = kin
        m = copy.copy(model)
        m.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
        self.model = m
        h = CellHandles.from_model(m)
        self.handles = h
        env = np.array(sorted(h.env_geoms))
        robot_bodies = {int(m.geom_bodyid[g]) for g in h.robot_geoms}
        self._is_robot = np.zeros(m.ngeom, dtype=bool)
        for g in range(m.ngeom):
            if m.geom_bodyid[g] in robot_bodies and m.geom_contype[g] != 0:
                self._is_robot[g] = True
        self._is_env = np.zeros(m.ngeom, dtype=bool)
        self._is_env[env] = True
        robot = np.flatnonzero(self._is_robot)
        body_name = [m.body(int(m.geom_bodyid[g])).name for g in range(m.ngeom)]

        def on(g: int, names: tuple[str, ...]) -> bool:
            b = body_name[g]
            return any(b == n or (n[0] == "*" and b.endswith(n[1:] + "_link")) for n in names)

        # Only the pairs of the module doc pass the contact filter (the floor is a cell part).
        # Spare targets are parked out of reach; target_0 stands in for the held one.
        m.geom_contype[:] = 0
        m.geom_conaffinity[:] = 0
        m.geom_contype[robot] = _CELL_BIT
        m.geom_conaffinity[env] = _CELL_BIT
        # Clearance: cell boxes grow by it, the other cell parts (floor, the bin's cage meshes)
        # keep it as a margin (margins make mesh pairs dear, and MuJoCo's box-box collider
        # ignores them).
        m.geom_margin[:] = 0.0
        m.geom_gap[:] = 0.0
        kind = m.geom_type[env]
        _inflate(m, [int(g) for g in env[kind == mujoco.mjtGeom.mjGEOM_BOX]], CLEARANCE)
        m.geom_margin[env[kind != mujoco.mjtGeom.mjGEOM_BOX]] = CLEARANCE
        for plane in env[kind == mujoco.mjtGeom.mjGEOM_PLANE]:  # a floor: a slab CLEARANCE thick
            g = int(plane)
            m.geom_type[g] = mujoco.mjtGeom.mjGEOM_BOX
            m.geom_size[g] = (_FLOOR_HALF, _FLOOR_HALF, CLEARANCE)
            m.geom_margin[g] = 0.0
            m.geom_rbound[g] = float(np.linalg.norm(m.geom_size[g]))
            m.geom_aabb[g] = (0.0, 0.0, 0.0, *m.geom_size[g])
            b = int(m.geom_bodyid[g])
            if m.body_bvhnum[b] == 1:  # the world's one volume: the plane's half space
                m.bvh_aabb[m.body_bvhadr[b]] = m.geom_aabb[g]
        m.opt.ccd_tolerance = _CCD_TOLERANCE
        for bit, movers, against in _SELF:
            for r in robot:
                if on(int(r), movers):
                    m.geom_contype[r] |= bit
                if on(int(r), against):
                    m.geom_conaffinity[r] |= bit
        for r in robot:
            if on(int(r), _HELD_AGAINST):
                m.geom_conaffinity[r] |= _HELD_BIT
        self._held_geom = int(h.target_geoms[0])
        self._held_qpos = int(h.target_qpos[0])
        self._held_type = _CELL_BIT | _HELD_BIT
        # the broadphase filters bodies by the union of their geoms' bits: recompute it
        m.geom_contype[self._held_geom] = self._held_type
        m.body_contype[:] = 0
        m.body_conaffinity[:] = 0
        for g in range(m.ngeom):
            m.body_contype[m.geom_bodyid[g]] |= m.geom_contype[g]
            m.body_conaffinity[m.geom_bodyid[g]] |= m.geom_conaffinity[g]
        m.geom_contype[self._held_geom] = 0
        self.data = mujoco.MjData(m)
        mujoco.mj_resetDataKeyframe(m, self.data, 0)
        self._finger_open = float(m.actuator_ctrlrange[h.grip_act, 0])
        self._arm = slice(int(h.arm_qpos[0]), int(h.arm_qpos[-1]) + 1)
        self._cos_tilt = math.cos(math.radians(HOLD_TILT_DEG))
        self._grip_body = int(m.body("gripper_link").id)
        self._offset: FloatArray | None = None
        #: What :meth:`hold` holds, as bytes (equal keys: the same states are valid).
        self.hold_key = b""
        #: States checked so far.
        self.checks = 0
        self.hold(None, None)

    def hold(
        self,
        target: TargetSpec | None,
        offset: npt.ArrayLike | None,
        finger_q: float | None = None,
    ) -> None:
        """Check the states that follow holding ``target`` at ``offset`` (its centre in the
        gripper_link frame [m]), or nothing (None), with the fingers at ``finger_q`` [m]
        (default: fully open)."""
        m, g, d = self.model, self._held_geom, self.data
        finger = self._finger_open if finger_q is None else float(finger_q)
        d.qpos[self.handles.finger_qpos] = finger
        if target is None or offset is None:
            m.geom_contype[g] = 0
            self._offset = None
            self.hold_key = np.array([finger]).tobytes()
            return
        self._offset = np.asarray(offset, dtype=np.float64).reshape(3)
        self.hold_key = np.array([finger, target.radius, target.length, *self._offset]).tobytes()
        m.geom_contype[g] = self._held_type
        r, half = target.radius, target.length / 2.0
        m.geom_size[g, :2] = (r, half)
        m.geom_rbound[g] = math.hypot(r, half)
        m.geom_aabb[g] = (0, 0, 0, r, r, half)
        # the broadphase reads the body's bounding box, a compiled copy of the geom's
        m.bvh_aabb[m.body_bvhadr[m.geom_bodyid[g]]] = (0, 0, 0, r, r, half)

    def _contact(self, i: int, q: FloatArray) -> Hit | None:
        m, d = self.model, self.data
        if not d.ncon:
            return None
        g1, g2 = (int(g) for g in d.contact.geom[0])
        if self._is_env[g1] or self._is_env[g2]:
            mover, other = (g2, g1) if self._is_env[g1] else (g1, g2)
            kind = "cell"
        else:  # the arm against itself (named from the hand's end), or the held target
            b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
            held2 = g2 == self._held_geom
            mover, other = (g2, g1) if held2 or (b2 > b1 and g1 != self._held_geom) else (g1, g2)
            kind = "self"
        name = "the held target" if mover == self._held_geom else m.geom(mover).name
        return Hit(i, np.array(q, dtype=np.float64), name, m.geom(other).name, kind)

    def first_hit(
        self,
        qs: FloatArray,
        target: TargetSpec | None = None,
        offset: npt.ArrayLike | None = None,
        finger_q: float | None = None,
    ) -> Hit | None:
        """The first of the joint states ``qs`` (n, 6) that collides (see the module doc), or
        None.

        Args:
            qs: Arm joint states [rad].
            target: The held target (None: nothing held).
            offset: The held target's centre in the gripper_link frame [m].
            finger_q: Finger joint position [m] (default: fully open).
        """
        self.hold(target, offset, finger_q)
        return self.scan(qs)

    def scan(self, qs: FloatArray) -> Hit | None:
        """:meth:`first_hit` under the current :meth:`hold`."""
        qs = np.asarray(qs, dtype=np.float64).reshape(-1, 6)
        m, d = self.model, self.data
        a = self._held_qpos
        held, up = None, None
        if self._offset is not None:
            T = self.kin.forward(qs)
            held, up = held_poses(T, self._offset), T[:, 2, 2]
            tilted = np.flatnonzero(up < self._cos_tilt)
            last = int(tilted[0]) if len(tilted) else len(qs)
        else:
            last = len(qs)
        kin, collide = mujoco.mj_kinematics, mujoco.mj_collision
        for i in range(last):
            d.qpos[self._arm] = qs[i]
            if held is not None:
                d.qpos[a : a + 7] = held[i]
            kin(m, d)
            collide(m, d)
            self.checks += 1
            hit = self._contact(i, qs[i])
            if hit is not None:
                return hit
        if up is not None and last < len(qs):
            tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(up[last])))))
            return Hit(
                last,
                qs[last].copy(),
                "the held target",
                f"{tilt:.1f} deg from upright (most {HOLD_TILT_DEG:.0f})",
                "tilt",
            )
        return None

    @property
    def holding(self) -> bool:
        """Whether the states checked next hold a target (:meth:`hold`)."""
        return self._offset is not None

    def state_validity(self) -> Callable[[FloatArray], bool]:
        """A function ``valid(q) -> bool`` for one joint state [rad], under the current
        :meth:`hold` (what a sampling planner calls). The held target is placed from MuJoCo's
        own gripper_link pose (a second kinematics pass)."""
        m, d, a, arm = self.model, self.data, self._held_qpos, self._arm
        off, cos_tilt, grip = self._offset, self._cos_tilt, self._grip_body
        kin, collide = mujoco.mj_kinematics, mujoco.mj_collision

        def valid(q: FloatArray) -> bool:
            self.checks += 1
            d.qpos[arm] = q
            kin(m, d)
            if off is not None:
                R = d.xmat[grip].reshape(3, 3)
                if R[2, 2] < cos_tilt:
                    return False
                d.qpos[a : a + 3] = R @ off + d.xpos[grip]
                d.qpos[a + 3 : a + 7] = d.xquat[grip]
                kin(m, d)
            collide(m, d)
            return d.ncon == 0

        return valid
