"""The environment's camera observations, named as ManiSkill3 names them.

``PickPlaceEnv(obs_mode=...)``:

* ``"state"`` (default): the goal-conditioned state dict alone.
* ``"rgbd"``: also ``sensor_data``, per sensor of the cell (``{uid}``: ``shelf_rgbd``,
  ``gripper``, ...) ``rgb`` (H, W, 3) uint8 and ``depth`` (H, W, 1) uint16 in millimetres along
  the optical axis, 0 where the sensor measured nothing (out of range, or dropped by its noise
  model), as ManiSkill3's ``rgb+depth`` mode gives them.
* ``"pointcloud"``: also ``pointcloud``, every pixel of every sensor fused in the world frame
  (the robot's base frame): ``xyzw`` (N, 4) float32 [m], homogeneous, ``w = 0`` where the
  sensor measured nothing (then ``xyz = 0``); ``rgb`` (N, 3) uint8; ``segmentation`` (N, 1)
  int16: the MuJoCo geom id seen plus one (0: nothing). N is the sum of the sensors' W x H.

The looks are the sensors' own (:class:`kr210_sim.sensors.SensorRig`): resolution, field of
view, range and the seeded noise model of the cell file. ``info["sensor_param"]`` gives, per
sensor, ManiSkill3's camera parameters: ``intrinsic_cv`` (3, 3) (OpenCV), ``extrinsic_cv``
(4, 4) world to the OpenCV camera frame (x right, y down, z forward), and ``cam2world_gl``
(4, 4) the OpenGL camera frame (x right, y up, z back) to the world. ManiSkill3 puts them in
the observation; here they are in ``info``, so the observation stays what a policy learns on.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from gymnasium import spaces

from kr210_sim.errors import ConfigError
from kr210_sim.perception.camera import Observation, backproject
from kr210_sim.sensors.render import SensorRig

import mujoco  # isort: skip

#: The observation modes and what each adds to the state dict.
OBS_MODES = ("state", "rgbd", "pointcloud")
#: The OpenCV camera frame to the OpenGL one (y and z turned over).
CV_TO_GL = np.diag([1.0, -1.0, -1.0, 1.0])


class SensorObservations:
    """Renders the cell's sensors into an observation mode's entries.

    Args:
        model: The environment's model (its sensors, from the cell file or the defaults).
        mode: ``"rgbd"`` or ``"pointcloud"``.

    Raises:
        ConfigError: An unknown mode, or a model without sensors.
    """

    def __init__(self, model: mujoco.MjModel, mode: str) -> None:
        if mode not in OBS_MODES[1:]:
            raise ConfigError(f"obs_mode must be one of {', '.join(OBS_MODES)}, got {mode!r}")
        self.mode = mode
        self.rig = SensorRig(model)
        self.names = list(self.rig.sensors)
        #: Per sensor, its images' (height, width) [px].
        self.sizes = {n: self.rig.sensor(n).resolution[::-1] for n in self.names}

    def spaces(self) -> dict[str, spaces.Space[Any]]:
        """The entries this mode adds to the observation space."""
        if self.mode == "rgbd":
            return {
                "sensor_data": spaces.Dict(
                    {
                        n: spaces.Dict(
                            {
                                "rgb": spaces.Box(0, 255, shape=(h, w, 3), dtype=np.uint8),
                                "depth": spaces.Box(0, 65535, shape=(h, w, 1), dtype=np.uint16),
                            }
                        )
                        for n, (h, w) in self.sizes.items()
                    }
                )
            }
        n = sum(h * w for h, w in self.sizes.values())
        inf = np.float32(np.inf)
        return {
            "pointcloud": spaces.Dict(
                {
                    "xyzw": spaces.Box(-inf, inf, shape=(n, 4), dtype=np.float32),
                    "rgb": spaces.Box(0, 255, shape=(n, 3), dtype=np.uint8),
                    "segmentation": spaces.Box(-1, 32767, shape=(n, 1), dtype=np.int16),
                }
            )
        }

    def observe(self, data: mujoco.MjData) -> dict[str, Any]:
        """This mode's entries for the state ``data`` (after kinematics), and the sensors'
        parameters (``info["sensor_param"]``)."""
        looks: dict[str, Observation] = {}
        segs: dict[str, npt.NDArray[np.int32]] = {}
        for n in self.names:
            if self.mode == "pointcloud":
                looks[n], segs[n] = self.rig.look_with_truth(data, n)
            else:
                looks[n] = self.rig.look(data, n)
        params = {n: sensor_param(o) for n, o in looks.items()}
        if self.mode == "rgbd":
            return {
                "sensor_data": {n: rgbd(o) for n, o in looks.items()},
                "sensor_param": params,
            }
        parts = [pointcloud(looks[n], segs[n]) for n in self.names]
        fused = {k: np.concatenate([p[k] for p in parts]) for k in ("xyzw", "rgb", "segmentation")}
        return {"pointcloud": fused, "sensor_param": params}

    def close(self) -> None:
        """Free the sensors' renderers."""
        self.rig.close()


def sensor_param(obs: Observation) -> dict[str, npt.NDArray[np.float32]]:
    """ManiSkill3's camera parameters of a look: ``intrinsic_cv`` (3, 3), ``extrinsic_cv``
    (4, 4: world to the OpenCV camera frame) and ``cam2world_gl`` (4, 4)."""
    T = np.asarray(obs.T_base_camera, dtype=np.float64)
    return {
        "intrinsic_cv": obs.intrinsics.K.astype(np.float32),
        "extrinsic_cv": np.linalg.inv(T).astype(np.float32),
        "cam2world_gl": (T @ CV_TO_GL).astype(np.float32),
    }


def rgbd(obs: Observation) -> dict[str, npt.NDArray[Any]]:
    """A look as ManiSkill3's ``rgb`` (H, W, 3) uint8 and ``depth`` (H, W, 1) uint16 [mm]
    (0: nothing measured)."""
    mm = np.rint(np.clip(obs.depth, 0.0, 65.535) * 1000.0).astype(np.uint16)
    return {"rgb": obs.rgb.copy(), "depth": mm[:, :, None]}


def pointcloud(obs: Observation, seg: npt.NDArray[np.int32]) -> dict[str, npt.NDArray[Any]]:
    """Every pixel of a look as a point: ``xyzw`` (H*W, 4) in the world frame [m] (``w = 0``
    and ``xyz = 0`` where nothing was measured), ``rgb`` (H*W, 3), ``segmentation`` (H*W, 1):
    the geom id seen plus one (0: nothing)."""
    pts, valid = backproject(obs.depth, obs.intrinsics)
    T = np.asarray(obs.T_base_camera, dtype=np.float64)
    xyzw = np.zeros((valid.size, 4), dtype=np.float32)
    flat = valid.reshape(-1)
    xyzw[flat, :3] = pts @ T[:3, :3].T + T[:3, 3]
    xyzw[flat, 3] = 1.0
    return {
        "xyzw": xyzw,
        "rgb": obs.rgb.reshape(-1, 3).copy(),
        "segmentation": (np.asarray(seg).reshape(-1, 1) + 1).astype(np.int16),
    }
