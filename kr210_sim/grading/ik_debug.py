"""The original exercise's debug script, ``IK_debug.py``: its three cases and what it printed.

Each case is a pose of gripper_link in base_link and the joint angles Gazebo showed for it
(:data:`IK_DEBUG_CASES`). ik-check tries them first (group ``ik_debug``, with Gazebo's angles as
``q_ref``) and, for each, gives what the script printed (:func:`ik_debug_rows`,
:func:`ik_debug_table`): the wrist-centre error, the six theta errors against Gazebo's angles
and the end-effector error.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import UnreachablePoseError
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.robot.quaternions import pose_matrix

FloatArray = npt.NDArray[np.float64]

#: The original exercise's ``IK_debug.py`` test cases: gripper_link's position [m] and
#: orientation (quaternion x, y, z, w) in base_link, and the joint angles Gazebo showed for the
#: pose [rad]. The angles are given to 0.01 rad: our forward kinematics of them misses the pose
#: by 7.1-8.4 mm and 0.28-0.38 deg, so a case passes on the pose, and the theta errors are
#: figures to read (several solutions reach a pose), as the script said of them.
IK_DEBUG_CASES = (
    (
        (2.16135, -1.42635, 1.55109),
        (0.708611, 0.186356, -0.157931, 0.661967),
        (-0.65, 0.45, -0.36, 0.95, 0.79, 0.49),
    ),
    (
        (-0.56754, 0.93663, 3.0038),
        (0.62073, 0.48318, 0.38759, 0.480629),
        (-0.79, -0.11, -2.33, 1.94, 1.14, -3.68),
    ),
    (
        (-1.3863, 0.02074, 0.90986),
        (0.01735, -0.2179, 0.9025, 0.371016),
        (-2.99, -0.12, 0.94, 4.06, 1.29, -4.12),
    ),
)


def ik_debug_poses(kin: Kinematics) -> list[tuple[int, FloatArray, FloatArray]]:
    """``(case number, T, Gazebo's angles [rad])`` of each of :data:`IK_DEBUG_CASES` that
    ``kin``'s robot can reach (all three for the KR210)."""
    found = []
    for i, (position, xyzw, gazebo) in enumerate(IK_DEBUG_CASES, start=1):
        T = pose_matrix(position, xyzw)
        try:
            kin.nearest(T, np.array(gazebo))
        except UnreachablePoseError:  # another robot's description: not its cases
            continue
        found.append((i, T, np.array(gazebo)))
    return found


def _xyz(d: FloatArray) -> dict[str, float]:
    return {
        "x": float(d[0]),
        "y": float(d[1]),
        "z": float(d[2]),
        "overall": float(np.linalg.norm(d)),
    }


def ik_debug_rows(kin: Kinematics, records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """What ``IK_debug.py`` printed for each of its cases, from the records of the check.

    Returns:
        One row per ``ik_debug`` record: ``case`` (1-3), Gazebo's angles ``gazebo_q`` and the
        answer ``q`` [rad] (2 pi twins moved nearest Gazebo's, as every answer is judged),
        ``wrist_centre_error_m`` and ``end_effector_error_m`` (``x``, ``y``, ``z`` as absolute
        differences, and ``overall``, the distance) of ``kin``'s forward kinematics of ``q``
        against the pose (the wrist centre is the pose's own: the script listed it rounded to
        4-5 digits, up to 0.07 mm off), ``theta_errors_rad`` (|q - gazebo_q| per joint),
        ``wall_time_s`` and ``problem``; without an answer the errors are None.
    """
    g = kin.geometry
    rows = []
    for r in records:
        if r["group"] != "ik_debug":
            continue
        case = int(r["name"].rsplit(" ", 1)[1])
        position, xyzw, gazebo = IK_DEBUG_CASES[case - 1]
        T = pose_matrix(position, xyzw)
        row: dict[str, Any] = {
            "case": case,
            "gazebo_q": list(gazebo),
            "q": r["q"],
            "wrist_centre_error_m": None,
            "theta_errors_rad": None,
            "end_effector_error_m": None,
            "wall_time_s": r["wall_time_s"],
            "problem": r["problem"],
        }
        if r["q"] is not None:
            q = np.asarray(r["q"], dtype=np.float64)
            Tq = kin.forward(q)
            wc = np.abs((Tq[:3, 3] - g.dg * Tq[:3, 0]) - (T[:3, 3] - g.dg * T[:3, 0]))
            row["wrist_centre_error_m"] = _xyz(wc)
            row["theta_errors_rad"] = [float(v) for v in np.abs(q - np.asarray(gazebo))]
            row["end_effector_error_m"] = _xyz(np.abs(Tq[:3, 3] - T[:3, 3]))
        rows.append(row)
    return rows


#: Width of a millimetre column and of a theta column [characters], each with at least one
#: space before its figure, however large (a miss of 100 m still keeps its columns apart).
MM_WIDTH = 10
THETA_WIDTH = 8


def _cell(value: float | None, width: int) -> str:
    """``value`` with 4 decimals right-aligned in ``width`` characters, always after a space
    ("-" for None)."""
    text = "-" if value is None else f"{value:.4f}"
    return " " + text.rjust(width - 1)


def ik_debug_table(rows: list[dict[str, Any]]) -> list[str]:
    """The lines of the ik-check table for :func:`ik_debug_rows` (none without rows): per case
    the wrist-centre error and the end-effector error in mm (x, y, z and the distance) and the
    six theta errors [rad], as ``IK_debug.py`` printed them; each figure after a space, so
    columns never run into each other."""
    if not rows:
        return []
    keys = ("x", "y", "z", "overall")

    def xyz(d: dict[str, float] | None) -> str:
        return "".join(_cell(None if d is None else 1000 * d[k], MM_WIDTH) for k in keys)

    axes = "".join(f"{k:>{MM_WIDTH}}" for k in keys)
    joints = "".join(f"{j:>{THETA_WIDTH}}" for j in range(1, 7))
    span, theta_span = 4 * MM_WIDTH, 6 * THETA_WIDTH
    out = [
        "  IK_debug.py's cases (theta errors against Gazebo's joint angles, given to 0.01 rad):",
        f"    {'case':<5}{'wrist centre error [mm]':>{span}}  {'theta errors [rad]':>{theta_span}}"
        f"  {'end effector error [mm]':>{span}}",
        f"    {'':<5}{axes}  {joints}  {axes}",
    ]
    for row in rows:
        th = row["theta_errors_rad"] or [None] * 6
        thetas = "".join(_cell(v, THETA_WIDTH) for v in th)
        out.append(
            f"    {row['case']:<5}{xyz(row['wrist_centre_error_m'])}  {thetas}"
            f"  {xyz(row['end_effector_error_m'])}"
        )
        if row["problem"]:
            out.append(f"         {row['problem']}")
    return out
