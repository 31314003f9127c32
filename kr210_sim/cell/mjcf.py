"""URDF -> MJCF: the KR210 and its pick-and-place cell as a MuJoCo model.

The robot comes from MuJoCo's own URDF import of ``assets/kr210/kr210.urdf``; this module adds
what URDF cannot say (actuators, gravity compensation, armature, the coupled fingers, sites,
cameras, contact parameters, a ``home`` keyframe) and the cell (floor, shelf, bin, targets,
lights) from a cell file's value (:class:`~kr210_sim.cell.spec.CellConfig`, see
:mod:`kr210_sim.cell.toml`). :func:`build_scene` writes the published cell to ``scenes/``; the
runtime loads the committed file (:func:`kr210_sim.cell.load.load_model`) and a test proves it is
current. Only the commands that build import this module (it pulls in trimesh for the dressing).

Named elements the runtime reads (:mod:`kr210_sim.cell.layout`): bodies ``shelf`` (geoms
``shelf_board_<row>``, ``shelf_top``, ``shelf_back``, ``shelf_wall_left/right``,
``shelf_divider_<k>``), ``bin`` (``bin_floor``, ``bin_wall_px/nx/py/ny``), ``obstacles``
(``obstacle_<i>``), ``target_<k>``; sites ``slot_<n>``, ``shelf_box``, ``bin_inside``,
``drop_<n>``; custom text ``cell_name``, ``cell_sha256`` and numerics ``randomize_*`` (and
``ready_q_deg`` when the cell sets it); robot hull colliders ``<link>_hull`` (class ``hull``).

The robot's part (classes, drives, gripper, colliders, the contact filter bits) is
:mod:`kr210_sim.cell.robot_model`; see also the README in ``assets/kr210``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import numpy.typing as npt

from kr210_sim.cell import dressing
from kr210_sim.cell.handles import ENV_PARTS, target_name
from kr210_sim.cell.parts import PART_TORSION, add_free_part
from kr210_sim.cell.robot_model import (
    CELL_AFFINITY,
    CELL_BIT,
    FLOOR_AFFINITY,
    GRASP_SOLIMP,
    GRASP_SOLREF,
    add_actuators,
    add_draw_meshes,
    add_hulls,
    configure_robot,
    look_at,
)
from kr210_sim.cell.sensing import TARGET_RGB
from kr210_sim.cell.sensing_mjcf import add_sensing
from kr210_sim.cell.spec import (
    SHELF_BOARD_THICKNESS,
    SHELF_POST_WIDTH,
    BinSpec,
    CellConfig,
    ObstacleSpec,
    ShelfSpec,
)
from kr210_sim.errors import ConfigError, SceneError
from kr210_sim.robot.description import ARM_JOINTS
from kr210_sim.util.outputs import check_folder, write_bytes_atomic
from kr210_sim.util.paths import MESH_DIR, SCENE_PATH, SCENES_DIR, URDF_PATH

import mujoco  # isort: skip  (after kr210_sim so MUJOCO_GL is chosen first)

#: Coefficient of rolling friction of steel on wood [m]: 0.22 in = 5.6 mm, "iron on wood" in the
#: same eMachineShop table. The bin's floor is lined with wood, as parts bins are against dents.
WOOD_ROLLING = 0.0056
#: Friction of the bin floor (the wood liner): sliding, torsional [m], rolling [m]. Its rolling
#: resistance (condim 6, and a higher priority than the targets', so its parameters apply: its
#: contact stiffness is therefore the targets' too, GRASP_SOLREF) stops a cylinder rolling on
#: its side within 1.5 v^2 r / (2 WOOD_ROLLING g) (0.06 m from 0.3 m/s for r = 5 cm) and damps
#: one rocking on its rim.
BIN_FLOOR_FRICTION = (1.0, PART_TORSION, WOOD_ROLLING)
#: Simulation timestep in [s].
TIMESTEP = 0.002
#: Offscreen framebuffer size in [px] (largest video frame).
OFFSCREEN_SIZE = (1920, 1088)

TARGET_RGBA = (*TARGET_RGB, 1.0)
SHELF_RGBA = (0.55, 0.42, 0.3, 1.0)
BIN_RGBA = (0.3, 0.32, 0.36, 1.0)
OBSTACLE_RGBA = (0.85, 0.75, 0.2, 1.0)


def _box(
    body: mujoco.MjsBody,
    name: str,
    center: npt.ArrayLike,
    half: npt.ArrayLike,
    rgba: tuple[float, ...],
    cls: mujoco.MjsDefault,
) -> mujoco.MjsGeom:
    geom = body.add_geom(
        name=name,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=[float(v) for v in np.asarray(center, dtype=float)],
        size=[float(v) for v in np.asarray(half, dtype=float)],
        rgba=list(rgba),
    )
    geom.classname = cls
    # a class set after creation does not reapply its defaults
    geom.contype, geom.conaffinity, geom.group = (
        cls.geom.contype,
        cls.geom.conaffinity,
        cls.geom.group,
    )
    return geom


def _add_world(spec: mujoco.MjSpec, cell: CellConfig, static: mujoco.MjsDefault) -> None:
    """Floor, sky, lights and the fixed cameras (the look: :mod:`kr210_sim.cell.dressing`)."""
    world = spec.worldbody
    # Infinite for collisions whatever its size; the dressing sets the drawn size.
    floor = world.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], material="floor"
    )
    floor.classname = static
    # Not the hulls: hull/plane tests cost about a fifth of the step rate; the primitive
    # colliders still touch the floor (and the planner checks the hulls against it).
    floor.contype, floor.conaffinity = CELL_BIT, FLOOR_AFFINITY
    # The whole cell, from high enough to look over the bin cage's rim into it.
    overview_pos, overview_at = (-1.6, -2.2, 3.4), (1.35, 1.0, 0.95)
    world.add_camera(
        name="overview",
        pos=list(overview_pos),
        xyaxes=list(look_at(overview_pos, overview_at)),
        fovy=56,
    )
    shelf_at = (*cell.shelf.to_world((-cell.shelf.depth / 2.0 + 0.1, 0.0, 0.0))[:2], 1.6)
    shelf_pos = (0.5, -1.6, 2.3)
    world.add_camera(
        name="shelf", pos=list(shelf_pos), xyaxes=list(look_at(shelf_pos, shelf_at)), fovy=62
    )
    bin_x, bin_y = cell.bin.position
    # Steep enough (about 70 deg down) to see the bin's floor over its 1 m walls.
    bin_pos = (bin_x - 0.55, bin_y + 0.75, 3.3)
    world.add_camera(
        name="bin", pos=list(bin_pos), xyaxes=list(look_at(bin_pos, (bin_x, bin_y, 0.1))), fovy=45
    )
    # Three-quarter view of the middle slot (slot 5 of the published cell): the wrist, the
    # gripper and the grasp large.
    slot = cell.slot((cell.n_slots + 1) // 2)
    hero_at = (slot[0] - 0.3, slot[1] + 0.05, slot[2] - 0.08)
    hero_pos = (slot[0] - 0.95, slot[1] - 1.0, slot[2] + 0.45)
    world.add_camera(
        name="hero", pos=list(hero_pos), xyaxes=list(look_at(hero_pos, hero_at)), fovy=45
    )


def _shelf_box(
    body: mujoco.MjsBody,
    shelf: ShelfSpec,
    name: str,
    local: tuple[float, float, float],
    half: tuple[float, float, float],
    static: mujoco.MjsDefault,
) -> None:
    """A box of the shelf, given in the shelf frame (see :class:`ShelfSpec`)."""
    geom = _box(body, name, shelf.to_world(local), half, SHELF_RGBA, static)
    if shelf.yaw_deg % 360.0:
        geom.quat = _yaw_quat(shelf.yaw_deg)


def _yaw_quat(yaw_deg: float) -> list[float]:
    h = math.radians(yaw_deg) / 2.0
    return [round(math.cos(h), 12), 0.0, 0.0, round(math.sin(h), 12)]


def _add_shelf(spec: mujoco.MjSpec, shelf: ShelfSpec, static: mujoco.MjsDefault) -> None:
    """``rows`` boards, a top, a back panel, two side walls and ``columns - 1`` dividers."""
    s = shelf
    body = spec.worldbody.add_body(name="shelf")
    hx, hw = s.depth / 2.0, s.half_width
    half_t = SHELF_BOARD_THICKNESS / 2.0
    for row, top in enumerate(s.board_tops, start=1):
        _shelf_box(body, s, f"shelf_board_{row}", (0, 0, top - half_t), (hx, hw, half_t), static)
    _shelf_box(body, s, "shelf_top", (0, 0, s.height - half_t), (hx, hw, half_t), static)
    _shelf_box(
        body, s, "shelf_back", (hx - 0.01, 0, s.height / 2.0), (0.01, hw, s.height / 2.0), static
    )
    # Posts at the compartment borders, numbered 0 (left wall, seen from the robot) to
    # ``columns`` (right wall); listed from the middle outwards, right side first.
    half_post = (hx, SHELF_POST_WIDTH / 2.0, s.height / 2.0)
    ys = [(s.columns / 2.0 - k) * s.column_pitch for k in range(s.columns + 1)]
    order = sorted(range(s.columns + 1), key=lambda k: (ys[k] > 0, abs(ys[k])))
    for k in order:
        if k == 0:
            name = "shelf_wall_left"
        elif k == s.columns:
            name = "shelf_wall_right"
        else:
            name = f"shelf_divider_{k}"
        _shelf_box(body, s, name, (0, ys[k], s.height / 2.0), half_post, static)


def _add_bin(spec: mujoco.MjSpec, bin_: BinSpec, static: mujoco.MjsDefault) -> None:
    """The open drop bin: a floor slab and four walls."""
    b = bin_
    bx, by = b.position
    hx, hy, height = b.size[0] / 2.0, b.size[1] / 2.0, b.size[2]
    w = b.wall
    body = spec.worldbody.add_body(name="bin")
    floor = _box(
        body,
        "bin_floor",
        (bx, by, b.floor_top / 2.0),
        (hx, hy, b.floor_top / 2.0),
        BIN_RGBA,
        static,
    )
    floor.condim = 6
    floor.friction = list(BIN_FLOOR_FRICTION)
    floor.priority = 2
    # Its priority makes its contact parameters the ones that apply against a target: as stiff
    # as the targets' own, or a cylinder dropped from 1.6 m sinks 31-33 mm into the floor.
    floor.solref = list(GRASP_SOLREF)
    floor.solimp = list(GRASP_SOLIMP)
    h = height / 2.0
    _box(body, "bin_wall_px", (bx + hx - w / 2, by, h), (w / 2, hy, h), BIN_RGBA, static)
    _box(body, "bin_wall_nx", (bx - hx + w / 2, by, h), (w / 2, hy, h), BIN_RGBA, static)
    _box(body, "bin_wall_py", (bx, by + hy - w / 2, h), (hx - w, w / 2, h), BIN_RGBA, static)
    _box(body, "bin_wall_ny", (bx, by - hy + w / 2, h), (hx - w, w / 2, h), BIN_RGBA, static)


def _add_obstacles(
    spec: mujoco.MjSpec, obstacles: tuple[ObstacleSpec, ...], static: mujoco.MjsDefault
) -> None:
    """The cell's boxes, ``obstacle_1`` ... in the body ``obstacles`` (none: no body)."""
    if not obstacles:
        return
    body = spec.worldbody.add_body(name="obstacles")
    for i, o in enumerate(obstacles, start=1):
        half = tuple(v / 2.0 for v in o.size)
        geom = _box(body, f"obstacle_{i}", o.position, half, OBSTACLE_RGBA, static)
        if o.yaw_deg % 360.0:
            geom.quat = _yaw_quat(o.yaw_deg)


