"""Closed-form kinematics: golden figures, cross-checks and round-trip properties."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from kr210_sim.cell.spec import MotionConfig
from kr210_sim.errors import IkFailedError, Kr210SimError, UnreachablePoseError
from kr210_sim.plan.planner import Planner
from kr210_sim.plan.poses import gripper_pose
from kr210_sim.robot import kinematics as kin
from kr210_sim.robot.description import RobotDescription, load_robot
from kr210_sim.sandbox.user_ik import UserIk
from kr210_sim.score.metrics import gripper_tracking_error_mm
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.util.paths import URDF_PATH

G = kin.committed().geometry


def random_q(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.uniform(G.lower, G.upper, size=(n, 6))


def rot_angle(Ra: np.ndarray, Rb: np.ndarray) -> np.ndarray:
    """Angle [rad] of the rotation between Ra and Rb (batched)."""
    c = (np.trace(np.swapaxes(Ra, -1, -2) @ Rb, axis1=-2, axis2=-1) - 1.0) / 2.0
    return np.arccos(np.clip(c, -1.0, 1.0))


def test_geometry_comes_from_urdf() -> None:
    assert (G.d0 + G.h1, G.a1, G.a2) == pytest.approx((0.75, 0.35, 1.25))
    assert (G.a3x, G.a3z, G.dg) == pytest.approx((1.50, -0.054, 0.303))
    assert G.forearm == pytest.approx(math.sqrt(1.5**2 + 0.054**2))
    assert G.forearm_angle == pytest.approx(math.atan2(0.054, 1.5))
    assert np.degrees(G.upper[3]) == pytest.approx(350.0)


def test_published_zero_pose() -> None:
    T = kin.forward(np.zeros(6))
    assert T[:3, 3] == pytest.approx([2.153, 0.0, 1.946], abs=1e-12)
    assert np.allclose(T[:3, :3], np.eye(3), atol=1e-12)


def test_forward_matches_yourdfpy() -> None:
    import yourdfpy

    urdf = yourdfpy.URDF.load(str(URDF_PATH), load_meshes=False, build_collision_scene_graph=False)
    rng = np.random.default_rng(1)
    qs = random_q(rng, 300)
    ours = kin.forward(qs)
    names = [f"joint_{i}" for i in range(1, 7)]
    for q, T in zip(qs, ours, strict=True):
        cfg = dict(zip(names, q, strict=True))
        cfg.update(right_gripper_finger_joint=0.0, left_gripper_finger_joint=0.0)
        urdf.update_cfg(cfg)
        ref = urdf.get_transform("gripper_link", "base_link")
        assert np.abs(ref - T).max() < 1e-9


def test_round_trip_every_solution_and_original_found() -> None:
    rng = np.random.default_rng(2)
    qs = random_q(rng, 10_000)
    T = kin.forward(qs)
    sols = kin.inverse(T)
    assert sols.shape == (10_000, 8, 6)
    valid = ~np.isnan(sols).any(axis=-1)
    assert valid.any(axis=1).all()
    back = kin.forward(np.where(valid[..., None], sols, 0.0).reshape(-1, 6)).reshape(-1, 8, 4, 4)
    pos_err = np.linalg.norm(back[..., :3, 3] - T[:, None, :3, 3], axis=-1)[valid]
    target_R = np.broadcast_to(T[:, None, :3, :3], back[..., :3, :3].shape)
    ang_err = rot_angle(back[..., :3, :3], target_R)[valid]
    assert pos_err.max() <= 1e-9
    assert ang_err.max() <= 1e-7  # arccos near 1 loses precision: 1e-7 rad = |R - R'| ~ 1e-14
    rot_dev = np.abs(back[..., :3, :3] - T[:, None, :3, :3]).max(axis=(-2, -1))[valid]
    assert rot_dev.max() <= 1e-9
    # one solution equals the original q modulo 2 pi
    diff = np.abs(np.remainder(sols - qs[:, None] + np.pi, 2 * np.pi) - np.pi).max(axis=-1)
    assert (np.nanmin(diff, axis=1) < 1e-7).all()
    # every returned solution is inside the limits
    v = sols[valid]
    assert (v >= G.lower - 1e-9).all() and (v <= G.upper + 1e-9).all()


def test_single_and_batch_paths_agree() -> None:
    rng = np.random.default_rng(3)
    qs = random_q(rng, 500)
    T = kin.forward(qs)
    batch = kin.inverse(T)
    for i in range(len(qs)):
        single = kin.inverse(T[i])
        b = batch[i][~np.isnan(batch[i]).any(axis=1)]
        assert single.shape == b.shape
        assert np.allclose(single, b, atol=1e-9)
        assert np.abs(kin.forward(qs[i]) - T[i]).max() < 1e-12  # scalar vs batch forward


def hard_poses(rng: np.random.Generator, g: kin.Geometry, n: int) -> dict[str, np.ndarray]:
    """Joint states (n, 6) inside ``g``'s limits by kind: random, and the hard cases."""
    q = {kind: rng.uniform(g.lower, g.upper, size=(n, 6)) for kind in ("random", "wrist", "axis")}
    q["wrist"][:, 4] = 0.0  # wrist singular: only q4 + q6 is defined
    # wrist centre on joint 1's axis (q1 free): a1 + a2 sin q2 + L cos(q2 + q3 + phi) = 0
    q["axis"][:, 1] = rng.uniform(-0.3, 0.3, size=n)
    c = -(g.a1 + g.a2 * np.sin(q["axis"][:, 1])) / g.forearm
    q["axis"][:, 2] = -np.arccos(c) - g.forearm_angle - q["axis"][:, 1]
    limits = rng.uniform(g.lower, g.upper, size=(n, 6))
    for row in limits:  # two joints exactly at a limit
        j = rng.choice(6, size=2, replace=False)
        row[j] = np.where(rng.random(2) < 0.5, g.lower[j], g.upper[j])
    q["limits"] = limits
    q["stretched"] = rng.uniform(g.lower, g.upper, size=(n, 6))
    q["stretched"][:, 2] = -math.pi / 2 - g.forearm_angle  # forearm in line with link_2
    return q


