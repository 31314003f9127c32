"""One look of a sensor: MuJoCo's colour and depth renders of its camera, the sensor's range and
noise applied, as an :class:`~kr210_sim.perception.camera.Observation`.

MuJoCo's depth render is already the distance to the image plane (along the optical axis, the
depth image's convention), in metres; the intrinsics come from the camera's ``fovy``
(:meth:`~kr210_sim.perception.camera.Intrinsics.from_fovy`), and the optical frame from the
camera's pose (:func:`~kr210_sim.perception.camera.optical_from_mujoco`): the cell's world frame
is the robot's base frame. Sensors render without shadows or reflections (a third of the cost,
and what a depth camera's colour imager needs no more than the pipeline does).
"""

from __future__ import annotations

import zlib

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.sensing import SensorSpec
from kr210_sim.cell.sensing_layout import sensors_of
from kr210_sim.errors import ConfigError
from kr210_sim.perception.camera import Intrinsics, Observation, optical_from_mujoco
from kr210_sim.sensors.noise import MODELS, apply_noise

import mujoco  # isort: skip  (after kr210_sim so MUJOCO_GL is chosen first)


def look_seed(sensor: SensorSpec, time: float) -> list[int]:
    """The seed of a look's generator when the caller passes none: the sensor's seed, its name
    (two sensors looking at once draw apart) and the look's simulated time [s] in microseconds
    (the same look, the same noise)."""
    return [sensor.seed, zlib.crc32(sensor.name.encode()), round(time * 1e6)]


class SensorRig:
    """Renders the sensors of one model; keeps one renderer per image size.

    Args:
        model: A compiled cell model with sensors (:mod:`kr210_sim.cell.sensing_mjcf`).

    Raises:
        ConfigError: When the model has no sensors.
    """

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.sensors = sensors_of(model)
        if not self.sensors:
            raise ConfigError(
                "the scene has no sensors: build it from a cell file (--cell, or build-scene)"
            )
        self._renderers: dict[tuple[int, int], mujoco.Renderer] = {}
        self.option = mujoco.MjvOption()
        self.option.geomgroup[:] = (1, 1, 1, 0, 0, 0)  # the drawn look, not colliders or sites

    def renderer(self, width: int, height: int) -> mujoco.Renderer:
        """The renderer of one image size (made once)."""
        key = (width, height)
        if key not in self._renderers:
            r = mujoco.Renderer(self.model, height, width)
            r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
            r.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
            self._renderers[key] = r
        return self._renderers[key]

    def warm(self, data: mujoco.MjData) -> None:
        """Make every sensor's renderer and draw one frame with each (the GL context, its
        shaders and the model's textures: about 0.5 s with Mesa's llvmpipe, once), so that the
        first look costs what every other does."""
        for name in self.sensors:
            self.render(data, name)

    def sensor(self, name: str) -> SensorSpec:
        """A sensor by name.

        Raises:
            ConfigError: Naming the sensors there are.
        """
        if name not in self.sensors:
            raise ConfigError(f"no sensor {name!r} (sensors: {', '.join(self.sensors)})")
        return self.sensors[name]

    def intrinsics(self, name: str) -> Intrinsics:
        """A sensor's intrinsics."""
        s = self.sensor(name)
        return Intrinsics.from_fovy(s.resolution[0], s.resolution[1], s.fovy_deg)

    def pose(self, data: mujoco.MjData, name: str) -> npt.NDArray[np.float64]:
        """The sensor's optical frame in the base frame, 4 x 4 (``data`` after kinematics)."""
        cam = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        return optical_from_mujoco(data.cam_xpos[cam], data.cam_xmat[cam])

    def render(
        self, data: mujoco.MjData, name: str, segmentation: bool = False
    ) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.float32], npt.NDArray[np.int32] | None]:
        """The perfect colour and depth images [m] of a sensor (and, with ``segmentation``,
        the geom id seen at each pixel, -1 for none): ground truth, never a pipeline's input."""
        s = self.sensor(name)
        r = self.renderer(*s.resolution)
        r.update_scene(data, camera=name, scene_option=self.option)
        rgb = r.render().copy()
        r.enable_depth_rendering()
        r.update_scene(data, camera=name, scene_option=self.option)
        depth = r.render().astype(np.float32)
        r.disable_depth_rendering()
        seg = self._segment(r) if segmentation else None
        return rgb, depth, seg

    @staticmethod
    def _segment(r: mujoco.Renderer) -> npt.NDArray[np.int32]:
        """The model geom seen at each pixel (-1: none or not a geom), from MuJoCo's id-colour
        render. The scene's geom of each id is looked up for the ids in the image only (MuJoCo's
        own segmentation render visits every geom of the scene, ~0.35 s with the dressing)."""
        flags = r.scene.flags
        saved = (flags[mujoco.mjtRndFlag.mjRND_SEGMENT], flags[mujoco.mjtRndFlag.mjRND_IDCOLOR])
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
        try:
            img = r.render()
        finally:
            flags[mujoco.mjtRndFlag.mjRND_SEGMENT], flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = saved
        ids = img[..., 0].astype(np.int32) | (img[..., 1].astype(np.int32) << 8)
        ids |= img[..., 2].astype(np.int32) << 16
        table = np.full(int(ids.max()) + 1, -1, dtype=np.int32)
        for sid in np.unique(ids):
            if sid == 0:  # the background
                continue
            g = r.scene.geoms[int(sid) - 1]
            if g.objtype == mujoco.mjtObj.mjOBJ_GEOM:
                table[sid] = g.objid
        return table[ids]

    def look(
        self,
        data: mujoco.MjData,
        name: str,
        rng: np.random.Generator | None = None,
        noise: bool = True,
    ) -> Observation:
        """One look of sensor ``name``: the colour and depth images with its range and noise.

        Args:
            data: The simulation's state (after kinematics: camera poses current).
            name: The sensor's name.
            rng: The noise's generator (default: seeded by :func:`look_seed`).
            noise: Apply the sensor's noise model (a sensor whose model is "none" never does).
        """
        obs, _ = self._look(data, name, rng, noise, False)
        return obs

    def look_with_truth(
        self,
        data: mujoco.MjData,
        name: str,
        rng: np.random.Generator | None = None,
        noise: bool = True,
    ) -> tuple[Observation, npt.NDArray[np.int32]]:
        """:meth:`look`, and the geom id seen at each pixel (-1: none) for labels."""
        obs, seg = self._look(data, name, rng, noise, True)
        assert seg is not None
        return obs, seg

    def _look(
        self,
        data: mujoco.MjData,
        name: str,
        rng: np.random.Generator | None,
        noise: bool,
        segmentation: bool,
    ) -> tuple[Observation, npt.NDArray[np.int32] | None]:
        s = self.sensor(name)
        rgb, depth, seg = self.render(data, name, segmentation)
        depth[(depth < s.near) | (depth > s.far) | ~np.isfinite(depth)] = 0.0
        intr = self.intrinsics(name)
        if noise and s.noise != "none":
            gen = rng if rng is not None else np.random.default_rng(look_seed(s, data.time))
            rgb, depth = apply_noise(rgb, depth, intr, MODELS[s.noise], gen)
        obs = Observation(
            sensor=name,
            rgb=rgb,
            depth=depth,
            intrinsics=intr,
            T_base_camera=self.pose(data, name),
            time=float(data.time),
        )
        return obs, seg

    def close(self) -> None:
        """Free the renderers' GL contexts."""
        for r in self._renderers.values():
            r.close()
        self._renderers.clear()