def _add_cell_sites(spec: mujoco.MjSpec, cell: CellConfig) -> None:
    """The named sites the runner, planner and scoring read the layout from (group 5, hidden).

    * ``slot_<n>``: slot n's point on its board (x, y of the compartment centre, z of the board
      top), numbered as :class:`ShelfSpec` says;
    * ``shelf_box``: a box site over the shelf's outer volume (its frame is the shelf frame);
    * ``bin_inside``: a box site over the bin's inner volume, floor top to rim;
    * ``drop_<n>``: where cylinder n of a filling is released (x, y; z at the rim).
    """
    s, b = cell.shelf, cell.bin
    shelf, bin_ = spec.body("shelf"), spec.body("bin")
    quat = _yaw_quat(s.yaw_deg) if s.yaw_deg % 360.0 else [1.0, 0.0, 0.0, 0.0]
    for n in range(1, cell.n_slots + 1):
        shelf.add_site(
            name=f"slot_{n}",
            pos=[float(v) for v in s.to_world(s.slot_local(n))],
            quat=quat,
            size=[0.02, 0, 0],
            group=5,
        )
    shelf.add_site(
        name="shelf_box",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=[float(v) for v in s.to_world((0.0, 0.0, s.height / 2.0))],
        quat=quat,
        size=[s.depth / 2.0, s.half_width, s.height / 2.0],
        group=5,
    )
    bx, by = b.position
    (ix, iy), rim = b.inner_half, b.size[2]
    bin_.add_site(
        name="bin_inside",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=[bx, by, (b.floor_top + rim) / 2.0],
        size=[ix, iy, (rim - b.floor_top) / 2.0],
        group=5,
    )
    for n, (dx, dy) in enumerate(b.drop_offsets(), start=1):
        bin_.add_site(name=f"drop_{n}", pos=[bx + dx, by + dy, rim], size=[0.02, 0, 0], group=5)


