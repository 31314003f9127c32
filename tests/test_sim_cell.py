"""The control loop's one-command step: the same physics as tracking a constant-velocity ramp."""

from __future__ import annotations

import numpy as np

from kr210_sim.cell.load import load_model
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.sim.cell import Cell, ramp


def test_step_command_steps_exactly_as_track_on_a_ramp() -> None:
    q0 = np.asarray(MotionConfig().ready_q)
    qd = np.array([0.5, -0.2, 0.3, 0.4, -0.6, 1.0])
    cells = [Cell(load_model()), Cell(load_model())]
    for cell in cells:
        cell.reset(q0)
        cell.close_gripper()
    cells[0].track(ramp(q0, qd, 0.04))
    cells[1].step_command(q0, qd, 20)
    a, b = cells[0].data, cells[1].data
    assert a.time == b.time and np.isclose(a.time, 0.04)
    assert np.array_equal(a.qpos, b.qpos) and np.array_equal(a.qvel, b.qvel)
    assert np.array_equal(a.ctrl, b.ctrl)
    moved = cells[1].q - q0
    assert np.all(np.sign(moved) == np.sign(qd))  # the arm follows the command


def test_ramp_samples_a_constant_velocity_line() -> None:
    traj = ramp(np.zeros(6), np.arange(6.0), 0.5)
    q, qd, qdd = traj.sample_many(np.array([0.0, 0.25, 0.5, 1.0]))
    assert np.allclose(q[:, 5], [0.0, 1.25, 2.5, 2.5])  # held at the end
    assert np.allclose(qd[:3], np.arange(6.0)) and not qd[3].any() and not qdd.any()
    assert np.allclose(traj.sample(0.25)[0], q[1])