def out_of_reach(rng: np.random.Generator, g: kin.Geometry, n: int) -> np.ndarray:
    """Poses (n, 4, 4) whose wrist centre is 5 cm to 2 m beyond the reach from either place
    joint 2 can take."""
    R = kin.forward(rng.uniform(g.lower, g.upper, size=(n, 6)))[:, :3, :3]
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    far = g.a1 + g.reach + rng.uniform(0.05, 2.0, size=(n, 1))
    T = np.repeat(np.eye(4)[None], n, axis=0)
    T[:, :3, :3] = R
    T[:, :3, 3] = np.array([0.0, 0.0, g.d0 + g.h1]) + u * far + g.dg * R[:, :, 0]
    return T


def _odd_limits() -> RobotDescription:
    """The committed description with limits that take the other branch of every wrapping rule
    (the committed limits take the first): joint 1 narrower than +-pi, joint 2 past -pi, joint 3
    inside +-pi, joint 4 off centre, joint 5 wider than +-pi, joint 6 from -100 to 270 deg."""
    robot = load_robot()
    lower = np.radians([-170.0, -200.0, -175.0, -120.0, -190.0, -100.0])
    upper = np.radians([170.0, 120.0, 65.0, 150.0, 190.0, 270.0])
    return dataclasses.replace(robot, q_lower=lower, q_upper=upper)


def _same_solutions(single: np.ndarray, batch_rows: np.ndarray, tol: float) -> bool:
    """Whether two solution sets are the same up to ``tol`` [rad] per joint (the batch path
    repeats a solution where two branches coincide: wrist straight, arm stretched; a joint at
    exactly +-pi may come out as either)."""
    rows = batch_rows[~np.isnan(batch_rows[:, 0])]
    if not len(single) or not len(rows):
        return len(single) == len(rows)
    d = np.abs(np.remainder(single[:, None, :] - rows[None, :, :] + np.pi, 2 * np.pi) - np.pi)
    close = (d <= tol).all(axis=2)
    return bool(close.any(axis=1).all() and close.any(axis=0).all())


