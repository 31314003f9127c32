"""The streaming summary: exact against NumPy, independent of arrival order, bounded."""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np
import pytest

from kr210_sim.eval.summary import EpisodeSummary, percentile, wilson_interval


@pytest.mark.parametrize(
    ("k", "n", "lo", "hi"),
    [
        (95, 100, 0.888250, 0.978456),
        (10, 10, 0.722467, 1.0),
        (0, 10, 0.0, 0.277533),
        (1000, 1000, 0.996173, 1.0),
    ],
)
def test_wilson_interval_golden(k: int, n: int, lo: float, hi: float) -> None:
    got = wilson_interval(k, n)
    assert got == pytest.approx((lo, hi), abs=1e-6)
    # Cross-check: the bounds are the roots of (p - x)^2 = z^2 x (1 - x) / n.
    z, p = 1.959964, k / n
    roots = sorted(np.roots([1 + z * z / n, -(2 * p + z * z / n), p * p]).real)
    assert got == pytest.approx(roots, abs=1e-9)


def test_histogram_percentiles_match_numpy() -> None:
    rng = np.random.default_rng(7)
    for trial in range(300):
        n = int(rng.integers(1, 60))
        # cycle times: multiples of a 2 ms tick, few distinct values, many repeats
        values = np.round(rng.integers(2000, 2000 + int(rng.integers(1, 40)), n) * 0.002, 6)
        histogram = Counter(values.tolist())
        for q in (0, 5, 50, 95, 99.9, 100, float(rng.uniform(0, 100))):
            want = float(np.percentile(values, q))
            assert percentile(histogram, q) == pytest.approx(want, abs=1e-12), (trial, q)


def _records(n: int, seed: int) -> list[dict[str, Any]]:
    rng = np.random.default_rng(seed)
    reasons = [None, None, None, "grasp_missed", "missed_bin", "unreachable"]
    out = []
    for i in range(n):
        reason = reasons[int(rng.integers(len(reasons)))]
        out.append(
            {
                "episode": i,
                "seed": 1000 + i,
                "slot": int(rng.integers(1, 10)),
                "success": reason is None,
                "reason": reason,
                "detail": "" if reason is None else f"d{i}",
                "cycle_time": round(float(rng.integers(2200, 2900)) * 0.002, 6),
                "creep_mm": float(rng.uniform(0, 5)),
                "max_tracking_error_deg": rng.uniform(0, 0.2, size=6).tolist(),  # per joint
                "grasp_attempts": int(rng.integers(1, 3)),
            }
        )
    return out


def _summarise(records: list[dict[str, Any]], cap: int = 1000) -> EpisodeSummary:
    s = EpisodeSummary(failed_records=cap)
    for r in records:
        s.add(r)
    return s


def test_summary_matches_a_direct_computation() -> None:
    records = _records(400, seed=1)
    s = _summarise(records).summary()
    ok = [r for r in records if r["success"]]
    times = np.array([r["cycle_time"] for r in ok])
    assert (s["episodes"], s["successes"]) == (400, len(ok))
    assert s["cycle_time"]["mean"] == round(float(np.mean(times)), 6)
    assert s["cycle_time"]["std"] == pytest.approx(float(np.std(times)), abs=1e-6)
    assert s["cycle_time"]["p50"] == round(float(np.median(times)), 6)
    assert s["cycle_time"]["p95"] == round(float(np.percentile(times, 95)), 6)
    assert s["cycle_time"]["max"] == float(times.max())
    gripped = [r["creep_mm"] for r in records if r["reason"] not in ("unreachable", "grasp_missed")]
    assert s["max_creep_mm"] == max(gripped)
    assert s["max_tracking_error_deg"] == max(max(r["max_tracking_error_deg"]) for r in records)
    assert s["grasp_retries"] == sum(r["grasp_attempts"] - 1 for r in records)
    assert s["retries_recovered"] == sum(r["grasp_attempts"] > 1 for r in ok)
    for reason, f in s["failures"].items():
        mine = [r for r in records if r["reason"] == reason]
        assert f["count"] == len(mine)
        assert [e["seed"] for e in f["examples"]] == [r["seed"] for r in mine[:5]]


