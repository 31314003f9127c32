"""The compiled single-pose IK (robot/_ik_native.c) against the pure-Python path (its
functions imported directly, so both are tested in one process) and the batch path."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest
from test_kinematics import _longer_link_2, _odd_limits, _same_solutions, hard_poses, out_of_reach

from kr210_sim.robot import ik_scalar
from kr210_sim.robot import kinematics as kin

native = pytest.importorskip("kr210_sim.robot._ik_native", reason="the C extension was not built")


def test_the_native_path_is_in_use_when_built() -> None:
    """An install that built the extension uses it (``make test`` and CI have a compiler)."""
    assert ik_scalar.NATIVE
    assert ik_scalar.inverse_one is native.inverse_one
    assert ik_scalar.nearest_one is native.nearest_one


def test_pure_ik_in_the_environment_takes_the_python_path() -> None:
    code = "from kr210_sim.robot import ik_scalar as s; print(s.NATIVE, s.inverse_one.__name__)"
    env = {**os.environ, "KR210_SIM_PURE_IK": "1"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.stdout.split() == ["False", "inverse_one_py"], out.stderr


def test_hypot_is_pythons() -> None:
    """rho and |sin q5| are math.hypot's floats (CPython's own algorithm, not libm's hypot)."""
    rng = np.random.default_rng(16)
    n = 200_000
    for scale in (1.0, 1e-3, 1e150, 1e-150, 1e-310):
        x = (rng.normal(size=n) * 10.0 ** rng.integers(-8, 8, n) * scale).tolist()
        y = (rng.normal(size=n) * scale).tolist()
        assert [native.hypot(a, b) for a, b in zip(x, y, strict=True)] == [
            math.hypot(a, b) for a, b in zip(x, y, strict=True)
        ]
    for a, b in ((0.0, 0.0), (-0.0, 3.0), (math.inf, math.nan), (math.nan, 1.0), (5e-324, 0.0)):
        want, got = math.hypot(a, b), native.hypot(a, b)
        assert got == want or (math.isnan(got) and math.isnan(want))


def _robots() -> dict[str, tuple[kin.Kinematics, int]]:
    """Kinematics and poses per kind: the committed one (6 kinds x 17,000 poses) and two
    descriptions with other limits and another geometry (6 x 3,000 each)."""
    return {
        "committed": (kin.committed(), 17_000),
        "odd limits": (kin.Kinematics(_odd_limits()), 3_000),
        "link_2 0.2 m longer": (kin.Kinematics(_longer_link_2(0.2)), 3_000),
    }


@pytest.mark.parametrize("robot", ["committed", "odd limits", "link_2 0.2 m longer"])
def test_native_and_python_paths_give_the_same_floats(robot: str) -> None:
    """Every solution and every nearest (reference near a solution, and at random) of the native
    path is the pure-Python path's, bit for bit, on random, singular, on-axis, limit, stretched
    and out-of-reach poses; the batch path gives the same solution sets."""
    k, n = _robots()[robot]
    g = k.geometry
    rng = np.random.default_rng(160)
    qs = hard_poses(rng, g, n)
    poses = {kind: k.forward(q) for kind, q in qs.items()}
    poses["out of reach"] = out_of_reach(rng, g, n)
    qs["out of reach"] = rng.uniform(g.lower, g.upper, size=(n, 6))
    total = found = 0
    for kind, T in poses.items():
        near = qs[kind] + rng.normal(0.0, 0.05, size=qs[kind].shape)
        anywhere = rng.uniform(g.lower, g.upper, size=qs[kind].shape)
        batch = k.inverse(T[:300])
        for i in range(len(T)):
            a, b = native.inverse_one(T[i], g), ik_scalar.inverse_one_py(T[i], g)
            assert a.shape == b.shape and a.tobytes() == b.tobytes(), (kind, i, a, b)
            for ref in (near[i], anywhere[i]):
                x, y = native.nearest_one(T[i], ref, g), ik_scalar.nearest_one_py(T[i], ref, g)
                assert x == y, (kind, i, ref, x, y)
            if i < 300:
                tol = 1e-7 if kind == "stretched" else 1e-9
                assert _same_solutions(a, batch[i], tol), (kind, i)
            found += len(a)
        total += len(T)
    assert total >= (100_000 if robot == "committed" else 18_000)
    assert found > total