@pytest.mark.parametrize("robot", [None, "odd limits"])
def test_single_pose_path_matches_the_batch_path_on_hard_poses(robot: str | None) -> None:
    """The single-pose path (pure math) and the batch path (numpy) are separate code: both give
    the same solutions on random poses, with the wrist straight, the wrist centre on joint 1's
    axis, joints at their limits, the arm stretched, and out of reach."""
    k = kin.committed() if robot is None else kin.Kinematics(_odd_limits())
    g = k.geometry
    rng = np.random.default_rng(33)
    poses = {kind: k.forward(q) for kind, q in hard_poses(rng, g, 300).items()}
    poses["out of reach"] = out_of_reach(rng, g, 300)
    for kind, T in poses.items():
        batch = k.inverse(T)
        found = 0
        tol = 1e-7 if kind == "stretched" else 1e-9  # acos near 1: q2, q3 to ~sqrt(eps)
        for i in range(len(T)):
            single = k.inverse(T[i])
            assert _same_solutions(single, batch[i], tol), (kind, i, single, batch[i])
            assert ((single >= g.lower - 1e-9) & (single <= g.upper + 1e-9)).all()
            found += len(single)
        assert (found == 0) == (kind == "out of reach"), kind


def _nearest_from_batch(k: kin.Kinematics, T: np.ndarray, ref: np.ndarray) -> list:
    """(cost, q) of every candidate of ``nearest``, built from the batch path's solutions with
    the documented rules (wrist straight: q4 kept at the reference's; joints 1, 4, 6 at their
    2 pi twin inside the limits closest to the reference; cost sum(((q - ref) / v_max)^2))."""
    g = k.geometry
    lo, hi = g.lower - kin.LIMIT_SLACK, g.upper + kin.LIMIT_SLACK
    out = []
    for cand in k.inverse(T[None])[0]:
        if np.isnan(cand[0]):
            continue
        cand = cand.copy()
        if abs(math.sin(cand[4])) < 1e-7:
            shift = ref[3] - cand[3]
            cand[3] = ref[3]
            cand[5] += -shift if math.cos(cand[4]) > 0 else shift
            twins = cand[5] + 2 * np.pi * np.arange(-3, 4)
            inside = twins[(twins >= lo[5]) & (twins <= hi[5])]
            if not len(inside):
                continue
            if not lo[5] <= cand[5] <= hi[5]:
                cand[5] = inside[np.argmin(np.abs(np.remainder(inside + np.pi, 2 * np.pi) - np.pi))]
        for j in (0, 3, 5):
            twins = cand[j] + 2 * np.pi * np.arange(-3, 4)
            twins = twins[(twins >= lo[j]) & (twins <= hi[j])]
            if len(twins):
                cand[j] = twins[np.argmin(np.abs(twins - ref[j]))]
        out.append((float((((cand - ref) / g.v_max) ** 2).sum()), cand))
    return out


@pytest.mark.parametrize("robot", [None, "odd limits"])
def test_nearest_is_the_cheapest_candidate_of_the_batch_path(robot: str | None) -> None:
    """``nearest`` searches its branches branch and bound (a shoulder or an arm that alone costs
    more than the best so far is skipped): it still returns the cheapest of all candidates."""
    k = kin.committed() if robot is None else kin.Kinematics(_odd_limits())
    g = k.geometry
    rng = np.random.default_rng(34)
    checked = 0
    for kind, qs in hard_poses(rng, g, 150).items():
        T = k.forward(qs)
        refs = [qs + rng.normal(0.0, 0.05, qs.shape), rng.uniform(g.lower, g.upper, qs.shape)]
        for i in range(len(T)):
            for ref in (refs[0][i], refs[1][i]):
                cands = sorted(_nearest_from_batch(k, T[i], ref), key=lambda c: c[0])
                q = k.nearest(T[i], ref)
                cost = float((((q - ref) / g.v_max) ** 2).sum())
                tol = 1e-7 if kind == "stretched" else 1e-9  # acos near 1: q2, q3 to ~sqrt(eps)
                assert cost == pytest.approx(cands[0][0], rel=tol, abs=1e-12), (kind, i)
                assert np.abs(k.forward(q) - T[i]).max() < 1e-9
                if len(cands) == 1 or cands[1][0] > cands[0][0] + 1e-6:  # a clear winner
                    np.testing.assert_allclose(q, cands[0][1], atol=tol)
                    checked += 1
    assert checked > 900  # of 1,500


