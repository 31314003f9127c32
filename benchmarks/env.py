"""The Gymnasium environment's speed and the scripted expert's success rate.

Run: ``python benchmarks/env.py [--steps N] [--episodes N] [--randomize]``. Prints figures only:

* policy steps per second (25 Hz steps, 20 physics steps each) of one environment with
  seeded random actions (and the share of it spent in ``mj_step``), and of
  ``gymnasium.make_vec(..., vectorization_mode="async")`` with 2 processes (steps of all
  environments together);
* the scripted expert's success rate over ``--episodes`` seeded episodes (seeds 0 ... N-1) in
  each control mode, its mean episode length, and the environment's steps per second under its
  actions (the expert's own planning time excluded).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

from kr210_sim.envs import ENV_ID, ScriptedExpert
from kr210_sim.envs.pick_place import POLICY_DT, SUBSTEPS

PHYSICS = [0.0]


def _timed_step(m: mujoco.MjModel, d: mujoco.MjData, _step: Any = mujoco.mj_step) -> None:
    t = time.perf_counter()
    _step(m, d)
    PHYSICS[0] += time.perf_counter() - t


def single_env(control: str, steps: int) -> tuple[float, float]:
    """Policy steps/s of one environment with seeded random actions, and the share of the wall
    time spent in ``mj_step`` (timed in a second pass)."""
    env = gym.make(ENV_ID, control=control, max_steps=10**9)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(steps)]
    walls = []
    for timed in (False, True):
        env.reset(seed=0)
        mujoco.mj_step = _timed_step if timed else _timed_step.__defaults__[0]  # type: ignore
        PHYSICS[0] = 0.0
        t = time.perf_counter()
        for a in actions:
            env.step(a)
        walls.append(time.perf_counter() - t)
    mujoco.mj_step = _timed_step.__defaults__[0]  # type: ignore
    env.close()
    return steps / walls[0], PHYSICS[0] / walls[1]


def vector_env(control: str, steps: int, n: int = 2) -> float:
    """Policy steps/s of ``n`` async environments together."""
    vec = gym.make_vec(
        ENV_ID, num_envs=n, vectorization_mode="async", control=control, max_steps=10**9
    )
    vec.reset(seed=list(range(n)))
    vec.action_space.seed(0)
    actions = [vec.action_space.sample() for _ in range(steps // n)]
    vec.step(actions[0])  # workers warmed up
    t = time.perf_counter()
    for a in actions:
        vec.step(a)
    wall = time.perf_counter() - t
    vec.close()
    return len(actions) * n / wall


def expert(
    control: str, episodes: int, randomize: bool
) -> tuple[int, float, dict[int, int], float]:
    """Successes, mean episode length [steps], failures per slot of the scripted expert, and the
    environment's steps/s under its actions (time in ``env.step`` only)."""
    env = gym.make(ENV_ID, control=control, randomize=randomize)
    policy = ScriptedExpert(env)
    ok, lengths, failed = 0, [], {}
    in_step = 0.0
    for seed in range(episodes):
        obs, info = env.reset(seed=seed)
        steps = 0
        while True:
            action = policy(obs)
            t = time.perf_counter()
            obs, _, terminated, truncated, info = env.step(action)
            in_step += time.perf_counter() - t
            steps += 1
            if terminated or truncated:
                break
        ok += int(info["is_success"])
        if not info["is_success"]:
            failed[info["slot"]] = failed.get(info["slot"], 0) + 1
        lengths.append(steps)
    return ok, float(np.mean(lengths)), failed, sum(lengths) / in_step


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--steps", type=int, default=2000, help="policy steps per speed figure")
    parser.add_argument("--episodes", type=int, default=100, help="expert episodes per mode")
    parser.add_argument("--randomize", action="store_true", help="randomised cylinders")
    args = parser.parse_args()
    print(f"policy step: {POLICY_DT * 1000:.0f} ms = {SUBSTEPS} physics steps")
    for control in ("joint", "cartesian"):
        rate, share = single_env(control, args.steps)
        print(
            f"{control:<9} 1 env      : {rate:7.0f} steps/s ({rate * POLICY_DT:5.1f}x real time, "
            f"physics {100 * share:3.0f} %)"
        )
        print(f"{control:<9} 2 async    : {vector_env(control, args.steps):7.0f} steps/s in all")
    if args.episodes:
        for control in ("joint", "cartesian"):
            t = time.perf_counter()
            ok, length, failed, rate = expert(control, args.episodes, args.randomize)
            print(
                f"expert {control:<9}: {ok}/{args.episodes} episodes succeeded "
                f"({100 * ok / args.episodes:.0f} %), mean {length:.0f} steps "
                f"({length * POLICY_DT:.1f} s), env {rate:.0f} steps/s under its actions, "
                f"{time.perf_counter() - t:.0f} s wall"
                + (f", failures by slot {failed}" if failed else "")
            )


if __name__ == "__main__":
    main()
