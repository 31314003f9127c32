"""The Gymnasium environment: spaces, checker, determinism, the runner's sampler and scoring,
vectorised rewards, bad actions, async vector envs and rendering."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

import kr210_sim.envs  # noqa: E402
from kr210_sim.envs.pick_place import POLICY_DT, PickPlaceEnv  # noqa: E402
from kr210_sim.errors import ActionError, ConfigError  # noqa: E402
from kr210_sim.score.scoring import in_bin  # noqa: E402
from kr210_sim.sim.session import episode_runner  # noqa: E402
from kr210_sim.util.paths import SCENE_PATH  # noqa: E402

ENV_ID = kr210_sim.envs.ENV_ID


@pytest.fixture(scope="module")
def joint_env() -> PickPlaceEnv:
    return PickPlaceEnv(control="joint")


def test_registered_and_made_by_id() -> None:
    assert ENV_ID == "kr210_sim/PickPlace-v0" and ENV_ID in gym.registry
    env = gym.make(ENV_ID, control="cartesian", reward="dense")
    assert isinstance(env.unwrapped, PickPlaceEnv)
    assert env.action_space.shape == (5,) and env.unwrapped.reward_type == "dense"
    assert gym.make(ENV_ID).action_space.shape == (7,)


def test_a_scene_with_another_timestep_is_refused(tmp_path: Path) -> None:
    """A policy step is 20 physics steps of the scene's: a 1 ms scene would make it 20 ms."""
    xml = SCENE_PATH.read_text()
    meshes = (SCENE_PATH.parent / "../assets/kr210/meshes").resolve()
    xml = xml.replace('meshdir="../assets/kr210/meshes"', f'meshdir="{meshes}"')
    xml = xml.replace("<option ", '<option timestep="0.001" ', 1)
    scene = tmp_path / "fine.xml"
    scene.write_text(xml)
    with pytest.raises(ConfigError, match=r"timestep is 0.001 s; the environment needs 0.002"):
        PickPlaceEnv(scene=scene)


@pytest.mark.parametrize("control", ["joint", "cartesian"])
def test_check_env_passes(control: str) -> None:
    env = PickPlaceEnv(control=control, max_steps=20)
    check_env(env, skip_render_check=True)  # reset and step determinism included


def test_reset_spawns_what_run_spawns_for_the_seed(joint_env: PickPlaceEnv) -> None:
    for seed, randomize in ((0, False), (7, True), (123, True)):
        runner = episode_runner(seed, randomize=randomize)
        expected, _ = runner.start_cycle(1, runner.slot_for_cycle())
        _, info = joint_env.reset(seed=seed, options={"randomize": randomize})
        assert joint_env.target == expected and info["slot"] == expected.slot
        p, _ = joint_env.cell.target_pose()
        assert np.allclose(p[:2], expected.position[:2], atol=2e-3)  # settled on its board


def test_observation_layout(joint_env: PickPlaceEnv) -> None:
    obs, info = joint_env.reset(seed=1, options={"slot": 4})
    assert info["slot"] == 4 and info["is_success"] is False
    o = obs["observation"]
    assert o.shape == (20,) and joint_env.observation_space.contains(obs)
    assert np.allclose(o[:6], joint_env.ready_q, atol=1e-3) and np.abs(o[6:12]).max() < 0.05
    assert 0.1 < o[12] < 0.3  # the open finger gap [m]
    assert np.allclose(o[13:16], joint_env.cell.gripper_pose()[:3, 3])
    assert np.isclose(np.linalg.norm(o[16:20]), 1.0)
    slot4 = joint_env.layout.slots[3]
    assert np.allclose(obs["achieved_goal"][:2], slot4[:2], atol=2e-3)
    assert in_bin(obs["desired_goal"], joint_env.bin)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"control": "torque"}, "control must be 'joint' or 'cartesian', got 'torque'"),
        ({"reward": "shaped"}, "reward must be 'sparse' or 'dense', got 'shaped'"),
        ({"slot": 10}, "slot must be 0 (random) or 1-9, got 10"),
        ({"max_steps": 0}, "max_steps must be a whole number >= 1, got 0"),
        ({"render_mode": "human"}, "render_mode must be None or 'rgb_array', got 'human'"),
        ({"render_mode": "rgb_array", "camera": "top"}, "no camera 'top'; cameras: overview"),
        # a size no renderer takes is the size's fault, not OpenGL's, and said up front
        ({"render_mode": "rgb_array", "width": 480.5}, "frame size must be whole numbers"),
        ({"render_mode": "rgb_array", "width": 0}, "frame size must be positive, got 0x352"),
    ],
)
def test_bad_arguments(kwargs: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError) as exc:
        PickPlaceEnv(**kwargs)
    assert message in str(exc.value)