def test_nearest_of_an_unreachable_pose_raises_on_every_path() -> None:
    T = np.eye(4)
    T[:3, 3] = [5.0, 0.0, 1.0]
    for pose in (T, T.tolist(), T.astype(np.float32)):
        with pytest.raises(UnreachablePoseError, match="out of reach"):
            kin.nearest(pose, np.zeros(6))
        assert kin.inverse(pose).shape == (0, 6)


def test_single_pose_inputs_of_any_array_like_give_the_same_answer() -> None:
    q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])
    T = kin.forward(q)
    want_inv, want_near = kin.inverse(T), kin.nearest(T, q)
    for pose in (T.tolist(), np.asfortranarray(T), T.copy()[::1, ::1]):
        np.testing.assert_array_equal(kin.inverse(pose), want_inv)
        np.testing.assert_array_equal(kin.nearest(pose, q.tolist()), want_near)
    out = kin.inverse(T)
    out[0, 0] = 99.0  # a fresh, writable array each call
    np.testing.assert_array_equal(kin.inverse(T), want_inv)
    assert kin.inverse(T).flags.writeable and kin.nearest(T, q).flags.writeable


def test_nearest_returns_reference_when_it_is_a_solution() -> None:
    rng = np.random.default_rng(4)
    for q in random_q(rng, 500):
        assert np.allclose(kin.nearest(kin.forward(q), q), q, atol=1e-7)


def test_nearest_never_jumps_a_full_turn_along_a_path() -> None:
    # Roll the gripper about its own x axis through +-pi and beyond: q6 must wind, not wrap.
    q = np.array([0.2, 0.1, -0.2, 0.0, 0.6, 0.0])
    T0 = kin.forward(q)
    prev = q
    for a in np.linspace(0.0, 1.8 * np.pi, 400):
        R_roll = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
        T = T0.copy()
        T[:3, :3] = T0[:3, :3] @ R_roll
        qn = kin.nearest(T, prev)
        assert np.abs(qn - prev).max() < 0.1
        prev = qn
    assert prev[5] > np.pi  # wound past +pi inside the +-350 deg limit


def test_wrist_singularity() -> None:
    q = np.array([0.3, 0.2, -0.1, 0.7, 0.0, -0.4])  # q5 = 0: only q4 + q6 is defined
    T = kin.forward(q)
    sols = kin.inverse(T)
    assert len(sols) >= 1 and not np.isnan(sols).any()
    for s in sols:
        assert np.abs(kin.forward(s) - T).max() < 1e-9
    n = kin.nearest(T, q)
    assert np.abs(kin.forward(n) - T).max() < 1e-9
    assert n[3] == pytest.approx(0.7)  # keeps the reference's q4
    assert n[5] == pytest.approx(-0.4)


def test_wrist_centre_on_joint_1_axis() -> None:
    # q2 = 0 and q3 chosen so the wrist centre sits on the joint_1 axis: q1 is then free.
    q3 = -math.acos(-G.a1 / G.forearm) - G.forearm_angle
    q = np.array([0.4, 0.0, q3, 0.3, 0.5, 0.2])
    T = kin.forward(q)
    w = T[:3, 3] - G.dg * T[:3, 0]
    assert np.hypot(w[0], w[1]) < 1e-12
    sols = kin.inverse(T)
    assert len(sols) >= 1 and not np.isnan(sols).any()
    for s in sols:
        assert np.abs(kin.forward(s) - T).max() < 1e-9
    n = kin.nearest(T, q)
    assert np.abs(kin.forward(n) - T).max() < 1e-9


