"""The cell's sensors and clutter in the MJCF (called by :func:`kr210_sim.cell.mjcf.build_spec`).

* Each sensor is a camera of its name: fixed in the world, or on ``gripper_link`` (the sensor
  named ``gripper`` is the wrist camera the robot already carries: it sets its pose and field
  of view). Its range, noise model and seed are custom model data (``sensors``,
  ``sensor_<name>``, ``sensor_<name>_noise``, ``sensor_<name>_mount``), read back by
  :func:`kr210_sim.sensors.spec.sensors_of`.
* Each object kind gets ``count`` free bodies ``clutter_<kind>_<j>`` (one geom of the same name),
  parked upright on the floor out of reach and out of every fixed camera's shot, as the spare
  targets are; :mod:`kr210_sim.sim.clutter` places them on the shelf at the start of a cycle.
  The kinds, the clutter settings and the pick list are custom data too (``object_kinds``,
  ``object_<kind>``, ``clutter``, ``pick_list``).
"""

from __future__ import annotations

from kr210_sim.cell.parts import add_free_part
from kr210_sim.cell.sensing import SHAPES, ObjectKind, SensorSpec, clutter_name
from kr210_sim.cell.spec import CellConfig
from kr210_sim.errors import SceneError

import mujoco  # isort: skip  (after kr210_sim so MUJOCO_GL is chosen first)

#: Where the first parked clutter object waits (x, y) [m], rows along +y, a row per kind.
CLUTTER_PARK = (-3.8, -4.2)
#: Spacing of parked clutter objects [m].
CLUTTER_PARK_SPACING = 0.3
_GEOM_TYPES = {
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
}


def add_sensing(spec: mujoco.MjSpec, cell: CellConfig) -> None:
    """The cell's sensors (cameras), clutter bodies and their custom data.

    Raises:
        SceneError: When the wrist camera a ``gripper`` sensor declares is missing.
    """
    for sensor in cell.sensors:
        _add_camera(spec, sensor)
        spec.add_numeric(
            name=f"sensor_{sensor.name}",
            data=[sensor.near, sensor.far, float(sensor.seed), *map(float, sensor.resolution)],
        )
        spec.add_text(name=f"sensor_{sensor.name}_noise", data=sensor.noise)
        spec.add_text(name=f"sensor_{sensor.name}_mount", data=sensor.mount)
    if cell.sensors:
        spec.add_text(name="sensors", data=" ".join(s.name for s in cell.sensors))
    for row, kind in enumerate(cell.objects):
        _add_kind(spec, kind, row)
    if cell.objects:
        spec.add_text(name="object_kinds", data=" ".join(k.name for k in cell.objects))
    if cell.clutter is not None:
        c = cell.clutter
        spec.add_numeric(name="clutter", data=[*map(float, c.per_bay), *c.gap, float(c.seed)])
    if tuple(cell.pick) != ("target",):
        spec.add_text(name="pick_list", data=" ".join(cell.pick))


def _add_camera(spec: mujoco.MjSpec, sensor: SensorSpec) -> None:
    xyaxes = list(sensor.mujoco_xyaxes())
    res = list(sensor.resolution)
    if sensor.mount == "world":
        spec.worldbody.add_camera(
            name=sensor.name,
            pos=list(sensor.position),
            xyaxes=xyaxes,
            fovy=sensor.fovy_deg,
            resolution=res,
        )
        return
    body = spec.body("gripper_link")
    if body is None:  # pragma: no cover - configure_robot made it
        raise SceneError("the robot has no gripper_link to mount a sensor on")
    if sensor.name == "gripper":
        cam = spec.camera("gripper")
        if cam is None:  # pragma: no cover - configure_robot made it
            raise SceneError("the robot has no wrist camera 'gripper'")
        cam.pos = list(sensor.position)
        cam.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
        cam.alt.xyaxes = xyaxes
        cam.fovy = sensor.fovy_deg
        cam.resolution = res
        return
    body.add_camera(
        name=sensor.name,
        pos=list(sensor.position),
        xyaxes=xyaxes,
        fovy=sensor.fovy_deg,
        resolution=res,
    )


def _add_kind(spec: mujoco.MjSpec, kind: ObjectKind, row: int) -> None:
    """``kind.count`` free bodies of one kind, parked in a row of their own."""
    hx, hy, hz = kind.half_extents
    if kind.shape == "cylinder":
        size = [kind.size[0], kind.size[1] / 2.0, 0.0]
    elif kind.shape == "box":
        size = [hx, hy, hz]
    else:
        size = [kind.size[0], 0.0, 0.0]
    x0, y0 = CLUTTER_PARK
    for j in range(kind.count):
        name = clutter_name(kind.name, j)
        pos = [x0 - row * CLUTTER_PARK_SPACING, y0 + j * CLUTTER_PARK_SPACING, hz]
        add_free_part(
            spec,
            name,
            pos,
            _GEOM_TYPES[kind.shape],
            size,
            kind.mass,
            (*kind.rgb, 1.0),
            kind.friction,
        )
    spec.add_numeric(
        name=f"object_{kind.name}",
        data=[
            float(SHAPES.index(kind.shape)),
            *[*kind.size, 0.0, 0.0][:3],
            *kind.rgb,
            kind.mass,
            kind.friction,
            float(kind.count),
        ],
    )