def _add_cell_info(spec: mujoco.MjSpec, cell: CellConfig) -> None:
    """The cell's name, its file's hash and the randomisation ranges, as custom model data."""
    spec.add_text(name="cell_name", data=cell.name)
    spec.add_text(name="cell_sha256", data=cell.sha256 or "none")
    r = cell.randomization
    spec.add_numeric(name="randomize_xy_offset", data=[r.xy_offset])
    # in degrees: the MJCF keeps 6 digits, which would turn pi into 3.14159
    spec.add_numeric(name="randomize_yaw_deg", data=[round(math.degrees(a), 9) for a in r.yaw])
    for key in ("radius", "length", "mass", "friction"):
        spec.add_numeric(name=f"randomize_{key}", data=list(getattr(r, key)))
    if cell.ready_q_deg is not None:
        spec.add_numeric(name="ready_q_deg", data=list(cell.ready_q_deg))


def _add_targets(spec: mujoco.MjSpec, cell: CellConfig) -> None:
    """Ten free target cylinders, parked upright on the floor out of the robot's reach."""
    t = cell.target
    for k in range(cell.n_targets):
        add_free_part(
            spec,
            target_name(k),
            cell.park_position(k),
            mujoco.mjtGeom.mjGEOM_CYLINDER,
            [t.radius, t.length / 2.0, 0],
            t.mass,
            TARGET_RGBA,
            t.friction,
        )