def test_arm_stretched_boundary() -> None:
    # Elbow straight (wrist centre at full reach): one elbow branch, still exact.
    q = np.array([0.0, 0.5, -np.pi / 2 + G.forearm_angle, 0.0, 0.3, 0.0])
    T = kin.forward(q)
    sols = kin.inverse(T)
    assert len(sols) >= 1
    assert min(np.abs(s - q).max() for s in sols) < 1e-6
    for s in sols:
        assert np.abs(kin.forward(s) - T).max() < 1e-9


def test_unreachable_pose() -> None:
    T = np.eye(4)
    T[:3, 3] = [5.0, 0.0, 1.0]
    assert kin.inverse(T).shape == (0, 6)
    assert np.isnan(kin.inverse(T[None])).all()
    with pytest.raises(UnreachablePoseError, match=r"out of reach: .* 1\.\d+ m beyond"):
        kin.nearest(T, np.zeros(6))


def test_unreachable_by_joint_limit_names_the_joint() -> None:
    # Within reach, but pointing back at the base: the wrist would have to fold past 125 deg.
    T = np.eye(4)
    T[:3, :3] = np.diag([-1.0, -1.0, 1.0])
    T[:3, 3] = [1.8, 0.0, 1.5]
    assert kin.inverse(T).shape == (0, 6)
    with pytest.raises(UnreachablePoseError, match=r"joint limit: .*joint_5 by >= \d+\.\d deg"):
        kin.nearest(T, np.zeros(6))


def test_error_hierarchy() -> None:
    assert issubclass(UnreachablePoseError, Kr210SimError)
    assert issubclass(UnreachablePoseError, ValueError)


@pytest.mark.parametrize(
    ("pose", "message"),
    [
        (np.eye(3), "shape"),
        (np.full((4, 4), np.nan), "NaN"),
        (np.diag([1.0, 1.0, 2.0, 1.0]), "orthonormal"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), "reflection"),
        (np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [1, 0, 0, 1]], float), "bottom row"),
        (np.array([[1, 0, 0, np.inf], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]), "NaN or inf"),
        (np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, np.nan, 1]]), "NaN or inf"),
        (np.diag([1.0 + 2e-6, 1.0, 1.0, 1.0]), r"orthonormal \(\|R\^T R - I\| = 4\.00e-06"),
        (np.diag([-1.0, 1.0, 1.0, 1.0]), "reflection"),
    ],
)
def test_invalid_pose(pose: np.ndarray, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        kin.inverse(pose)
    if pose.shape == (4, 4):
        with pytest.raises(ValueError, match=message):
            kin.nearest(pose, np.zeros(6))
        # The batch path, large enough to be checked chunk by chunk on the thread pool, with the
        # bad pose last.
        batch = np.repeat(np.eye(4)[None], kin.CHUNK + 5, axis=0)
        batch[-1] = pose
        with pytest.raises(ValueError, match=message):
            kin.inverse(batch)


def test_single_and_batch_pose_checks_accept_the_same_poses() -> None:
    """The single-pose check takes a quicker test first (columns 1 and 2 orthonormal, column 3
    their cross product, to 1e-7) and the exact checks when that fails: the same poses pass and
    fail as on the batch path, for rotations off by 0 to 3e-6 and for reflections."""
    rng = np.random.default_rng(35)
    q = random_q(rng, 400)
    T = kin.forward(q)
    passed = failed = 0
    for i, scale in enumerate(np.repeat([0.0, 3e-8, 2e-7, 6e-7, 1.2e-6, 3e-6], 60)):
        pose = T[i].copy()
        pose[:3, :3] += scale * rng.uniform(-1.0, 1.0, size=(3, 3))
        R = pose[:3, :3]
        err = np.abs(R.T @ R - np.eye(3)).max()
        try:
            kin.inverse(pose[None])
            batch_ok = True
        except ValueError as exc:
            assert "orthonormal" in str(exc)
            batch_ok = False
        try:
            kin.inverse(pose)
            kin.nearest(pose, q[i])
            single_ok = True
        except ValueError as exc:
            assert "orthonormal" in str(exc)
            single_ok = False
        assert single_ok == batch_ok == (err <= 1e-6), (scale, err)
        passed, failed = passed + single_ok, failed + (not single_ok)
    assert passed > 150 and failed > 100
    for pose in T[:20]:
        pose = pose.copy()
        pose[:3, 2] *= -1.0  # the third column turned round: a reflection
        for call in (lambda p: kin.inverse(p), lambda p: kin.inverse(p[None])):
            with pytest.raises(ValueError, match="reflection"):
                call(pose)


def test_invalid_q() -> None:
    with pytest.raises(ValueError, match="shape"):
        kin.forward(np.zeros(5))
    with pytest.raises(ValueError, match="NaN"):
        kin.forward([0, 0, np.nan, 0, 0, 0])
    with pytest.raises(ValueError, match="q_ref"):
        kin.nearest(np.eye(4), np.zeros(3))
    bad = np.eye(4)[None].repeat(2, 0)
    bad[1, 0, 0] = 2.0
    with pytest.raises(ValueError, match="orthonormal"):
        kin.inverse(bad)


# -- the kinematics of the description given ---------------------------------------------------
Q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])


