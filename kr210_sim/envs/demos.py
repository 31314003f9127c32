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
from kr210_sim.util.interrupts import check as check_interrupt
from kr210_sim.util.interrupts import deferred, signal_name
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
        interrupted: The interrupt (Ctrl-C, SIGTERM) that stopped the recording early, or None:
            the file then holds the episodes that finished.
    """

    path: Path
    episodes: int
    successes: int
    samples: int
    interrupted: KeyboardInterrupt | None = None


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

    Ctrl-C or SIGTERM stops the recording after the episode in progress is dropped: the file
    holds the episodes that finished (``data`` attribute ``interrupted`` true), as ``run`` and
    ``evaluate`` keep theirs, and the summary's ``interrupted`` is set.

    Args:
        path: HDF5 file to write (atomically: it appears whole, or not at all).
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
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= 2**63 - episodes:
        raise ConfigError(
            f"seed must be a whole number from 0 to 2**63 - episodes (each episode's seed is "
            f"stored as a 64-bit integer in the dataset), got {seed!r}"
        )
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
        done = 0
        interrupted: KeyboardInterrupt | None = None
        for i in range(episodes):
            try:
                check_interrupt()
                run = _run_episode(env, expert, model, data, state, spec, seed + i)
                with deferred():  # an episode is written whole (an interrupt lands after)
                    success, steps = _write_episode(group, f"demo_{i}", run, seed + i, env)
                    successes += success
                    samples += steps
                    done += 1
                    if success:
                        names.append(f"demo_{i}")
            except KeyboardInterrupt as exc:  # keep what finished, as run and evaluate do
                interrupted = exc
                line.end()
                sys.stderr.write(
                    f"kr210_sim: interrupted after {done} episodes ({signal_name(exc)}); "
                    "writing those\n"
                )
                break
            if line.due() or i + 1 == episodes:
                line.show(f"demos {bar((i + 1) / episodes)} {i + 1}/{episodes} episodes")
        line.end()
        env_args = {"env_name": ENV_ID, "type": "gymnasium", "env_kwargs": kwargs}
        try:
            with deferred():  # the file's index is written whole, then the file committed
                group.attrs.update(
                    total=samples,
                    env_args=json.dumps(env_args),
                    episodes=done,
                    successes=successes,
                    interrupted=interrupted is not None,
                )
                f.create_dataset("mask/successful", data=np.array(names, dtype="S"))
        except KeyboardInterrupt as exc:
            interrupted = interrupted or exc
    env.close()
    return DemoSummary(out, done, successes, samples, interrupted)


def _write_episode(
    group: Any, name: str, run: tuple[Any, ...], seed: int, env: Any
) -> tuple[bool, int]:
    """Write one episode's datasets and attributes as ``group/name``; returns (success,
    steps)."""
    rec, o_list, n_list, info = run
    demo = group.create_group(name)
    for k in OBS_KEYS:
        demo.create_dataset(f"obs/{k}", data=np.asarray(o_list[k]))
        demo.create_dataset(f"next_obs/{k}", data=np.asarray(n_list[k]))
    demo.create_dataset("actions", data=np.asarray(rec["actions"], dtype=np.float32))
    demo.create_dataset("rewards", data=np.asarray(rec["rewards"], dtype=np.float64))
    demo.create_dataset("dones", data=np.asarray(rec["dones"], dtype=np.uint8))
    demo.create_dataset("states", data=np.asarray(rec["states"]))
    success = bool(info["is_success"])
    target = env.unwrapped.target
    demo.attrs.update(
        num_samples=len(rec["actions"]),
        seed=seed,
        success=success,
        slot=target.slot,
        target=json.dumps({**asdict(target), "spec": asdict(target.spec)}),
    )
    return success, len(rec["actions"])


def _run_episode(
    env: Any, expert: Any, model: Any, data: Any, state: Any, spec: Any, seed: int
) -> tuple[dict[str, list[Any]], dict[str, list[Any]], dict[str, list[Any]], dict[str, Any]]:
    """One episode of the expert from ``env.reset(seed=seed)``: its records (actions, rewards,
    dones, states), observations, next observations and last info."""
    obs, info = env.reset(seed=seed)
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
            return rec, o_list, n_list, info