def _dress(
    spec: mujoco.MjSpec, cell: CellConfig, visual: mujoco.MjsDefault, mesh_dir: Path | str
) -> None:
    """The look of robot and cell (visual-only geoms, materials, lights): see
    :mod:`kr210_sim.cell.dressing`. The shelf is dressed in its own frame (a child body at its
    footprint's centre, turned by its yaw), so any cell's shelf gets its racking."""
    s, b = cell.shelf, cell.bin
    shelf_corners = [
        s.to_world((sx * s.depth / 2, sy * s.half_width, 0.0)) for sx in (-1, 1) for sy in (-1, 1)
    ]
    xs = [float(c[0]) for c in shelf_corners] + [b.position[0] + d * b.size[0] / 2 for d in (-1, 1)]
    ys = [float(c[1]) for c in shelf_corners] + [b.position[1] + d * b.size[1] / 2 for d in (-1, 1)]
    dressing.add_materials(spec)
    dressing.dress_robot(spec, visual, mesh_dir)
    dressing.dress_floor(
        spec,
        visual,
        robot_xy=(0.0, 0.0),
        plate_half=0.6,
        marked=(
            min(-1.3, min(xs) - 0.25),
            min(-1.6, min(ys) - 0.25),
            max(xs) + 0.25,
            max(ys) + 0.4,
        ),
        hall=(
            min(-6.0, min(xs) - 2.0),
            min(-6.0, min(ys) - 2.0),
            max(6.5, max(xs) + 2.0),
            max(6.0, max(ys) + 2.0),
        ),
    )
    shelf = spec.body("shelf")
    dressing.hide(shelf)
    frame = shelf.add_body(name="shelf_look", pos=[s.position[0], s.position[1], 0.0])
    if s.yaw_deg % 360.0:
        frame.quat = _yaw_quat(s.yaw_deg)
    dressing.dress_shelf(
        spec,
        frame,
        visual,
        x_front=-s.depth / 2.0,
        depth=s.depth,
        half_width=s.half_width,
        height=s.height,
        board_tops=s.board_tops,
        board_thickness=SHELF_BOARD_THICKNESS,
        upright_y=[(s.columns / 2.0 - k) * s.column_pitch for k in range(s.columns + 1)],
    )
    bin_body = spec.body("bin")
    dressing.hide(bin_body)
    dressing.dress_bin(
        spec, bin_body, visual, b.position, (b.size[0], b.size[1]), b.size[2], b.floor_top
    )
    dressing.add_lights(spec, center=(1.0, 1.0, 1.0))