def _longer_link_2(extra: float) -> RobotDescription:
    """The committed description with link_2 (joint_2 to joint_3) ``extra`` [m] longer."""
    robot = load_robot()
    j3 = robot.joints["joint_3"]
    origin = j3.origin.copy()
    origin[2, 3] += extra
    return dataclasses.replace(
        robot, joints={**robot.joints, "joint_3": dataclasses.replace(j3, origin=origin)}
    )


def test_committed_description_keeps_todays_figures() -> None:
    ours = kin.Kinematics(load_robot())
    assert ours.geometry is G  # one description, read once
    golden = [
        [0.751795650393, -0.508633676091, 0.419636847282, 2.23040283168],
        [0.515917515459, 0.850049497261, 0.106042300279, 0.775802487224],
        [-0.410648776076, 0.136775859538, 0.901476537107, 1.946676543196],
        [0.0, 0.0, 0.0, 1.0],
    ]
    np.testing.assert_allclose(ours.forward(Q), golden, atol=1e-11)
    np.testing.assert_array_equal(ours.forward(Q), kin.forward(Q))
    np.testing.assert_array_equal(ours.nearest(kin.forward(Q), Q), kin.nearest(kin.forward(Q), Q))


def test_a_changed_link_length_changes_the_kinematics_by_exactly_that() -> None:
    longer = kin.Kinematics(_longer_link_2(0.1))
    g = longer.geometry
    assert g.a2 == pytest.approx(G.a2 + 0.1, abs=1e-15) and g != G
    assert (g.d0, g.h1, g.a1, g.a3x, g.a3z, g.dg) == (G.d0, G.h1, G.a1, G.a3x, G.a3z, G.dg)
    # link_2 turns about joint_2 by q2 from upright: the gripper moves by 0.1 m along it
    for q2 in (0.0, 0.5, -0.4):
        q = np.array([0.0, q2, 0.0, 0.0, 0.0, 0.0])
        moved = longer.forward(q)[:3, 3] - kin.forward(q)[:3, 3]
        np.testing.assert_allclose(moved, [0.1 * math.sin(q2), 0.0, 0.1 * math.cos(q2)], atol=1e-12)
    # inverse kinematics in the changed geometry: every solution reaches the pose in it
    T = longer.forward(Q)
    sols = longer.inverse(T)
    assert len(sols)
    np.testing.assert_allclose(
        longer.forward(sols), np.broadcast_to(T, (len(sols), 4, 4)), atol=1e-9
    )
    q = longer.nearest(T, Q)
    np.testing.assert_allclose(q, Q, atol=1e-9)
    assert np.linalg.norm(kin.forward(q)[:3, 3] - T[:3, 3]) > 0.05  # not the committed arm's