def test_summary_does_not_depend_on_arrival_order() -> None:
    records = _records(300, seed=2)
    reference = _summarise(records, cap=7)
    rng = np.random.default_rng(3)
    for _ in range(20):
        shuffled = [records[i] for i in rng.permutation(len(records))]
        s = _summarise(shuffled, cap=7)
        assert s.summary() == reference.summary()
        assert s.failed_records() == reference.failed_records()


def test_failed_records_keep_the_lowest_episodes_up_to_the_cap() -> None:
    records = _records(200, seed=4)
    failed = [r for r in records if not r["success"]]
    s = _summarise(records[::-1], cap=10)
    assert s.failed == len(failed) > 10
    assert s.failed_records() == failed[:10]
    assert len(s._failed) == 10  # bounded, whatever the number of failures


def test_empty_summary() -> None:
    s = EpisodeSummary().summary()
    assert s["episodes"] == 0 and s["success_rate"] == 0.0
    assert s["success_rate_ci95"] == [0.0, 1.0]
    assert s["cycle_time"] == {"mean": 0.0, "std": 0.0, "p50": 0.0, "p95": 0.0, "max": 0.0}


def _perceived(n: int, seed: int) -> list[dict[str, Any]]:
    """Records of ``--perceive`` episodes: some not seen, some on the wrong object."""
    out = _records(n, seed)
    rng = np.random.default_rng(seed + 100)
    for r in out:
        seen = bool(rng.uniform() > 0.1)
        r["perception"] = {
            "label": "red_can",
            "seen": seen,
            "label_seen": "red_can" if seen else None,
            "right_object": seen and bool(rng.uniform() > 0.05),
            "position_error_mm": round(float(rng.gamma(2.0, 1.2)), 3) if seen else None,
            "axis_error_deg": 0.5 if seen else None,
            "confidence": 0.8,
            "clusters": [3],
            "looks": int(rng.integers(1, 3)),
            "reason": "",
            "cpu_time_ms": round(float(rng.uniform(30, 90)), 3),
            "wall_look_ms": 120.0,
        }
    return out


def test_perception_summary_matches_a_direct_computation_in_any_order() -> None:
    from kr210_sim.eval.summary import PerceptionSummary

    records = _perceived(300, seed=5)
    p = _summarise(records).summary()["perception"]
    blocks = [r["perception"] for r in records]
    errors = np.array([b["position_error_mm"] for b in blocks if b["seen"]])
    right = sum(b["right_object"] for b in blocks)
    assert (p["episodes"], p["recognised"]) == (300, right)
    assert p["recognition_rate"] == right / 300
    assert p["recognition_rate_ci95"] == [round(v, 6) for v in wilson_interval(right, 300)]
    assert p["not_seen"] == sum(not b["seen"] for b in blocks) > 0
    assert p["second_looks"] == sum(b["looks"] > 1 for b in blocks)
    assert p["position_error_mm"]["median"] == pytest.approx(float(np.median(errors)), abs=1e-6)
    assert p["position_error_mm"]["p95"] == pytest.approx(np.percentile(errors, 95), abs=1e-6)
    assert p["position_error_mm"]["max"] == float(errors.max())
    cpu = [b["cpu_time_ms"] for b in blocks]
    assert p["cpu_time_ms"]["mean"] == pytest.approx(float(np.mean(cpu)), rel=1e-12)
    assert p["cpu_time_ms"]["max"] == max(cpu)
    rng = np.random.default_rng(6)
    for _ in range(10):
        shuffled = [records[i] for i in rng.permutation(len(records))]
        assert _summarise(shuffled).summary()["perception"] == p
    # nothing seen: no errors to sum up, never a NaN
    blind = PerceptionSummary()
    blind.add({**blocks[0], "seen": False, "right_object": False, "position_error_mm": None})
    assert blind.summary()["position_error_mm"] is None


def test_a_summary_without_perception_has_no_perception_block() -> None:
    assert "perception" not in _summarise(_records(20, seed=8)).summary()