def _add_contact_sensors(spec: mujoco.MjSpec, obstacles: bool) -> None:
    """How many contacts the moving robot (link_1's subtree) has with each cell part (shelf,
    bin, obstacles, floor), read by the control loop every tick."""
    for env in ENV_PARTS:
        if env == "obstacles" and not obstacles:
            continue
        spec.add_sensor(
            name=f"robot_{env}_contacts",
            type=mujoco.mjtSensor.mjSENS_CONTACT,
            objtype=mujoco.mjtObj.mjOBJ_XBODY,
            objname="link_1",
            reftype=mujoco.mjtObj.mjOBJ_GEOM if env == "floor" else mujoco.mjtObj.mjOBJ_BODY,
            refname=env,
            intprm=[1, 0, 1],  # data = "found" (count), no reduction
        )


def build_spec(
    cell: CellConfig | None = None,
    urdf_path: Path | str = URDF_PATH,
    mesh_dir: Path | str = MESH_DIR,
    planning: bool = False,
) -> mujoco.MjSpec:
    """Build the whole cell as an :class:`mujoco.MjSpec`.

    Args:
        cell: Cell layout (defaults to the published cell).
        urdf_path: The KR210 URDF.
        mesh_dir: Folder of the URDF's visual meshes.
        planning: Give the robot the finest hull colliders (the hulls of the drawn meshes
            themselves, 3,280 vertices) instead of the stepped model's light ones (1,224, at most
            7 mm proud of them): a kinematic model for collision checks, not for stepping.

    Returns:
        The spec, ready to compile or save.

    Raises:
        SceneError: When the URDF cannot be read or compiled.
    """
    if cell is None:
        from kr210_sim.cell.toml import published_cell

        cell = published_cell()
    urdf_path = Path(urdf_path)
    if not urdf_path.is_file():
        raise SceneError(f"URDF not found: {urdf_path}")
    try:
        spec = mujoco.MjSpec.from_file(str(urdf_path))
    except Exception as exc:
        raise SceneError(f"MuJoCo cannot read URDF {urdf_path}: {exc}") from exc
    spec.modelname = "kr210_cell"
    spec.meshdir = str(Path(mesh_dir).resolve())
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
    # Sleeping: resting bodies (parked spares, cylinders in the bin) leave the solver, which
    # keeps the step rate of a full bin close to that of an empty cell (~4x faster).
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    spec.visual.global_.offwidth, spec.visual.global_.offheight = OFFSCREEN_SIZE
    spec.visual.quality.shadowsize = 4096
    spec.stat.center = [1.0, 0.6, 1.2]
    spec.stat.extent = 4.0

    visual = spec.add_default("visual", spec.default)
    visual.geom.contype, visual.geom.conaffinity, visual.geom.group = 0, 0, 2
    visual.geom.density = 0
    collision = spec.add_default("collision", spec.default)
    collision.geom.group = 3
    hull = spec.add_default("hull", spec.default)
    hull.geom.contype, hull.geom.conaffinity, hull.geom.group = 0, 0, 3  # set per geom
    static = spec.add_default("static", spec.default)
    static.geom.group = 0
    static.geom.contype, static.geom.conaffinity = CELL_BIT, CELL_AFFINITY

    configure_robot(spec, visual, collision)
    _add_world(spec, cell, static)
    _add_shelf(spec, cell.shelf, static)
    _add_bin(spec, cell.bin, static)
    _add_obstacles(spec, cell.obstacles, static)
    _add_targets(spec, cell)
    add_sensing(spec, cell)
    _dress(spec, cell, visual, mesh_dir)
    add_hulls(spec, hull, fine=planning)  # one per finish of each link's mesh
    add_draw_meshes(spec)
    _add_cell_sites(spec, cell)
    _add_cell_info(spec, cell)
    _add_contact_sensors(spec, bool(cell.obstacles))

    try:
        model = spec.compile()
    except Exception as exc:
        raise SceneError(f"the cell does not compile: {exc}") from exc
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    dof = [model.jnt_dofadr[model.joint(n).id] for n in ARM_JOINTS]
    full = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, full)
    add_actuators(spec, np.array([full[i, i] for i in dof]))
    try:
        model = spec.compile()
    except Exception as exc:
        raise SceneError(f"the cell does not compile with actuators: {exc}") from exc
    ctrl = np.zeros(model.nu)
    spec.add_key(name="home", qpos=model.qpos0.tolist(), ctrl=ctrl.tolist())
    return spec


