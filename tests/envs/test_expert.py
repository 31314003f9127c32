"""The scripted expert drives the environment through its own action space to success."""

from __future__ import annotations

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from kr210_sim.cell.load import model_for  # noqa: E402
from kr210_sim.cell.toml import PUBLISHED_CELL  # noqa: E402
from kr210_sim.envs import ENV_ID, ScriptedExpert  # noqa: E402
from kr210_sim.envs.pick_place import PickPlaceEnv  # noqa: E402
from kr210_sim.errors import ConfigError  # noqa: E402
from kr210_sim.score.scoring import in_bin  # noqa: E402
from kr210_sim.sim.session import episode_runner  # noqa: E402

CELLS = PUBLISHED_CELL.parent

pytestmark = pytest.mark.slow


def _episode(env: gym.Env, expert: ScriptedExpert, seed: int) -> tuple[bool, int, float]:
    obs, _ = env.reset(seed=seed)
    steps, worst = 0, 0.0
    cell = env.unwrapped.cell
    while True:
        action = expert(obs)
        assert env.action_space.contains(action)
        worst = max(worst, float(np.abs(action).max()))
        obs, reward, terminated, truncated, info = env.step(action)
        steps += 1
        if terminated or truncated:
            break
        assert reward == -1.0  # no success before the episode ends on it
    if info["is_success"]:  # and it is one, read off the physics, not off the info
        position = cell.target_pose()[0]
        assert in_bin(position, env.unwrapped.bin)
        assert np.array_equal(position, obs["achieved_goal"])
        mass = env.unwrapped.target.spec.mass  # it cannot leave: too little energy to rise
        assert position[2] + cell.target_energy() / (mass * 9.81) < env.unwrapped.bin.rim
        assert not any(cell.finger_target_contacts()) and info["robot_cell_contacts"] == 0
        assert reward == 0.0 and terminated and not truncated
    return bool(info["is_success"]), steps, worst


@pytest.mark.parametrize("control", ["joint", "cartesian"])
def test_the_expert_succeeds_in_both_control_modes(control: str) -> None:
    env = gym.make(ENV_ID, control=control, randomize=True)
    expert = ScriptedExpert(env)
    results = [_episode(env, expert, seed) for seed in (0, 1, 2)]
    assert [ok for ok, _, _ in results] == [True, True, True]
    assert all(steps < env.unwrapped.max_steps for _, steps, _ in results)
    if control == "cartesian":  # the plan's swings are faster than the box: it runs at the limit
        assert max(w for _, _, w in results) == pytest.approx(1.0)


def test_the_expert_plans_the_cycle_the_runner_plans() -> None:
    """Same planner, collision checks, detours and drop spot: in the column cell, whose swings
    need detours, the expert's plan for an episode is the run's plan for its seed."""
    cell = CELLS / "column.toml"
    env = PickPlaceEnv(scene=cell)
    expert = ScriptedExpert(env)
    obs, _ = env.reset(seed=4)
    expert(obs)
    runner = episode_runner(4, model=model_for(cell=cell))
    sample, k = runner.start_cycle(1, runner.slot_for_cycle())
    assert sample == env.target
    ran = runner.plan_cycle(runner.observe_target(k), sample.spec)
    plan = expert.plan
    assert plan is not None and plan.detours == ran.detours > 0
    assert plan.drop_spot == ran.drop_spot and plan.drop_xy == ran.drop_xy
    assert [s.phase for s in plan.steps] == [s.phase for s in ran.steps]
    for a, b in zip(plan.moves, ran.moves, strict=True):
        assert a.kind == b.kind and np.array_equal(a.q_end, b.q_end)


def test_the_expert_needs_the_pick_place_environment() -> None:
    with pytest.raises(ConfigError, match="ScriptedExpert drives kr210_sim/PickPlace-v0"):
        ScriptedExpert(gym.make("CartPole-v1"))