def test_planner_runner_and_scoring_use_the_robot_they_are_given() -> None:
    robot = _longer_link_2(0.1)
    longer = kin.Kinematics(robot)
    planner = Planner(robot, MotionConfig())
    q_ready = planner.ready_q
    T = gripper_pose((2.2, 0.4, 1.2), 0.3)
    q = planner.solve(T, q_ready, "test")
    np.testing.assert_allclose(longer.forward(q), T, atol=1e-9)
    assert np.linalg.norm(kin.forward(q)[:3, 3] - T[:3, 3]) > 0.05
    line = planner.lin("approach", q, gripper_pose((2.2, 0.4, 1.0), 0.3))
    np.testing.assert_allclose(longer.forward(line.q_end)[:3, 3], [2.2, 0.4, 1.0], atol=1e-9)
    # a user's IK is judged with the robot's own forward kinematics: the committed arm's
    # answers miss the longer arm's pose
    judged = Planner(robot, MotionConfig(), UserIk("committed:nearest", kin.nearest))
    with pytest.raises(IkFailedError, match="misses the pose by"):
        judged.solve(T, q_ready, "test")
    # the tracking error seen at the gripper: joint_2 off by d turns the gripper about the
    # joint_2 axis, a chord 2 r sin(d / 2) with r the gripper's distance from that axis
    d = 0.002
    q_meas = q + np.array([0.0, d, 0.0, 0.0, 0.0, 0.0])
    for k in (longer, kin.committed()):
        g = k.geometry
        c1, s1 = math.cos(q[0]), math.sin(q[0])
        p = k.forward(q)[:3, 3]
        joint_2 = np.array([g.a1 * c1, g.a1 * s1, g.d0 + g.h1])
        r = np.linalg.norm(np.cross(p - joint_2, [-s1, c1, 0.0]))
        err = gripper_tracking_error_mm(k, [q_meas], [q])
        assert err[0] == pytest.approx(2000.0 * r * math.sin(d / 2), rel=1e-9)
    # the runner plans, checks paths and scores with the description it is given
    runner = Runner(RunConfig(cycles=1), robot=robot)
    assert runner.planner.kinematics.robot is robot
    assert runner.planner.checker is not None and runner.planner.checker.kin.robot is robot


def test_package_code_takes_the_kinematics_of_its_robot() -> None:
    """No module of the package but the kinematics itself uses the committed URDF's module-level
    functions: each builds a :class:`Kinematics` from the description it was given."""
    import ast
    from pathlib import Path

    package = Path(kin.__file__).resolve().parents[1]
    bound = {"forward", "inverse", "nearest", "committed"}
    found = []
    for path in package.rglob("*.py"):
        if path.name == "kinematics.py" and path.parent.name == "robot":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module == "kr210_sim.robot.kinematics":
                found += [f"{path.name}: {a.name}" for a in node.names if a.name in bound]
            elif isinstance(node, ast.ImportFrom) and node.module == "kr210_sim.robot":
                found += [f"{path.name}: kinematics" for a in node.names if a.name == "kinematics"]
            elif isinstance(node, ast.Import):
                found += [
                    f"{path.name}: {a.name}" for a in node.names if a.name.endswith(".kinematics")
                ]
    assert len(list(package.rglob("*.py"))) > 50 and not found, found


def test_a_pose_just_out_of_reach_says_by_how_much_in_mm() -> None:
    """A wrist centre 0.4 mm beyond the reach read "0.000 m beyond the arm's reach"."""

    def pose(x: float) -> np.ndarray:
        T = np.eye(4)
        T[:3, 3] = [x, 0.0, 1.0]
        return T

    lo, hi = 2.0, 5.0  # reachable, unreachable: bisect the edge of the reach
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if kin.inverse(pose(mid)).shape[0] else (lo, mid)
    with pytest.raises(UnreachablePoseError) as exc:
        kin.nearest(pose(hi + 0.0004), np.zeros(6))
    assert re.search(r"is 0\.(39|40)\d* mm beyond the arm.s", str(exc.value)), str(exc.value)