def test_bad_reset_options(joint_env: PickPlaceEnv) -> None:
    with pytest.raises(ConfigError, match="slot must be 0 \\(random\\) or 1-9, got 12"):
        joint_env.reset(options={"slot": 12})
    with pytest.raises(ConfigError, match="unknown reset option"):
        joint_env.reset(options={"colour": "red"})


@pytest.mark.parametrize(
    ("action", "message"),
    [
        ([np.nan, 0, 0, 0, 0, 0, 0], "action entry 0 is nan: every entry must be a finite number"),
        ([0, 0, 0, np.inf, 0, 0, 0], "action entry 3 is inf"),
        ([0, 0, 0, 0, 0, 1.5, 0], "action entry 5 is 1.5, outside the action space [-1, 1]"),
        ([0, 0, 0], "action must have shape (7,) for control='joint', got (3,)"),
        ("left", "action must be 7 numbers in [-1, 1], got str"),
        ([0.5 + 0.1j, 0, 0, 0, 0, 0, 0], "action must be 7 real numbers in [-1, 1], got complex"),
    ],
)
def test_bad_actions_never_reach_mujoco(joint_env: PickPlaceEnv, action: Any, message: str) -> None:
    joint_env.reset(seed=2)
    d = joint_env.cell.data
    before = (d.time, d.qpos.copy(), d.qvel.copy(), d.ctrl.copy(), joint_env.q_cmd.copy())
    with pytest.raises(ActionError) as exc:
        joint_env.step(np.asarray(action) if not isinstance(action, str) else action)
    assert message in str(exc.value) and "\n" not in str(exc.value)
    assert d.time == before[0]
    for now, then in zip((d.qpos, d.qvel, d.ctrl, joint_env.q_cmd), before[1:], strict=True):
        assert np.array_equal(now, then)
    joint_env.step(np.zeros(7))  # the episode goes on
    assert np.isclose(d.time, before[0] + POLICY_DT)


def test_compute_reward_is_vectorised_and_matches_success() -> None:
    env = PickPlaceEnv(control="joint")
    env.reset(seed=0)
    goal = env.goal
    offsets = np.array([[0, 0, 0], [0, 0, 0.47], [0.45, 0, 0], [0, 0, -0.48]])
    ag = goal + offsets
    info = {
        "lift": np.array([0.0, 0.0, 0.0, 0.0]),
        "released": np.ones(4, bool),
        "robot_cell_contacts": np.zeros(4, int),
    }
    r = env.compute_reward(ag, np.broadcast_to(goal, ag.shape), info)
    assert r.tolist() == [
        0.0,
        0.0,
        -1.0,
        -1.0,
    ]  # centre; under the rim; past a wall; under the floor
    infos = [
        {"lift": h, "released": True, "robot_cell_contacts": n}
        for h, n in ((0.0, 0), (0.01, 0), (0.0, 0), (0.0, 0))  # 2nd: could rise over the rim
    ]
    assert env.compute_reward(ag, goal, infos).tolist() == [0.0, -1.0, -1.0, -1.0]
    infos[0]["robot_cell_contacts"] = 3  # the arm hit the cell in that episode
    assert env.compute_reward(ag, goal, infos).tolist() == [-1.0, -1.0, -1.0, -1.0]
    single = env.compute_reward(
        goal, goal, {"lift": 0.0, "released": False, "robot_cell_contacts": 0}
    )
    assert single == -1.0 and isinstance(single, float)
    with pytest.raises(ConfigError, match="compute_reward needs the info"):
        env.compute_reward(goal, goal, {})
    dense = PickPlaceEnv(reward="dense")
    obs, info = dense.reset(seed=0)
    expected = -(np.linalg.norm(obs["achieved_goal"] - goal) + 0.5 * info["gripper_to_target"])
    _, reward, *_ = dense.step(np.zeros(7))
    assert reward < 0 and np.isclose(reward, expected, atol=0.02)


def _cylinder_into_the_bin(env: PickPlaceEnv) -> None:
    """Stand the episode's cylinder on the bin floor at the goal's x, y (test setup)."""
    c = env.cell
    a, dof = int(c.handles.target_qpos[c.active_target]), int(c.handles.target_dof[c.active_target])
    assert env.target is not None
    z = env.bin.floor_top + env.target.spec.length / 2 + 1e-3
    c.data.qpos[a : a + 7] = (*env.goal[:2], z, 1.0, 0.0, 0.0, 0.0)
    c.data.qvel[dof : dof + 6] = 0.0


