"""Your KR210 inverse kinematics: fill in ``solve`` (numpy only is enough).

Check it:  python -m kr210_sim ik-check --ik examples/ik_template.py:solve
Run it:    python -m kr210_sim run --ik examples/ik_template.py:solve --cycles 10

The contract:

* ``T`` is a (4, 4) float64 homogeneous transform: the pose of the URDF ``gripper_link`` frame
  in the base frame (x towards the shelf, z up). At q = 0 it is the identity rotation with the
  origin at (2.153, 0, 1.946).
* ``q_ref`` is the arm's current joint state, shape (6,) [rad]. On straight-line moves it is
  the answer you gave for the previous pose, 1 cm back.
* Return six joint angles [rad] (a list, tuple or array), or ``None`` if the pose cannot be
  reached inside the joint limits.

What the harness checks, with its own forward kinematics, before the arm moves:
position error <= 1 mm, orientation error <= 1 mrad, every joint inside its limits (an angle
outside them is replaced by its 2 pi twin when that twin is inside), and on straight lines no
joint moving more than 0.1 rad from ``q_ref`` (a wrist flip or a 2 pi jump there fails the cycle).

Hints, in the order the exercise takes them:

1. Write the modified DH table from the URDF joint origins (see the published table in
   assets/kr210/README.md, or assets/kr210/kr210.urdf). Do not forget a3 = -0.054 m between
   joints 3 and 4.
2. The DH gripper frame is not gripper_link: R0_G(DH) = R(gripper_link) * Rz(pi) * Ry(-pi/2).
3. Wrist centre: wc = p - 0.303 * (DH gripper z axis) = p - 0.303 * T[:3, 0].
4. theta1 = atan2(wc_y, wc_x); theta2 and theta3 from the triangle joint_2 - joint_3 - wrist
   centre (law of cosines; the forearm side is sqrt(1.5^2 + 0.054^2) long and sits
   atan2(0.054, 1.5) below the forearm line).
5. R3_6 = R0_3(theta1..3)^T * R0_G; read theta4..6 off its entries with atan2.
6. There are up to 8 answers; return the one inside the limits nearest ``q_ref``. At q5 = 0
   only q4 + q6 is defined: keep q4 = q_ref[3].

A worked solution is in examples/ik_dh.py: try yours first.
"""

from __future__ import annotations

import numpy as np


def solve(T: np.ndarray, q_ref: np.ndarray) -> list[float] | None:
    """Joint angles [rad] that put gripper_link at pose ``T``, nearest ``q_ref``; or None."""
    p = T[:3, 3]  # gripper_link position [m]
    R = T[:3, :3]  # gripper_link orientation
    wc = p - 0.303 * R[:, 0]  # noqa: F841 (the wrist centre: yours to use)
    raise NotImplementedError("your inverse kinematics goes here")
