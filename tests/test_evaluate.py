"""Monte-Carlo evaluation: pure seeded episodes, worker-count independence, interruption."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import kr210_sim.evaluate as ev
from kr210_sim.cli import main
from kr210_sim.errors import ConfigError
from kr210_sim.evaluate import EvalConfig, episode_seed, evaluate, wilson_interval
from kr210_sim.report import strip_wall


def test_episode_seeds_are_fixed_and_distinct() -> None:
    seeds = [episode_seed(0, i) for i in range(1000)]
    assert len(set(seeds)) == 1000
    assert seeds[:3] == [episode_seed(0, 0), episode_seed(0, 1), episode_seed(0, 2)]
    assert episode_seed(1, 0) != episode_seed(0, 0)
    assert all(0 <= s < 2**32 for s in seeds)


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


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"episodes": 0}, "episodes must be"),
        ({"workers": 0}, "workers must be"),
        ({"seed": -1}, "seed must be"),
    ],
)
def test_config_is_checked(kwargs: dict[str, int], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        EvalConfig(**kwargs)  # type: ignore[arg-type]


def test_same_results_whatever_the_worker_count() -> None:
    one, _ = evaluate(EvalConfig(episodes=6, seed=3, randomize=True, workers=1))
    two, _ = evaluate(EvalConfig(episodes=6, seed=3, randomize=True, workers=2))
    assert json.dumps(strip_wall(one), sort_keys=True) == json.dumps(
        strip_wall(two), sort_keys=True
    )
    assert [e["episode"] for e in one["episodes"]] == list(range(6))
    assert one["summary"]["successes"] == 6
    assert one["execution"]["workers"] == 1 and two["execution"]["workers"] == 2


def test_an_episode_replays_as_a_one_cycle_run(tmp_path: Path) -> None:
    report, _ = evaluate(EvalConfig(episodes=2, seed=5, randomize=True))
    episode = report["episodes"][1]
    out = tmp_path / "replay.json"
    argv = ["run", "--cycles", "1", "--seed", str(episode["seed"]), "--randomize"]
    assert main([*argv, "--report", str(out)]) == 0
    (cycle,) = json.loads(out.read_text())["cycles"]
    assert cycle["slot"] == episode["slot"]
    assert cycle["cycle_time"] == episode["cycle_time"]
    assert cycle["target"]["spec"]["mass"] == pytest.approx(episode["target"]["mass"], abs=1e-6)


def test_failures_are_counted_with_example_seeds() -> None:
    records = [
        {"episode": i, "seed": 100 + i, "slot": 1, "success": i % 3 != 0,
         "reason": None if i % 3 else "grasp_missed", "detail": "d" if i % 3 == 0 else "",
         "cycle_time": 4.0 + i / 10, "creep_mm": 1.0, "max_tracking_error_deg": 0.3,
         "grasp_attempts": 2 if i == 1 else 1}
        for i in range(9)
    ]  # fmt: skip
    s = ev.summarise_episodes(records)
    assert (s["episodes"], s["successes"]) == (9, 6)
    f = s["failures"]["grasp_missed"]
    assert f["count"] == 3 and [e["seed"] for e in f["examples"]] == [100, 103, 106]
    assert s["retries_recovered"] == 1
    assert s["cycle_time"]["max"] == pytest.approx(4.8)


def test_ctrl_c_writes_the_episodes_done_and_exits_130(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    ctrl_c_on_call: Callable[[Callable[..., Any], int], Callable[..., Any]],
) -> None:
    monkeypatch.setattr(ev, "run_episode", ctrl_c_on_call(ev.run_episode, 3))
    report = tmp_path / "eval.json"
    assert main(["evaluate", "--episodes", "5", "--report", str(report)]) == 130
    data = json.loads(report.read_text())
    assert data["interrupted"] is True
    assert [e["episode"] for e in data["episodes"]] == [0, 1]
    assert data["summary"]["episodes"] == 2
    assert "interrupted after 2 episodes" in capsys.readouterr().err


def test_an_evaluation_of_another_cell_runs_in_it_and_says_how_to_replay() -> None:
    from kr210_sim.cells import PUBLISHED_CELL

    cell = PUBLISHED_CELL.parent / "grid_4x2.toml"
    report, interrupted = evaluate(EvalConfig(episodes=2, seed=1, cell=cell))
    assert not interrupted and report["summary"]["successes"] == 2
    assert report["config"]["cell"] == str(cell)
    assert report["config"]["replay"].endswith(f"--cell {cell}")
    assert all(1 <= e["slot"] <= 8 for e in report["episodes"])
    assert {e["target"]["position"][1] for e in report["episodes"]} <= {0.15, -0.95}