@pytest.mark.parametrize("collide", [False, True])
def test_a_robot_cell_collision_is_never_a_success(collide: bool) -> None:
    """In one episode the arm is first driven into the floor (joint 2 at full speed: a real
    contact in the physics), in the other it holds still; then the cylinder is stood in the bin
    and left there. As ``run`` scores a cycle, the episode with the collision never succeeds,
    however long the cylinder lies in the bin."""
    env = PickPlaceEnv(control="joint", max_steps=60)
    env.reset(seed=0)
    dive = np.array([0, 1.0, 0, 0, 0, 0, -1.0]) if collide else np.r_[np.zeros(6), -1.0]
    infos = [env.step(dive)[-1] for _ in range(15)]
    assert any(i["robot_cell_contact"] for i in infos) is collide
    _cylinder_into_the_bin(env)
    hold = np.r_[np.zeros(6), -1.0]
    rewards = []
    for _ in range(15):
        obs, reward, terminated, _, info = env.step(hold)
        rewards.append(reward)
        infos.append(info)
        if terminated:
            break
    assert in_bin(obs["achieved_goal"], env.bin) and info["lift"] < 1e-3 and info["released"]
    if not collide:
        assert info["is_success"] and terminated and rewards[-1] == 0.0
        assert info["robot_cell_contacts"] == 0
        return
    assert info["robot_cell_contacts"] > 0
    assert not any(i["is_success"] for i in infos) and set(rewards) == {-1.0}
    assert env.compute_reward(obs["achieved_goal"], obs["desired_goal"], info) == -1.0
    assert env.reset(seed=0)[1]["robot_cell_contacts"] == 0  # counted per episode


def test_truncation_at_the_step_limit() -> None:
    env = PickPlaceEnv(max_steps=3)
    env.reset(seed=0)
    flags = [env.step(np.zeros(7))[2:4] for _ in range(3)]
    assert flags == [(False, False), (False, False), (False, True)]
    with pytest.raises(ConfigError, match=r"the episode has ended .*: call reset"):
        env.step(np.zeros(7))  # it stepped on past the limit
    env.reset(seed=1)
    env.step(np.zeros(7))


def test_joint_actions_move_the_servo_targets_within_limits() -> None:
    env = PickPlaceEnv()
    env.reset(seed=0)
    q0 = env.q_cmd.copy()
    env.step(np.array([1, -1, 0, 0, 0, 0.5, 1.0]))
    dq = env.q_cmd - q0
    assert np.allclose(dq, env.qd_max * POLICY_DT * np.array([1, -1, 0, 0, 0, 0.5]))
    for _ in range(200):  # joint 1 pushed past its limit stays at it
        env.step(np.array([1, 0, 0, 0, 0, 0, 1.0]))
    assert env.q_cmd[0] == env.q_upper[0]


def test_async_vector_env_matches_single_envs() -> None:
    vec = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="async")
    try:
        obs, _ = vec.reset(seed=[3, 4])
        rng = np.random.default_rng(0)
        actions = rng.uniform(-1, 1, size=(5, 2, 7)).astype(np.float32)
        for a in actions:
            obs, reward, *_ = vec.step(a)
    finally:
        vec.close()
    for i, seed in enumerate((3, 4)):
        env = gym.make(ENV_ID)
        o, _ = env.reset(seed=seed)
        for a in actions[:, i]:
            o, r, *_ = env.step(a)
        assert np.array_equal(o["observation"], obs["observation"][i])
        assert r == reward[i] == -1.0


@pytest.mark.render
def test_rgb_array_rendering() -> None:
    env = PickPlaceEnv(render_mode="rgb_array", camera="shelf", width=160, height=128)
    env.reset(seed=0)
    frame = env.render()
    env.close()
    assert frame is not None and frame.shape == (128, 160, 3) and frame.dtype == np.uint8
    assert frame.std() > 10  # a picture, not a blank
    assert PickPlaceEnv().render() is None


def test_a_cell_file_by_cell_as_run_takes_it(ready_cell: Path) -> None:
    """``cell=`` is the name ``run(cell=)`` and ``--cell`` use; ``scene=`` takes a cell file too."""
    from kr210_sim.cell.load import model_identity

    by_cell = gym.make(ENV_ID, cell=ready_cell).unwrapped
    by_scene = PickPlaceEnv(scene=ready_cell)
    assert isinstance(by_cell, PickPlaceEnv)
    assert model_identity(by_cell.model) == model_identity(by_scene.model)
    assert np.allclose(by_cell.ready_q, np.radians([40, -15, 20, 0, -5, 0]))
    with pytest.raises(ConfigError, match=r"^give scene= or cell=, not both"):
        PickPlaceEnv(scene=SCENE_PATH, cell=ready_cell)
    with pytest.raises(ConfigError, match="cell file"):
        PickPlaceEnv(cell=ready_cell.with_name("missing.toml"))


def test_the_episode_starts_from_the_cells_ready_pose(ready_cell: Path) -> None:
    """A cell that sets ``[robot] ready_q``: the arm starts there and the commanded joint state
    is that pose (it was the motion settings' default, which the arm then swung to)."""
    env = PickPlaceEnv(scene=ready_cell)
    env.reset(seed=0)
    ready = np.radians([40, -15, 20, 0, -5, 0])
    assert np.allclose(env.ready_q, ready) and np.allclose(env.q_cmd, ready)
    assert np.allclose(env.cell.q, ready, atol=1e-3)
    env.close()
