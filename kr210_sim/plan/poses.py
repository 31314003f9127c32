"""The gripper poses a cycle is planned through, and the IK solutions a plan tries for them.

Every pose keeps the gripper level (its z axis up) and points it along a heading
(:func:`gripper_pose`), radially by default (:func:`radial_yaw`); the cylinder sits between the
fingers as far forward as the fingertip lips allow (:func:`grasp_depth`). A pose has up to
eight IK solutions: a carry is solved with the wrist untwisted (:func:`untwisted_nearest`), and a
pick tries the solution nearest the start, then the other untwisted ones
(:func:`branch_solutions`). Used by :mod:`kr210_sim.plan.planner`.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import PlanningError
from kr210_sim.robot.description import RobotDescription
from kr210_sim.robot.kinematics import Kinematics

FloatArray = npt.NDArray[np.float64]

#: Clearance between the cylinder and the fingertip lips at the grasp, along x [m].
LIP_CLEARANCE = 0.0005


def grasp_depth(robot: RobotDescription, radius: float) -> float:
    """x of the target's axis in the gripper_link frame at the grasp [m].

    The cylinder sits as far forward as the fingertip lips allow with :data:`LIP_CLEARANCE` to
    spare, so the lips catch it if it creeps out of the grip during fast swings.

    Args:
        robot: The robot description (finger and lip geometry).
        radius: Target radius [m].

    Raises:
        PlanningError: When the cylinder is too small for the lips to retain it or too large to
            fit between the open fingers.
    """
    d = robot.lip_depth
    if radius <= d:
        raise PlanningError(f"target radius {radius:.3f} m is too small for the {d} m lips")
    open_gap = robot.finger_gap(robot.finger_lower) - 2.0 * d
    if 2.0 * radius >= open_gap - 0.01:
        raise PlanningError(
            f"target diameter {2 * radius:.3f} m does not fit the open fingers ({open_gap:.3f} m)"
        )
    return robot.lip_x - math.sqrt(2.0 * radius * d - d * d) - LIP_CLEARANCE


def gripper_pose(position: npt.ArrayLike, yaw: float = 0.0) -> FloatArray:
    """gripper_link pose at ``position`` [m], level, pointing at heading ``yaw`` [rad]."""
    T = np.eye(4)
    c, s = math.cos(yaw), math.sin(yaw)
    T[:3, :3] = ((c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0))
    T[:3, 3] = np.asarray(position, dtype=np.float64)
    return T


def radial_yaw(position: npt.ArrayLike) -> float:
    """Heading [rad] of the horizontal line from the joint_1 axis through ``position`` [m]."""
    p = np.asarray(position, dtype=np.float64)
    return math.atan2(p[1], p[0])


#: Headings tried for a pick, off the radial, when the radial one collides [deg]: the nearest
#: first, to either side (the wrist twists more the farther off the radial it points).
GRASP_HEADINGS = tuple(s * d for d in range(5, 50, 5) for s in (1, -1))

#: Largest |q4| and |q6| of an untwisted wrist [rad].
UNTWISTED = math.pi / 2


def pick_poses(
    robot: RobotDescription,
    motion: MotionConfig,
    target_position: npt.ArrayLike,
    target_radius: float,
    yaw: float | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """gripper_link poses (4x4) of a pick: standoff, grasp, lift and lifted standoff.

    Args:
        robot: The arm (its fingers set how deep the grasp is, :func:`grasp_depth`).
        motion: The standoff, lift and grasp height offsets.
        target_position: Observed target centre [m].
        target_radius: Target radius [m].
        yaw: Heading the gripper points in [rad] (None: radial, :func:`radial_yaw`).
    """
    m = motion
    p = np.asarray(target_position, dtype=np.float64)
    depth = grasp_depth(robot, target_radius)
    if yaw is None:
        yaw = radial_yaw(p)
    u = np.array([math.cos(yaw), math.sin(yaw), 0.0])  # approach direction
    up = np.array([0.0, 0.0, 1.0])
    grasp = p - depth * u + m.grasp_dz * up
    T_grasp = gripper_pose(grasp, yaw)
    T_standoff = gripper_pose(grasp - m.standoff * u, yaw)
    T_lift = gripper_pose(grasp + m.lift * up, yaw)
    T_back = gripper_pose(grasp - m.standoff * u + m.lift * up, yaw)
    return T_standoff, T_grasp, T_lift, T_back


def release_pose(
    robot: RobotDescription, motion: MotionConfig, drop_xy: npt.ArrayLike, target_radius: float
) -> FloatArray:
    """gripper_link pose that holds the target's centre above ``drop_xy`` [m] at release (at
    ``motion.drop_height``, pointing radially)."""
    xy = np.asarray(drop_xy, dtype=np.float64)
    yaw = math.atan2(xy[1], xy[0])
    depth = grasp_depth(robot, target_radius)
    p = np.array([xy[0] - depth * math.cos(yaw), xy[1] - depth * math.sin(yaw), motion.drop_height])
    return gripper_pose(p, yaw)


def _untwisted(kin: Kinematics, T: FloatArray, q_ref: FloatArray) -> list[tuple[float, FloatArray]]:
    """The IK solutions for ``T`` inside the limits whose wrist is untwisted (|q4| and |q6|
    below 90 deg), joint 1 at its 2 pi twin nearest ``q_ref``, each with its cost from ``q_ref``
    (weighed as :meth:`Kinematics.nearest` weighs), cheapest first."""
    g = kin.geometry
    ref = np.asarray(q_ref, dtype=np.float64)
    out = []
    for sol in kin.inverse(T):
        q = sol.copy()
        k = np.round((ref[0] - q[0]) / (2 * math.pi))
        for twin in q[0] + 2 * math.pi * (k + np.arange(-1, 2)):
            if g.lower[0] <= twin <= g.upper[0] and abs(twin - ref[0]) < abs(q[0] - ref[0]):
                q[0] = twin
        q[3], q[5] = math.remainder(q[3], 2 * math.pi), math.remainder(q[5], 2 * math.pi)
        if abs(q[3]) > UNTWISTED or abs(q[5]) > UNTWISTED:
            continue
        if np.any(q < g.lower) or np.any(q > g.upper):
            continue
        out.append((float(np.sum(((q - ref) / g.v_max) ** 2)), q))
    return sorted(out, key=lambda c: c[0])


def untwisted_nearest(kin: Kinematics, T: FloatArray, q_ref: FloatArray) -> FloatArray:
    """The IK solution for ``T`` whose wrist is untwisted (|q4| and |q6| below 90 deg) nearest
    ``q_ref`` (weighed as :meth:`Kinematics.nearest` weighs), else ``kin.nearest``'s.

    A level gripper reached with the wrist turned half a turn (q6 = +-pi, the arm over its head)
    points the fingers up halfway through a move from a level pose: a held part would fall.

    Raises:
        UnreachablePoseError: When no solution lies inside the limits.
    """
    found = _untwisted(kin, T, q_ref)
    return found[0][1] if found else kin.nearest(T, q_ref)


def branch_solutions(kin: Kinematics, T: FloatArray, q_ref: FloatArray) -> list[FloatArray]:
    """The IK solutions for ``T`` a pick tries in turn: the one nearest ``q_ref``
    (:meth:`Kinematics.nearest`) first, then every other solution inside the limits with an
    untwisted wrist (joint 1 at its twin nearest ``q_ref``), nearest first.

    From a ready pose facing away (q1 = 180 deg) the nearest solution of a standoff straight
    ahead can flip the wrist on the straight line in; another branch reaches it plainly.

    Raises:
        UnreachablePoseError: When no solution lies inside the limits.
    """
    first = kin.nearest(T, q_ref)
    others = [q for _, q in _untwisted(kin, T, q_ref) if not np.allclose(q, first, atol=1e-9)]
    return [first, *others]
