"""KR210 inverse kinematics, worked the way the pick-and-place exercise asks (numpy only).

Check it:  python -m kr210_sim ik-check --ik examples/ik_dh.py:solve
Run it:    python -m kr210_sim run --ik examples/ik_dh.py:solve --cycles 10

The recipe:

1. Write the modified DH table (Craig's convention) from the URDF.
2. Turn the requested gripper_link pose (URDF frame) into the DH gripper frame: the two differ
   by a fixed rotation, R_corr = Rz(pi) * Ry(-pi/2).
3. Axes 4, 5 and 6 meet in one point, the wrist centre, d_G = 0.303 m behind the gripper along
   the DH gripper z axis. Its position depends on theta1..3 only: solve those by geometry.
4. With theta1..3 known, R0_3 is known, so R3_6 = R0_3^T * R0_6 and theta4..6 follow from its
   entries (an Euler-angle problem).
5. Each pose has up to 8 answers (shoulder front/back x elbow up/down x wrist flip). Keep the
   ones inside the joint limits and return the one nearest q_ref, so the arm never flips.
"""

from __future__ import annotations

import math

import numpy as np

pi = math.pi

# ---------------------------------------------------------------------------- 1. the DH table
# Lengths [m] read off the URDF joint origins.
D1 = 0.33 + 0.42  # base to joint_2 height: joint_1 origin z + joint_2 origin z
A1 = 0.35  # joint_2 is 0.35 m in front of the joint_1 axis
A2 = 1.25  # link_2: joint_2 to joint_3
A3 = -0.054  # the forearm's drop from joint_3 to joint_4 (easy to forget: it is small!)
D4 = 0.96 + 0.54  # joint_3 to the wrist centre along the forearm: joint_4 x + joint_5 x
DG = 0.193 + 0.11  # wrist centre to gripper_link: joint_6 x + gripper_joint x

# Rows i = 1..6 and G: alpha(i-1) [rad], a(i-1) [m], d(i) [m], offset added to q(i) [rad]
DH = [
    (0.0, 0.0, D1, 0.0),
    (-pi / 2, A1, 0.0, -pi / 2),  # theta2 = q2 - pi/2
    (0.0, A2, 0.0, 0.0),
    (-pi / 2, A3, D4, 0.0),
    (pi / 2, 0.0, 0.0, 0.0),
    (-pi / 2, 0.0, 0.0, 0.0),
    (0.0, 0.0, DG, 0.0),  # the gripper frame G (fixed)
]

# Joint limits [rad] from the URDF (lower, upper).
LIMITS = np.radians([(-185, 185), (-45, 85), (-210, 65), (-350, 350), (-125, 125), (-350, 350)])


