"""A slow ROS-form server graded within a budget: a request of many poses may take what is left
of the student's time, not --ik-timeout per pose (a sympy server takes up to ~1.6 s a pose on
an idle machine, more under load), while outside a budget the limit per pose stands."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import ros_class

from kr210_sim.robot import kinematics
from kr210_sim.sandbox.ik_guard import assess
from kr210_sim.sandbox.ik_sandbox import IkSandbox, Limits, SandboxStop

KIN = kinematics.committed()
Q = np.array([[0.1 * i, 0.2, -0.1, 0.3, 0.5, 0.1] for i in range(4)])
POSES = [kinematics.forward(q) for q in Q]

#: 0.3 s a pose (asleep: the machine's load does not change it), above a 0.1 s limit per pose.
SLOW = ros_class.sleeping_server(0.3)


def test_a_slow_server_s_request_may_take_its_budget(tmp_path: Path) -> None:
    script = tmp_path / "IK_server.py"
    script.write_text(SLOW)
    limits = Limits(call_timeout=0.1)
    with IkSandbox(str(script), limits, capture=True, stop=True) as box:
        box.start()
        box.deadline = time.monotonic() + 30.0  # a graded student's budget
        answers = box.batch(POSES)
        one = box(POSES[0], Q[0])  # a request of one pose too (a run's standoff pose)
    assert all(assess(KIN, T, q, a).passed for T, q, a in zip(POSES, Q, answers, strict=True))
    assert assess(KIN, POSES[0], Q[0], one).passed
    with IkSandbox(str(script), limits, capture=True, stop=True) as box:  # no budget: per pose
        box.start()
        with pytest.raises(SandboxStop, match=r"no answer within 0\.4 s"):
            box.batch(POSES)
    with IkSandbox(str(script), limits, capture=True, stop=True) as box:
        box.start()
        with pytest.raises(SandboxStop, match=r"no answer within 0\.1 s"):
            box(POSES[0], Q[0])
