"""The cell's look: materials, the robot's multi-finish meshes, racking, bin, floor, lights.

Everything here is visual only: geoms of the ``visual`` default class (``contype`` =
``conaffinity`` = 0, group 2, density 0), so the model's masses, contacts and therefore the
physics do not change. The functions take the cell's geometry as plain numbers, so the
scene builder can call them with whatever layout it builds (see :mod:`kr210_sim.cell.mjcf`).

* The robot's links get their extra mesh parts (``<link>__<finish>.stl``, written by
  :mod:`kr210_sim.robot.meshes`) and a material per finish.
* The shelf's collision boxes are hidden (group 3, like the robot's) and drawn as pallet
  racking: upright frames with bracing, front and back beams, steel decks and a mesh back panel.
* The bin's collision walls are hidden and drawn as a wire-mesh pallet cage: a steel frame, a
  solid floor and see-through mesh walls, so the drops can be seen from any side.
* The floor is sealed concrete (no checker, so no moire), the robot stands on a steel floor
  plate, yellow lines mark the cell, and hall walls hide the horizon.
* Key, fill and rim lights; only the key light casts shadows.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise
from pathlib import Path

import numpy as np
import trimesh

from kr210_sim.robot.meshes import BUILDERS, MAIN_FINISH

import mujoco  # isort: skip  (after kr210_sim so MUJOCO_GL is chosen first)

#: Colours (RGBA) and surface properties (specular, shininess) of the finishes.
FINISH_LOOK: dict[str, tuple[tuple[float, float, float, float], float, float]] = {
    "orange": ((0.96, 0.4, 0.02, 1.0), 0.35, 0.55),
    "dark": ((0.2, 0.2, 0.21, 1.0), 0.3, 0.4),
    "black": ((0.07, 0.07, 0.08, 1.0), 0.45, 0.6),
    "steel": ((0.62, 0.64, 0.67, 1.0), 0.8, 0.8),
    "alu": ((0.78, 0.8, 0.83, 1.0), 0.6, 0.5),
}
#: Cell colours (RGBA).
UPRIGHT_RGBA = (0.1, 0.22, 0.45, 1.0)
BEAM_RGBA = (0.95, 0.55, 0.05, 1.0)
DECK_RGBA = (0.58, 0.6, 0.62, 1.0)
MESH_RGBA = (0.25, 0.26, 0.28, 0.35)
CAGE_RGBA = (0.55, 0.57, 0.6, 1.0)
CAGE_MESH_RGBA = (0.6, 0.62, 0.65, 0.18)
MARKING_RGBA = (0.95, 0.78, 0.05, 1.0)
WALL_RGBA = (0.72, 0.73, 0.74, 1.0)
DADO_RGBA = (0.32, 0.38, 0.42, 1.0)

#: How far the drawn floor reaches past the hall's walls and open sides [m], and its grid [m].
#: MuJoCo's infinite plane costs 4-5 ms a render pass in software (llvmpipe) whatever its grid;
#: with shadows, about a third of a 640x480 frame (61 against 41 ms). A finite one
#: drawn on a 2 m grid looks the same from every fixed camera. It still collides as an infinite
#: plane (MuJoCo's plane size is for drawing only).
FLOOR_MARGIN = 24.0
FLOOR_GRID = 2.0

#: Wire spacing of the bin cage's mesh walls [m] and wire half-thickness [m].
CAGE_PITCH = 0.125
CAGE_WIRE = 0.004


def _geom(
    body: mujoco.MjsBody,
    visual: mujoco.MjsDefault,
    name: str,
    center: Sequence[float],
    half: Sequence[float],
    rgba: Sequence[float] | None = None,
    material: str | None = None,
    kind: mujoco.mjtGeom = mujoco.mjtGeom.mjGEOM_BOX,
    pitch: float = 0.0,
) -> mujoco.MjsGeom:
    """A visual-only geom in ``body``: a box (half sizes) or ``kind`` with MuJoCo sizes,
    turned by ``pitch`` [rad] about y."""
    geom = body.add_geom(
        name=name,
        type=kind,
        pos=[float(v) for v in center],
        size=[float(v) for v in half],
    )
    geom.classname = visual
    geom.contype, geom.conaffinity, geom.group, geom.density = 0, 0, 2, 0.0
    if pitch:
        geom.quat = [float(np.cos(pitch / 2)), 0.0, float(np.sin(pitch / 2)), 0.0]
    if material is not None:
        geom.material = material
    if rgba is not None:
        geom.rgba = [float(v) for v in rgba]
    return geom


class _Boxes:
    """Boxes gathered by colour and drawn as one mesh geom per colour: a rack or a cage of a
    hundred bars costs a handful of draw calls instead of a hundred (render time per frame)."""

    def __init__(self) -> None:
        self.parts: dict[tuple[float, ...], list[tuple[Sequence[float], Sequence[float], float]]]
        self.parts = {}

    def add(
        self,
        center: Sequence[float],
        half: Sequence[float],
        rgba: Sequence[float],
        pitch: float = 0.0,
    ) -> None:
        """A box of half sizes ``half`` [m] at ``center`` [m], turned by ``pitch`` [rad] about y."""
        self.parts.setdefault(tuple(rgba), []).append((center, half, pitch))

    def flush(
        self, spec: mujoco.MjSpec, body: mujoco.MjsBody, visual: mujoco.MjsDefault, prefix: str
    ) -> None:
        """Add one mesh (flat-shaded: a normal per triangle) and geom per colour to ``body``."""
        unit = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
        for k, (rgba, boxes) in enumerate(self.parts.items()):
            verts, faces, normals = [], [], []
            for i, (center, half, pitch) in enumerate(boxes):
                c, si = np.cos(pitch), np.sin(pitch)
                rot = np.array([[c, 0.0, si], [0.0, 1.0, 0.0], [-si, 0.0, c]])
                verts.append((unit.vertices * np.asarray(half)) @ rot.T + np.asarray(center))
                faces.append(unit.faces + 8 * i)
                normals.append(unit.face_normals @ rot.T)
            name = f"{prefix}_{k}"
            mesh = spec.add_mesh(name=name)
            mesh.uservert = np.round(np.vstack(verts), 6).ravel().tolist()
            mesh.userface = np.vstack(faces).ravel().tolist()
            mesh.usernormal = np.round(np.vstack(normals), 6).ravel().tolist()
            mesh.userfacenormal = np.repeat(np.arange(12 * len(boxes)), 3).tolist()
            geom = body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name)
            geom.classname = visual
            geom.contype, geom.conaffinity, geom.group, geom.density = 0, 0, 2, 0.0
            geom.rgba = list(rgba)
        self.parts.clear()


def add_materials(spec: mujoco.MjSpec) -> None:
    """The robot finishes as named materials (``finish_<name>``)."""
    for finish, (rgba, specular, shininess) in FINISH_LOOK.items():
        spec.add_material(
            name=f"finish_{finish}", rgba=list(rgba), specular=specular, shininess=shininess
        )


def dress_robot(spec: mujoco.MjSpec, visual: mujoco.MjsDefault, mesh_dir: Path | str) -> None:
    """Give each link's URDF visual its finish and add the link's other mesh parts.

    Args:
        spec: The scene, with the URDF robot imported and :func:`add_materials` called.
        visual: The visual default class.
        mesh_dir: Folder of the link meshes (``<link>__<finish>.stl`` files are looked up here).
    """
    mesh_dir = Path(mesh_dir)
    for link, finish in MAIN_FINISH.items():
        body = spec.body(link)
        main = spec.geom(f"{link}_visual")
        main.material = f"finish_{finish}"
        main.rgba = [0.5, 0.5, 0.5, 1.0]  # MuJoCo's default: the material's colour applies
        lip = spec.geom(f"{link}_visual1")
        if lip is not None:  # the fingertip lip (a URDF visual box): rubber
            lip.material = "finish_black"
            lip.rgba = [0.5, 0.5, 0.5, 1.0]
        for path in sorted(mesh_dir.glob(f"{link}__*.stl")):
            part = path.stem.split("__", 1)[1]
            spec.add_mesh(name=path.stem, file=path.name)
            geom = body.add_geom(
                name=f"{link}_visual_{part}",
                type=mujoco.mjtGeom.mjGEOM_MESH,
                meshname=path.stem,
                material=f"finish_{part}",
            )
            geom.classname = visual
            geom.contype, geom.conaffinity, geom.group, geom.density = 0, 0, 2, 0.0
    assert set(MAIN_FINISH) == set(BUILDERS)


def hide(body: mujoco.MjsBody) -> None:
    """Move every colliding geom of ``body`` to group 3 (not drawn by default, as the robot's
    collision geoms); the dressing draws the body instead. Collisions are unchanged."""
    for geom in body.geoms:
        if geom.contype or geom.conaffinity:
            geom.group = 3


def dress_shelf(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    visual: mujoco.MjsDefault,
    x_front: float,
    depth: float,
    half_width: float,
    height: float,
    board_tops: Sequence[float],
    board_thickness: float,
    upright_y: Sequence[float],
) -> None:
    """Draw the shelf as pallet racking: upright frames, beams, decks and a mesh back panel.

    Args:
        spec: The scene (the bars are drawn as one mesh per colour).
        body: The shelf body.
        visual: The visual default class.
        x_front: x of the shelf's open front [m].
        depth: Depth along x [m].
        half_width: Half its width along y [m].
        height: Height of the top [m].
        board_tops: z of each board's top surface [m], bottom row first.
        board_thickness: Board thickness [m].
        upright_y: y of each upright frame's centre line [m].
    """
    boxes = _Boxes()
    post = 0.04  # half size of an upright post (a 80 mm column)
    xs = (x_front + post, x_front + depth - post - 0.02)
    for y in upright_y:
        for x in xs:
            boxes.add((x, y, height / 2), (post, 0.035, height / 2), UPRIGHT_RGBA)
        # zig-zag bracing between the two posts of the frame
        span = xs[1] - xs[0] - 2 * post
        n = max(2, round(height / 0.75))
        step = (height - 0.3) / n
        length = float(np.hypot(span, step))
        angle = float(np.arctan2(step, span))
        for k in range(n):
            z = 0.15 + (k + 0.5) * step
            sign = 1 if k % 2 == 0 else -1
            boxes.add(
                ((xs[0] + xs[1]) / 2, y, z), (length / 2, 0.012, 0.012), UPRIGHT_RGBA, -sign * angle
            )
    bays = list(pairwise(upright_y))
    levels = [*board_tops, height]
    for y0, y1 in bays:
        yc, half = (y0 + y1) / 2, (y1 - y0) / 2 - 0.035
        for r, top in enumerate(levels):
            for x in xs:
                # beams 5 mm below the deck's top, so the two never share a plane
                z = top - 0.005 - 0.055
                boxes.add((x, yc, z), (0.025, half, 0.055), BEAM_RGBA)
            if r < len(board_tops):
                boxes.add(
                    (x_front + depth / 2 - 0.01, yc, top - board_thickness / 4),
                    (depth / 2 - 0.07, half, board_thickness / 4),
                    DECK_RGBA,
                )
    _geom(
        body,
        visual,
        "rack_back_mesh",
        (x_front + depth - 0.01, 0.0, height / 2),
        (0.004, half_width, height / 2),
        MESH_RGBA,
    )
    boxes.flush(spec, body, visual, "rack")


def dress_bin(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    visual: mujoco.MjsDefault,
    center_xy: tuple[float, float],
    size_xy: tuple[float, float],
    height: float,
    floor_top: float,
) -> None:
    """Draw the bin as a wire-mesh pallet cage: a steel frame, a floor and see-through walls.

    Args:
        spec: The scene (the bars are drawn as one mesh per colour).
        body: The bin body.
        visual: The visual default class.
        center_xy: Centre of the bin on the floor [m].
        size_xy: Outer extents along x and y [m].
        height: Wall height [m].
        floor_top: z of the floor's top surface [m].
    """
    boxes = _Boxes()
    bx, by = center_xy
    hx, hy = size_xy[0] / 2, size_xy[1] / 2
    tube = 0.02
    boxes.add((bx, by, floor_top / 2), (hx, hy, floor_top / 2), FINISH_LOOK["dark"][0])
    for sx, sy in ((-1, -1), (-1, 1), (1, -1), (1, 1)):
        boxes.add(
            (bx + sx * (hx - tube), by + sy * (hy - tube), height / 2),
            (tube, tube, height / 2),
            CAGE_RGBA,
        )
    for z in (height - tube, height / 2):
        for dx, dy in ((0, 1), (1, 0)):
            for s in (-1, 1):
                boxes.add(
                    (bx + dx * s * (hx - tube), by + dy * s * (hy - tube), z),
                    (tube if dx else hx, tube if dy else hy, tube),
                    CAGE_RGBA,
                )
    # Mesh walls: a tinted see-through panel per side and the vertical wires of the grid.
    for axis, (dx, dy) in enumerate(((0, 1), (1, 0))):
        half = hx if dy else hy  # half the length of this pair of sides
        n = round(2 * half / CAGE_PITCH)
        for s in (-1, 1):
            side = f"{axis}_{'p' if s > 0 else 'n'}"
            x, y = bx + dx * s * (hx - tube), by + dy * s * (hy - tube)
            _geom(
                body,
                visual,
                f"cage_panel_{side}",
                (x, y, height / 2),
                (0.002 if dx else hx, 0.002 if dy else hy, height / 2),
                CAGE_MESH_RGBA,
            )
            for k in range(1, n):
                t = -half + k * CAGE_PITCH
                boxes.add(
                    (x + dy * t, y + dx * t, height / 2),
                    (CAGE_WIRE, CAGE_WIRE, height / 2),
                    CAGE_RGBA,
                )
    boxes.flush(spec, body, visual, "cage")


def dress_floor(
    spec: mujoco.MjSpec,
    visual: mujoco.MjsDefault,
    robot_xy: tuple[float, float],
    plate_half: float,
    marked: tuple[float, float, float, float],
    hall: tuple[float, float, float, float],
) -> None:
    """Concrete floor, background, the robot's floor plate, cell markings and hall walls.

    The floor plane (geom ``floor``, centred on the world origin) is drawn
    :data:`FLOOR_MARGIN` past the farthest hall corner, on a :data:`FLOOR_GRID` grid.

    Args:
        spec: The scene (the floor geom ``floor`` must use material ``floor``).
        visual: The visual default class.
        robot_xy: Where the robot's base stands [m].
        plate_half: Half side of the robot's steel floor plate [m].
        marked: The marked cell area on the floor, (x_min, y_min, x_max, y_max) [m].
        hall: The hall's walls, (x_min, y_min, x_max, y_max) [m]; walls stand at x_max and y_max.
    """
    spec.add_texture(
        name="skybox",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.62, 0.64, 0.66],
        rgb2=[0.3, 0.31, 0.32],
        width=64,
        height=384,
    )
    spec.add_texture(
        name="floor",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_FLAT,
        rgb1=[0.5, 0.5, 0.49],
        rgb2=[0.5, 0.5, 0.49],
        mark=mujoco.mjtMark.mjMARK_RANDOM,
        markrgb=[0.42, 0.42, 0.41],
        random=0.25,
        width=256,
        height=256,
    )
    floor_mat = spec.add_material(
        name="floor", texrepeat=[2, 2], texuniform=True, specular=0.15, shininess=0.2
    )
    floor_mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "floor"
    reach = max(abs(v) for v in hall) + FLOOR_MARGIN
    spec.geom("floor").size = [reach, reach, FLOOR_GRID]
    world = spec.worldbody
    rx, ry = robot_xy
    _geom(
        world,
        visual,
        "floor_plate",
        (rx, ry, 0.006),
        (plate_half, plate_half, 0.006),
        material="finish_steel",
    )
    x0, y0, x1, y1 = marked
    line = 0.04
    for name, c, half in (
        ("marking_xn", (x0, (y0 + y1) / 2), (line, (y1 - y0) / 2 + line)),
        ("marking_xp", (x1, (y0 + y1) / 2), (line, (y1 - y0) / 2 + line)),
        ("marking_yn", ((x0 + x1) / 2, y0), ((x1 - x0) / 2 + line, line)),
        ("marking_yp", ((x0 + x1) / 2, y1), ((x1 - x0) / 2 + line, line)),
    ):
        _geom(world, visual, name, (*c, 0.002), (*half, 0.002), MARKING_RGBA)
    hx0, hy0, hx1, hy1 = hall
    wall_h = 7.0
    for name, c, half in (
        ("hall_wall_x", (hx1, (hy0 + hy1) / 2), (0.1, (hy1 - hy0) / 2)),
        ("hall_wall_y", ((hx0 + hx1) / 2, hy1), ((hx1 - hx0) / 2, 0.1)),
    ):
        _geom(world, visual, name, (*c, wall_h / 2), (*half, wall_h / 2), WALL_RGBA)
        _geom(
            world,
            visual,
            f"{name}_dado",
            (*c, 0.6),
            (half[0] + 0.02, half[1] + 0.02, 0.6),
            DADO_RGBA,
        )


def add_lights(
    spec: mujoco.MjSpec, center: tuple[float, float, float], headlight: float = 0.2
) -> None:
    """Key (casts the shadows), fill and rim lights aimed at ``center`` [m], and a dim
    headlight (``headlight`` [0-1] diffuse) so no side is black."""
    # The key light's shadow map covers 0.25 x extent around the centre: texels small enough
    # that the default video quality (1024 px map) shows no shadow acne on the floor plate.
    spec.visual.map.shadowclip = 0.25
    spec.visual.headlight.ambient = [0.22, 0.22, 0.23]
    spec.visual.headlight.diffuse = [headlight] * 3
    spec.visual.headlight.specular = [0.05, 0.05, 0.05]
    world = spec.worldbody
    c = np.array(center)
    for name, offset, diffuse, specular, shadow in (
        ("key", (-2.5, -4.0, 7.0), (0.62, 0.6, 0.56), (0.3, 0.3, 0.3), True),
        ("fill", (-5.0, 3.0, 3.5), (0.22, 0.24, 0.27), (0.0, 0.0, 0.0), False),
        ("rim", (5.0, 4.0, 5.0), (0.3, 0.3, 0.32), (0.25, 0.25, 0.25), False),
    ):
        pos = c + offset
        direction = (c - pos) / np.linalg.norm(c - pos)
        world.add_light(
            name=name,
            pos=pos.round(6).tolist(),
            dir=direction.round(6).tolist(),
            type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
            diffuse=list(diffuse),
            specular=list(specular),
            castshadow=shadow,
        )