def test_the_same_answer_for_every_kind_of_input() -> None:
    """Inputs the native path does not read itself (lists, float32, a q_ref list) go to the
    pure-Python path; Fortran-ordered and strided float64 poses are read in place."""
    g = kin.committed().geometry
    q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])
    T = kin.forward(q)
    want = ik_scalar.inverse_one_py(T, g)
    big = np.zeros((8, 8))
    big[::2, ::2] = T
    for pose in (T, T.tolist(), T.astype(np.float32), np.asfortranarray(T), big[::2, ::2]):
        a, b = native.inverse_one(pose, g), ik_scalar.inverse_one_py(pose, g)
        assert a.tobytes() == b.tobytes() and a.dtype == np.float64 and a.flags.writeable
        for ref in (q, q.tolist(), q.astype(np.float32), np.repeat(q, 2)[::2]):
            assert native.nearest_one(pose, ref, g) == ik_scalar.nearest_one_py(pose, ref, g)
    assert native.inverse_one(T, g).tobytes() == want.tobytes()
    far = np.eye(4)
    far[:3, 3] = [5.0, 0.0, 1.0]
    assert native.inverse_one(far, g).shape == (0, 6)
    assert native.nearest_one(far, q, g) == []


def _bad_poses() -> list[object]:
    T = kin.forward(np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4]))
    out: list[object] = []
    for i, j, v in ((0, 3, math.nan), (1, 1, math.inf), (3, 0, 0.1), (3, 3, 2.0), (0, 0, 1.01)):
        bad = T.copy()
        bad[i, j] = v
        out.append(bad)
    mirror = T.copy()
    mirror[:3, 2] *= -1.0  # a reflection
    slightly = T.copy()
    slightly[0, 0] += 5e-7  # past the quick test's 1e-7, inside ORTHO_TOL: accepted
    out += [mirror, slightly, np.eye(3), np.zeros((4, 4, 1)), "pose", [[1.0] * 4] * 4]
    return out


def _outcome(fn, *args) -> tuple[str, object]:  # type: ignore[no-untyped-def]
    try:
        r = fn(*args)
    except Exception as e:  # the type and message are what is compared
        return type(e).__name__, str(e)
    return "ok", r.tobytes() if isinstance(r, np.ndarray) else r


@pytest.mark.parametrize("pose", _bad_poses())
def test_bad_poses_raise_what_the_python_path_raises(pose: object) -> None:
    g = kin.committed().geometry
    q = np.zeros(6)
    assert _outcome(native.inverse_one, pose, g) == _outcome(ik_scalar.inverse_one_py, pose, g)
    assert _outcome(native.nearest_one, pose, q, g) == _outcome(
        ik_scalar.nearest_one_py, pose, q, g
    )


@pytest.mark.parametrize(
    "q_ref",
    [np.zeros(5), np.zeros((2, 6)), np.array([0, 0, math.nan, 0, 0, 0.0]), [0.0] * 5, "q",
     np.array([math.inf] * 6), [0, 0, 0, 0, 0, math.nan]],
)  # fmt: skip
def test_bad_references_raise_what_the_python_path_raises(q_ref: object) -> None:
    g = kin.committed().geometry
    T = kin.forward(np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4]))
    got = _outcome(native.nearest_one, T, q_ref, g)
    assert got == _outcome(ik_scalar.nearest_one_py, T, q_ref, g)
    assert got[0] == "ValueError"
    # a bad pose is named before a bad reference, as on the Python path
    bad = T.copy()
    bad[3, 3] = 2.0
    assert _outcome(native.nearest_one, bad, q_ref, g) == (
        "ValueError",
        "pose bottom row must be [0, 0, 0, 1]",
    )


def test_a_geometry_is_read_afresh_when_another_is_given() -> None:
    """The native constants cache holds one geometry: alternating two gives each its own."""
    a, b = kin.committed(), kin.Kinematics(_longer_link_2(0.3))
    q = np.array([0.3, 0.2, -0.3, 0.5, 0.6, -0.4])
    for _ in range(3):
        for k in (a, b):
            T = k.forward(q)
            got = native.inverse_one(T, k.geometry)
            assert got.tobytes() == ik_scalar.inverse_one_py(T, k.geometry).tobytes()
            assert min(np.abs(s - q).max() for s in got) < 1e-9
