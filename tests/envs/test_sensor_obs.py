"""The environment's camera observations, ManiSkill3's names: ``rgbd`` (``sensor_data``) and
``pointcloud``, with each sensor's ``intrinsic_cv``/``extrinsic_cv``/``cam2world_gl`` in
``info["sensor_param"]``: the parameters put the cylinder where the images show it."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env

from kr210_sim.envs.pick_place import PickPlaceEnv
from kr210_sim.errors import ConfigError
from kr210_sim.util.paths import SCENES_DIR

CELL = SCENES_DIR / "cells" / "cluttered.toml"


@pytest.fixture(scope="module")
def rgbd() -> Any:
    env = PickPlaceEnv(obs_mode="rgbd", cell=CELL)
    obs, info = env.reset(seed=3)
    yield env, obs, info
    env.close()


@pytest.fixture(scope="module")
def cloud() -> Any:
    env = PickPlaceEnv(obs_mode="pointcloud", cell=CELL)
    obs, info = env.reset(seed=3)
    yield env, obs, info
    env.close()


def test_rgbd_gives_each_sensors_images_in_maniskills_layout(rgbd: Any) -> None:
    env, obs, info = rgbd
    assert env.observation_space.contains(obs)
    data = obs["sensor_data"]
    assert set(data) == set(info["sensor_param"]) == {"shelf_rgbd", "gripper"}
    for name, images in data.items():
        w, h = env._sensors.rig.sensor(name).resolution
        assert images["rgb"].shape == (h, w, 3) and images["rgb"].dtype == np.uint8
        assert images["depth"].shape == (h, w, 1) and images["depth"].dtype == np.uint16
        p = info["sensor_param"][name]
        # the OpenGL camera is the OpenCV one with y and z turned over, and the extrinsic its
        # inverse: the three describe one camera
        assert np.allclose(
            p["cam2world_gl"] @ np.diag([1, -1, -1, 1]) @ p["extrinsic_cv"], np.eye(4), atol=1e-5
        )
        K = p["intrinsic_cv"]
        assert K[0, 2] == pytest.approx((w - 1) / 2, abs=1) and K[1, 2] == pytest.approx(
            (h - 1) / 2, abs=1
        )


def test_the_parameters_put_the_cylinder_where_the_depth_image_sees_it(rgbd: Any) -> None:
    env, obs, info = rgbd
    p = info["sensor_param"]["shelf_rgbd"]
    centre = obs["achieved_goal"]
    c = p["extrinsic_cv"] @ np.append(centre, 1.0)  # in the OpenCV camera frame
    u, v, _ = p["intrinsic_cv"] @ (c[:3] / c[2])
    depth = obs["sensor_data"]["shelf_rgbd"]["depth"][:, :, 0].astype(float) / 1000.0
    near = depth[int(v) - 2 : int(v) + 3, int(u) - 2 : int(u) + 3]
    near = near[near > 0]
    assert len(near) >= 5
    radius = env.target.spec.radius
    # the cylinder's front face: its centre's depth less about a radius (noise: a few mm)
    assert c[2] - radius - 0.02 < float(np.median(near)) < c[2] + 0.01


def test_a_pointcloud_fuses_every_pixel_in_the_world_and_labels_the_cylinder(cloud: Any) -> None:
    env, obs, info = cloud
    assert env.observation_space.contains(obs)
    pc = obs["pointcloud"]
    sizes = [env._sensors.rig.sensor(n).resolution for n in info["sensor_param"]]
    n = sum(w * h for w, h in sizes)
    assert pc["xyzw"].shape == (n, 4) and pc["rgb"].shape == (n, 3)
    assert pc["segmentation"].shape == (n, 1)
    w = pc["xyzw"][:, 3]
    assert set(np.unique(w)) <= {0.0, 1.0} and 0.5 * n < (w == 1).sum() < n
    assert not pc["xyzw"][w == 0, :3].any()
    geom = int(env.cell.handles.target_geoms[env.cell.active_target])
    mine = pc["xyzw"][pc["segmentation"][:, 0] == geom + 1]
    mine = mine[mine[:, 3] == 1, :3]
    assert len(mine) > 50
    spec = env.target.spec
    off = np.linalg.norm(mine - obs["achieved_goal"], axis=1)
    assert np.median(off) < np.hypot(spec.radius, spec.length / 2) + 0.01
    # a step renders afresh, with the parameters of the wrist camera where the arm has it
    obs2, *_, info2 = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    assert obs2["pointcloud"]["xyzw"].shape == (n, 4) and "sensor_param" in info2


def test_observation_modes_are_checked_and_state_stays_as_it_was() -> None:
    with pytest.raises(ConfigError, match="obs_mode must be one of state, rgbd, pointcloud"):
        PickPlaceEnv(obs_mode="rgb+depth+segmentation")
    env = PickPlaceEnv()
    obs, info = env.reset(seed=3)
    assert set(obs) == {"observation", "achieved_goal", "desired_goal"}
    assert "sensor_param" not in info


@pytest.mark.slow
def test_the_rgbd_env_passes_gymnasiums_checker() -> None:
    env = PickPlaceEnv(obs_mode="rgbd", cell=CELL, max_steps=3)
    try:
        check_env(env, skip_render_check=True)
    finally:
        env.close()
