"""The control loop: the one-command step is the same physics as tracking a ramp; the per-tick
contact monitor sees every link strike every cell part."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.handles import CellHandles
from kr210_sim.cell.load import load_model
from kr210_sim.cell.spec import MotionConfig
from kr210_sim.sim.cell import PERTURB_ENV, Cell, TickLog, perturbation, ramp
from kr210_sim.util.paths import SCENE_PATH


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


def _forearm_point(model: mujoco.MjModel, q: np.ndarray) -> np.ndarray:
    """World position [m] of the middle of link_3's forearm tube at arm state ``q``."""
    data = mujoco.MjData(model)
    data.qpos[:6] = q
    mujoco.mj_kinematics(model, data)
    b = model.body("link_3").id
    return data.xpos[b] + data.xmat[b].reshape(3, 3) @ np.array([0.7, 0.0, -0.054])


def test_the_contact_monitor_catches_a_forearm_strike() -> None:
    """A 6 cm block of the shelf stands where the forearm swings (joint 1 turning): the
    per-tick monitor flags the ticks and names the forearm's colliders, nothing else."""
    q0 = np.asarray(MotionConfig().ready_q)
    p = _forearm_point(load_model(), q0)
    c, s = np.cos(0.4), np.sin(0.4)  # 0.4 rad ahead along the swing
    block = (c * p[0] - s * p[1], s * p[0] + c * p[1], p[2])
    spec = mujoco.MjSpec.from_file(str(SCENE_PATH))
    board = spec.geom("shelf_board_1")
    spec.body("shelf").add_geom(
        name="block",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=list(block),
        size=[0.03, 0.03, 0.03],
        contype=board.contype,
        conaffinity=board.conaffinity,
    )
    cell = Cell(spec.compile())
    cell.reset(q0)
    rec = TickLog()
    cell.track(ramp(q0, [0.5, 0, 0, 0, 0, 0], 1.0), rec, "swing")
    contact = rec.arrays()["env_contact"]
    assert contact.any() and not contact[:150].any()  # clear for the first 0.3 s
    assert all("block" in pair for pair in rec.contact_pairs), rec.contact_pairs
    struck = {name for pair in rec.contact_pairs for name in pair} - {"block"}
    assert "link_3_hull" in struck and all(name.startswith("link_3") for name in struck), struck


def test_every_moving_link_can_touch_every_cell_part() -> None:
    """The monitor is complete: each moving link has a collider that the contact filter pairs
    with every geom of the shelf, the bin and the floor, and no exclusion hides a pair."""
    model = load_model()
    h = CellHandles.from_model(model)
    ct, ca = model.geom_contype, model.geom_conaffinity
    excluded = {(int(s >> 16), int(s & 0xFFFF)) for s in model.exclude_signature}
    for link in ("link_1", "link_2", "link_3", "link_4", "link_5", "link_6", "gripper_link"):
        b = model.body(link).id
        colliders = [g for g in h.robot_geoms if model.geom_bodyid[g] == b]
        for env in (g for g in h.env_geoms if ct[g] or ca[g]):  # the parts' colliders
            e = int(model.geom_bodyid[env])
            assert (b, e) not in excluded and (e, b) not in excluded
            assert any((ct[g] & ca[env]) or (ct[env] & ca[g]) for g in colliders), (
                link,
                model.geom(env).name,
            )


def test_target_energy_is_translation_plus_rotation() -> None:
    """½ m v² + ½ ωᵀ I ω of a cylinder thrown and spun about a tilted axis (I from its size)."""
    model = load_model()
    cell = Cell(model)
    h = cell.handles
    a, dof, b = int(h.target_qpos[3]), int(h.target_dof[3]), int(h.target_bodies[3])
    cell.data.qpos[a : a + 7] = (0.0, 2.5, 2.0, 0.9, 0.3, 0.2, 0.25)
    mujoco.mju_normalize4(cell.data.qpos[a + 3 : a + 7])
    v, w = np.array([0.5, -1.0, 2.0]), np.array([3.0, -2.0, 1.0])  # w in the body frame
    cell.data.qvel[dof : dof + 6] = (*v, *w)
    m = float(model.body_mass[b])
    r, half = model.geom_size[h.target_geoms[3], :2]
    ixx = m * (3 * r * r + (2 * half) ** 2) / 12
    inertia = np.array([ixx, ixx, m * r * r / 2])
    expected = 0.5 * m * v.dot(v) + 0.5 * inertia.dot(w * w)
    assert cell.target_energy(3) == pytest.approx(expected, rel=1e-9)
    assert cell.target_energy(4) == 0.0


def test_the_perturbation_nudges_each_initial_state_by_at_most_its_size(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """KR210_SIM_PERTURB=1e-9 moves the arm's reset by a seeded draw in [-1e-9, 1e-9] per
    joint, the same draw each time; unset, the reset is the keyframe exactly; not a number, a
    one-line error that names the variable."""
    model = load_model(SCENE_PATH)
    monkeypatch.delenv(PERTURB_ENV, raising=False)
    assert perturbation() == 0.0
    plain = Cell(model)
    q0 = plain.q.copy()
    np.testing.assert_array_equal(q0, model.key_qpos[0][plain.handles.arm_qpos])

    monkeypatch.setenv(PERTURB_ENV, "1e-9")
    assert perturbation() == 1e-9
    first, second = Cell(model), Cell(model)
    offset = first.q - q0
    assert 0.0 < np.max(np.abs(offset)) <= 1e-9
    assert len(set(np.sign(offset))) == 2  # a draw, not a shift
    np.testing.assert_array_equal(first.q, second.q)  # seeded: reproducible
    first.reset()
    assert not np.array_equal(first.q, second.q)  # each reset draws anew
    assert np.max(np.abs(first.q - q0)) <= 1e-9

    for bad in ("tiny", "nan", "inf"):
        monkeypatch.setenv(PERTURB_ENV, bad)
        with pytest.raises(ValueError, match="KR210_SIM_PERTURB"):
            perturbation()