def build_scene(out_dir: Path | str = SCENES_DIR, cell: CellConfig | None = None) -> list[Path]:
    """Write the cell MJCF to ``out_dir`` (mesh paths relative to it).

    Args:
        out_dir: Destination folder (``scenes/`` by default).
        cell: Cell layout (defaults to the published cell).

    Returns:
        The files written.

    Raises:
        ConfigError: When ``out_dir`` cannot be created or written (checked before building).
        SceneError: When the cell cannot be built.
    """
    out = check_folder(out_dir)
    path = out / SCENE_PATH.name
    if path.is_dir():
        raise ConfigError(f"cannot write {path}: it is a folder")
    xml = scene_xml(cell)
    abs_dir = str(MESH_DIR.resolve())
    rel_dir = Path(_relpath(MESH_DIR, out)).as_posix()
    xml = xml.replace(f'meshdir="{abs_dir}"', f'meshdir="{rel_dir}"', 1)
    if rel_dir not in xml:
        raise SceneError("could not make the mesh folder relative in the generated MJCF")
    header = (
        "<!-- Generated by `python -m kr210_sim build-scene` from assets/kr210/kr210.urdf and "
        "scenes/cells/published.toml. Do not edit by hand. -->\n"
    )
    return [write_bytes_atomic(path, (header + xml).encode())]


def scene_xml(cell: CellConfig | None = None) -> str:
    """The cell's MJCF text, its mesh folder an absolute path (see :func:`build_spec`)."""
    spec = build_spec(cell)
    spec.meshdir = str(MESH_DIR.resolve())
    return str(spec.to_xml())


def _relpath(target: Path, start: Path) -> str:
    import os

    return os.path.relpath(target.resolve(), start.resolve())