def dh_transform(alpha: float, a: float, d: float, theta: float) -> np.ndarray:
    """Modified DH: T = Rx(alpha) * Tx(a) * Rz(theta) * Tz(d)."""
    ca, sa, ct, st = math.cos(alpha), math.sin(alpha), math.cos(theta), math.sin(theta)
    return np.array(
        [
            [ct, -st, 0.0, a],
            [st * ca, ct * ca, -sa, -sa * d],
            [st * sa, ct * sa, ca, ca * d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def rot_y(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# ------------------------------------------------------- 2. DH gripper frame vs URDF gripper_link
# R0_G(DH) = R0_gripper_link(URDF) * R_CORR: the DH gripper frame has z along the fingers, the
# URDF gripper_link has x along them.
R_CORR = rot_z(pi) @ rot_y(-pi / 2)


def forward(q: np.ndarray) -> np.ndarray:
    """gripper_link pose (URDF frame) from the DH chain: use it to check your answers."""
    T = np.eye(4)
    for i, (alpha, a, d, offset) in enumerate(DH):
        theta = (q[i] if i < 6 else 0.0) + offset
        T = T @ dh_transform(alpha, a, d, theta)
    T[:3, :3] = T[:3, :3] @ R_CORR.T  # back from the DH gripper frame to gripper_link
    return T


def r0_3(q1: float, q2: float, q3: float) -> np.ndarray:
    """Rotation of DH frame 3 in the base frame."""
    T = np.eye(4)
    for (alpha, a, d, offset), q in zip(DH[:3], (q1, q2, q3), strict=True):
        T = T @ dh_transform(alpha, a, d, q + offset)
    return T[:3, :3]


# ------------------------------------------------------------- 3. the wrist centre: theta1..3
def arm_solutions(wc: np.ndarray) -> list[tuple[float, float, float]]:
    """(q1, q2, q3) that put the wrist centre at ``wc``: up to 4 (shoulder x elbow)."""
    side_a = math.hypot(D4, A3)  # joint_3 to the wrist centre (1.501 m)
    side_c = A2  # joint_2 to joint_3
    sag = math.atan2(-A3, D4)  # the wrist centre sits this far below the forearm line (0.036)
    out = []
    for shoulder in (+1, -1):  # front: joint_2 between the base axis and the wrist; back
        q1 = math.atan2(wc[1], wc[0]) + (0.0 if shoulder > 0 else pi)
        r = shoulder * math.hypot(wc[0], wc[1]) - A1  # horizontal distance joint_2 -> wrist
        s = wc[2] - D1  # vertical distance joint_2 -> wrist
        side_b = math.hypot(r, s)
        # Law of cosines: angle a at joint_2, angle b at joint_3 of the triangle.
        cos_a = (side_b**2 + side_c**2 - side_a**2) / (2 * side_b * side_c)
        cos_b = (side_a**2 + side_c**2 - side_b**2) / (2 * side_a * side_c)
        if abs(cos_a) > 1.0 or abs(cos_b) > 1.0:
            continue  # the wrist centre is out of reach on this side
        angle_a, angle_b = math.acos(cos_a), math.acos(cos_b)
        elevation = math.atan2(s, r)
        # Elbow up: link_2 leans back from the line to the wrist by angle a.
        out.append((q1, pi / 2 - elevation - angle_a, pi / 2 - angle_b - sag))
        # Elbow down: the mirror image of the triangle.
        out.append((q1, pi / 2 - elevation + angle_a, angle_b - 3 * pi / 2 - sag))
    return out


# ------------------------------------------------------------------ 4. the wrist: theta4..6
def wrist_solutions(R3_6: np.ndarray, q4_ref: float) -> list[tuple[float, float, float]]:
    """(q4, q5, q6) with R3_6 = R3_4 R4_5 R5_6: two wrist flips, or one line at q5 = 0.

    R3_6 = [[c4c5c6 - s4s6, -c4c5s6 - s4c6, -c4s5],
            [        s5c6,         -s5s6,     c5],
            [-s4c5c6 - c4s6, s4c5s6 - c4c6,  s4s5]]
    """
    sin5 = math.hypot(R3_6[0, 2], R3_6[2, 2])
    if sin5 < 1e-9:  # wrist singularity: only q4 + q6 is defined; keep q4 where it is
        q46 = math.atan2(-R3_6[0, 1], R3_6[0, 0])
        return [(q4_ref, 0.0, q46 - q4_ref)]
    out = []
    for flip in (+1, -1):
        q5 = math.atan2(flip * sin5, R3_6[1, 2])
        q4 = math.atan2(flip * R3_6[2, 2], -flip * R3_6[0, 2])
        q6 = math.atan2(-flip * R3_6[1, 1], flip * R3_6[1, 0])
        out.append((q4, q5, q6))
    return out


# ----------------------------------------------------------------- 5. pick the nearest answer
def nearest_twin(angle: float, ref: float, lo: float, hi: float) -> float | None:
    """The angle +- k 2pi inside [lo, hi] closest to ``ref``, or None."""
    best = None
    for k in range(-2, 3):
        a = angle + 2 * pi * k
        if lo - 1e-9 <= a <= hi + 1e-9 and (best is None or abs(a - ref) < abs(best - ref)):
            best = a
    return best


def solve(T: np.ndarray, q_ref: np.ndarray) -> list[float] | None:
    """Joint angles [rad] that put gripper_link at pose ``T`` (4x4, base frame), nearest
    ``q_ref``; None when no answer lies inside the joint limits."""
    R0_G = T[:3, :3] @ R_CORR  # 2. requested orientation of the DH gripper frame
    wc = T[:3, 3] - DG * R0_G[:, 2]  # 3. the wrist centre
    best, best_cost = None, math.inf
    for q1, q2, q3 in arm_solutions(wc):
        R3_6 = r0_3(q1, q2, q3).T @ R0_G  # 4.
        for q4, q5, q6 in wrist_solutions(R3_6, q_ref[3]):
            q = [
                nearest_twin(a, r, lo, hi)
                for a, r, (lo, hi) in zip((q1, q2, q3, q4, q5, q6), q_ref, LIMITS, strict=True)
            ]
            if any(a is None for a in q):
                continue  # this branch breaks a joint limit
            cost = sum((a - r) ** 2 for a, r in zip(q, q_ref, strict=True))
            if cost < best_cost:
                best, best_cost = q, cost
    return best


if __name__ == "__main__":  # a quick self-check against the DH forward kinematics
    rng = np.random.default_rng(0)
    worst = 0.0
    for _ in range(1000):
        q_true = rng.uniform(LIMITS[:, 0], LIMITS[:, 1])
        T = forward(q_true)
        q = solve(T, q_true)
        worst = max(worst, float(np.abs(forward(np.array(q)) - T).max()))
    print(f"worst pose error over 1000 random poses: {worst:.2e}")
