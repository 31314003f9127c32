"""``python -m kr210_sim demos``: the scripted expert's episodes as an imitation-learning dataset.

The file is HDF5 in the layout of robosuite's demonstrations as robomimic stores them (the
layout robomimic trains from and other tools convert), written with h5py::

    data/                      attrs: total (samples in all demos), env_args (JSON: env_name,
                               type, env_kwargs), episodes, successes
    data/demo_<i>/             attrs: num_samples, seed, success, slot, target (JSON)
        obs/observation        (n, 20) float64   the observation before each action
        obs/achieved_goal      (n, 3)
        obs/desired_goal       (n, 3)
        next_obs/...           the observation after each action
        actions                (n, A) float32    in the environment's Box(-1, 1)
        rewards                (n,)   float64
        dones                  (n,)   uint8      1 on the step that ended the episode
        states                 (n, S) float64    MuJoCo's full physics state before each action
                                                 (``mj_getState``, ``mjSTATE_FULLPHYSICS``)
    mask/successful            names of the demos that succeeded

Episode ``i`` is ``env.reset(seed=seed + i)``: replaying its actions on a fresh environment made
with ``env_args`` gives the same states (the environment is deterministic). HDF5 rather than
Minari: Minari keeps datasets in its own local store and pulls in its own dependency tree,
while one h5py file in a known layout is what robomimic-style loaders read directly.
"""

from __future__ import annotations

import json
import logging
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from kr210_sim.errors import ConfigError
from kr210_sim.util.outputs import atomic_path, check_writable
from kr210_sim.util.progress import ProgressLine, bar

import mujoco  # isort: skip

log = logging.getLogger(__name__)

OBS_KEYS = ("observation", "achieved_goal", "desired_goal")


@dataclass(frozen=True, slots=True)
class DemoSummary:
    """What :func:`record_demos` wrote.

    Attributes:
        path: The HDF5 file.
        episodes: Episodes recorded.
        successes: Episodes that succeeded.
        samples: Steps in all episodes.
    """

    path: Path
    episodes: int
    successes: int
    samples: int


def _h5py() -> Any:
    try:
        import h5py
    except ImportError:
        raise ConfigError(
            "demos needs h5py and gymnasium: pip install '.[gym]' (in a clone)"
        ) from None
    return h5py


def record_demos(
    path: Path | str,
    episodes: int,
    seed: int = 0,
    control: str = "joint",
    randomize: bool = False,
    progress: TextIO | None = None,
) -> DemoSummary:
    """Run the scripted expert for ``episodes`` episodes and write them to ``path``.

    Args:
        path: HDF5 file to write (atomically: an interrupted recording leaves no file).
        episodes: Episodes (>= 1).
        seed: Episode ``i`` is reset with ``seed + i``.
        control: The environment's control mode (``joint`` or ``cartesian``).
        randomize: Randomise the cylinders.
        progress: Stream for the progress line (None: stderr).

    Raises:
        ConfigError: A bad argument, an unwritable path, or h5py / gymnasium missing.
    """
    if isinstance(episodes, bool) or not isinstance(episodes, int) or episodes < 1:
        raise ConfigError(f"episodes must be a whole number >= 1, got {episodes!r}")
    h5py = _h5py()
    out = check_writable(path)
    try:
        import gymnasium as gym

        from kr210_sim.envs import ENV_ID, ScriptedExpert
    except ImportError:
        raise ConfigError("demos needs gymnasium: pip install '.[gym]' (in a clone)") from None

    kwargs: dict[str, Any] = {"control": control, "randomize": randomize}
    env = gym.make(ENV_ID, **kwargs)
    expert = ScriptedExpert(env)
    model = env.unwrapped.model  # type: ignore[attr-defined]
    data = env.unwrapped.cell.data  # type: ignore[attr-defined]
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    line = ProgressLine(progress or sys.stderr)
    successes = samples = 0
    with atomic_path(out, ".hdf5") as tmp, h5py.File(tmp, "w") as f:
        group = f.create_group("data")
        names = []
        for i in range(episodes):
            obs, info = env.reset(seed=seed + i)
            rec: dict[str, list[Any]] = {"actions": [], "rewards": [], "dones": [], "states": []}
            o_list: dict[str, list[Any]] = {k: [] for k in OBS_KEYS}
            n_list: dict[str, list[Any]] = {k: [] for k in OBS_KEYS}
            while True:
                mujoco.mj_getState(model, data, state, spec)
                rec["states"].append(state.copy())
                action = expert(obs)
                for k in OBS_KEYS:
                    o_list[k].append(obs[k])
                obs, reward, terminated, truncated, info = env.step(action)
                for k in OBS_KEYS:
                    n_list[k].append(obs[k])
                rec["actions"].append(action)
                rec["rewards"].append(reward)
                rec["dones"].append(terminated or truncated)
                if terminated or truncated:
                    break
            name = f"demo_{i}"
            demo = group.create_group(name)
            for k in OBS_KEYS:
                demo.create_dataset(f"obs/{k}", data=np.asarray(o_list[k]))
                demo.create_dataset(f"next_obs/{k}", data=np.asarray(n_list[k]))
            demo.create_dataset("actions", data=np.asarray(rec["actions"], dtype=np.float32))
            demo.create_dataset("rewards", data=np.asarray(rec["rewards"], dtype=np.float64))
            demo.create_dataset("dones", data=np.asarray(rec["dones"], dtype=np.uint8))
            demo.create_dataset("states", data=np.asarray(rec["states"]))
            success = bool(info["is_success"])
            target = env.unwrapped.target  # type: ignore[attr-defined]
            demo.attrs.update(
                num_samples=len(rec["actions"]),
                seed=seed + i,
                success=success,
                slot=target.slot,
                target=json.dumps({**asdict(target), "spec": asdict(target.spec)}),
            )
            successes += success
            samples += len(rec["actions"])
            if success:
                names.append(name)
            if line.due() or i + 1 == episodes:
                line.show(f"demos {bar((i + 1) / episodes)} {i + 1}/{episodes} episodes")
        line.end()
        env_args = {"env_name": ENV_ID, "type": "gymnasium", "env_kwargs": kwargs}
        group.attrs.update(
            total=samples,
            env_args=json.dumps(env_args),
            episodes=episodes,
            successes=successes,
        )
        f.create_dataset("mask/successful", data=np.array(names, dtype="S"))
    env.close()
    return DemoSummary(out, episodes, successes, samples)
