"""``demos``: the scripted expert's episodes as an HDF5 dataset in robomimic's layout."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")
gym = pytest.importorskip("gymnasium")

from kr210_sim.cli import main  # noqa: E402

pytestmark = pytest.mark.slow


def test_demos_writes_a_replayable_dataset(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "demos.hdf5"
    argv = ["demos", "--episodes", "2", "--seed", "5", "--control", "cartesian", "--out", str(out)]
    assert main(argv) == 0
    assert "episodes   2 (2 succeeded)" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demos.hdf5"]
    with h5py.File(out) as f:
        data = f["data"]
        env_args = json.loads(data.attrs["env_args"])
        assert env_args == {
            "env_name": "kr210_sim/PickPlace-v0",
            "type": "gymnasium",
            "env_kwargs": {"control": "cartesian", "randomize": False},
        }
        assert list(f["mask/successful"][()]) == [b"demo_0", b"demo_1"]
        demo = data["demo_1"]
        n = int(demo.attrs["num_samples"])
        assert data.attrs["total"] == n + data["demo_0"].attrs["num_samples"]
        assert demo.attrs["seed"] == 6 and demo.attrs["success"]
        assert demo["actions"].shape == (n, 5) and demo["actions"].dtype == np.float32
        assert demo["obs/observation"].shape == (n, 20) and demo["next_obs/achieved_goal"].shape
        assert demo["dones"][-1] == 1 and demo["dones"][:-1].sum() == 0
        assert demo["rewards"][-1] == 0.0 and np.all(demo["rewards"][:-1] == -1.0)
        assert np.array_equal(demo["obs/observation"][1:], demo["next_obs/observation"][:-1])
        actions, first_obs = demo["actions"][()], demo["obs/observation"][0]
        last_obs = demo["next_obs/observation"][-1]
    # Replaying the actions on a fresh environment reproduces the episode.
    env = gym.make(env_args["env_name"], **env_args["env_kwargs"])
    obs, _ = env.reset(seed=6)
    assert np.array_equal(obs["observation"], first_obs)
    for a in actions:
        obs, _, terminated, _, info = env.step(a)
    assert terminated and info["is_success"] and np.array_equal(obs["observation"], last_obs)


def test_demos_refuses_an_unwritable_path(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["demos", "--episodes", "1", "--out", str(blocker / "d.hdf5")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("kr210_sim: error: ") and len(err.strip().splitlines()) == 1


def test_an_interrupted_recording_keeps_the_episodes_that_finished(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    ctrl_c_on_call: Any,
) -> None:
    from kr210_sim.envs import demos

    monkeypatch.setattr(demos, "_run_episode", ctrl_c_on_call(demos._run_episode, 3))
    out = tmp_path / "demos.hdf5"
    assert main(["demos", "--episodes", "5", "--out", str(out)]) == 130
    captured = capsys.readouterr()
    assert "episodes   2 (interrupted)" in captured.out
    assert "interrupted after 2 episodes (SIGINT); writing those" in captured.err
    with h5py.File(out) as f:
        data = f["data"]
        assert sorted(data.keys()) == ["demo_0", "demo_1"]
        assert data.attrs["episodes"] == 2 and bool(data.attrs["interrupted"])
        assert data.attrs["total"] == sum(data[d].attrs["num_samples"] for d in data)


def test_a_seed_beyond_64_bits_is_refused_before_any_episode(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "demos.hdf5"
    assert main(["demos", "--episodes", "2", "--seed", str(2**64), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "seed must be a whole number from 0 to 2**63 - episodes" in err
    assert err.count("\n") == 1 and not out.exists()
