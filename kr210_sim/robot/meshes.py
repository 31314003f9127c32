"""Procedural visual meshes of the KR210 links, generated with trimesh.

Each link is built in its URDF link frame from convex, closed pieces (bevelled discs, tapered
drums, rounded boxes and convex hulls of such outlines), grouped by finish: ``<link>.stl`` holds
the parts in the link's URDF material (KUKA orange for the arm, dark grey for the base and the
gripper body, steel for the flange and fingers), and ``<link>__<finish>.stl`` the parts in
another finish (motors, counterbalance, flange, gripper jaws), which
:mod:`kr210_sim.cell.dressing` adds as extra visual geoms with their materials. Every piece is a
closed solid, so every file is watertight; MuJoCo computes the vertex normals (smooth across
the fine facets of the round parts, sharp at box edges).

Proportions follow photographs of the KR210 (KR QUANTEC series): round base frame with its
cable connection box at the back, rotating column with the A1 and A2 motors, the
counterbalance cylinder beside A2, a tapered rocker (link 2), the arm with the A3 motor and
the A4-A6 motor pack at its back, the in-line wrist and an ISO 9409-1-A125 tool flange.
Generation is deterministic: the same code writes byte-identical files.
``python -m kr210_sim build-meshes`` regenerates ``assets/kr210/meshes/``.

Three levels of detail come from the same builders (:data:`LEVELS`):

* ``fine``: the drawn meshes of stills, close-ups and viewers (32 facets round a large part);
* ``draw``: the meshes the video renderer draws at 640x480 from the fixed cameras, with half
  the facets (``meshes/draw_*.stl``, swapped in by :func:`kr210_sim.media.render.draw_level`);
* ``collide``: the points of the robot's hull colliders (:func:`collider_points`): every round
  outline circumscribed with just enough facets that it stands at most :data:`COLLIDER_EXCESS`
  proud of the round part it covers, every rounded box by its plain box, so each collider
  encloses every fine and draw vertex of its parts with a few dozen hull vertices.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import numpy.typing as npt
import trimesh

from kr210_sim.util.outputs import check_folder, write_bytes_atomic
from kr210_sim.util.paths import MESH_DIR

#: Facets around a round part.
SECTIONS = 32
#: Largest distance [m] a collider's circumscribed outline stands proud of its round part.
COLLIDER_EXCESS = 0.004
#: File name prefix of the ``draw`` level's meshes (``draw_<fine file name>``, same folder:
#: MuJoCo's URDF import strips folders from mesh paths).
DRAW_PREFIX = "draw_"
#: The levels of detail (see the module's docstring).
LEVELS = ("fine", "draw", "collide")
_level = "fine"

#: Finishes (materials) of the mesh parts; each link's URDF material is its main finish.
FINISHES = ("orange", "dark", "black", "steel", "alu")
#: The finish of ``<link>.stl`` (the URDF visual) per link.
MAIN_FINISH: dict[str, str] = {
    "base_link": "dark",
    "link_1": "orange",
    "link_2": "orange",
    "link_3": "orange",
    "link_4": "orange",
    "link_5": "orange",
    "link_6": "steel",
    "gripper_link": "dark",
    "right_gripper_finger_link": "steel",
    "left_gripper_finger_link": "steel",
}

Parts = dict[str, list[trimesh.Trimesh]]
_AXES = {"x": 0, "y": 1, "z": 2}


def _hull(points: npt.ArrayLike) -> trimesh.Trimesh:
    """The convex hull of ``points`` [m] (a closed, outward-facing solid)."""
    pts = np.round(np.asarray(points, dtype=float).reshape(-1, 3), 9)
    mesh = trimesh.convex.convex_hull(pts)
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh


def _sections(radius: float) -> int:
    """Facets around a round part of ``radius`` [m] at the current level: fewer for small parts,
    half as many for ``draw``; for ``collide`` the fewest (at least 6) whose circumscribed
    outline stays within :data:`COLLIDER_EXCESS` of the circle."""
    if _level == "collide":
        return max(6, math.ceil(math.pi / math.acos(radius / (radius + COLLIDER_EXCESS))))
    n = 12 if radius < 0.012 else 24 if radius < 0.04 else SECTIONS
    return n // 2 if _level == "draw" else n


@contextlib.contextmanager
def _at_level(level: str) -> Iterator[None]:
    """Build meshes at ``level`` (one of :data:`LEVELS`) inside the block."""
    global _level
    if level not in LEVELS:
        raise ValueError(f"level must be one of {LEVELS}, got {level!r}")
    before, _level = _level, level
    try:
        yield
    finally:
        _level = before


def _circle(
    axis: str, radius: float, along: float, at: tuple[float, float, float], n: int = 0
) -> npt.NDArray[np.float64]:
    """``n`` points (default by size) on a circle of ``radius`` [m] around ``axis``, at
    coordinate ``along`` on the axis, the axis passing through ``at`` (its other two
    coordinates)."""
    n = n or _sections(radius)
    i = _AXES[axis]
    j, k = (i + 1) % 3, (i + 2) % 3
    t = (np.arange(n) + 0.5) * 2.0 * np.pi / n
    if _level == "collide":  # circumscribed: the polygon encloses the circle
        radius /= math.cos(math.pi / n)
    pts = np.zeros((n, 3))
    pts[:, i] = along
    pts[:, j] = at[j] + radius * np.cos(t)
    pts[:, k] = at[k] + radius * np.sin(t)
    return pts


def _drum(
    axis: str,
    start: float,
    end: float,
    radius: float,
    at: tuple[float, float, float] = (0.0, 0.0, 0.0),
    bevel: float = 0.0,
    end_radius: float | None = None,
) -> trimesh.Trimesh:
    """A round part along ``axis`` from ``start`` to ``end`` [m], ``radius`` at the start and
    ``end_radius`` (default the same) at the end, its rims bevelled by ``bevel`` [m]."""
    r1 = radius if end_radius is None else end_radius
    b = bevel
    s = 1.0 if end > start else -1.0
    rings = [
        _circle(axis, radius - b, start, at),
        _circle(axis, radius, start + s * b, at),
        _circle(axis, r1, end - s * b, at),
        _circle(axis, r1 - b, end, at),
    ]
    return _hull(np.vstack(rings))


def _rbox(
    lo: tuple[float, float, float], hi: tuple[float, float, float], radius: float
) -> trimesh.Trimesh:
    """A box between corners ``lo`` and ``hi`` [m] with every edge rounded by ``radius`` [m]."""
    lo_a, hi_a = np.array(lo, float) + radius, np.array(hi, float) - radius
    if _level == "collide":
        ball = _enclosing_ball(radius)
    else:
        count = [4, 6] if _level == "draw" else [6, 8]
        ball = trimesh.creation.uv_sphere(radius=radius, count=count).vertices
    corners = [
        ball + np.array([x, y, z])
        for x in (lo_a[0], hi_a[0])
        for y in (lo_a[1], hi_a[1])
        for z in (lo_a[2], hi_a[2])
    ]
    return _hull(np.vstack(corners))


def _enclosing_ball(radius: float) -> npt.NDArray[np.float64]:
    """Points whose hull encloses a ball of ``radius`` [m] and stands at most
    :data:`COLLIDER_EXCESS` proud of it (for a large ball at least 7 % of its radius): a
    cube's corners for a small ball, else an icosphere scaled out to its inradius."""
    if radius * (math.sqrt(3.0) - 1.0) <= COLLIDER_EXCESS:
        return radius * np.array([(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    sub = 0 if radius * (1.0 / 0.79465 - 1.0) <= COLLIDER_EXCESS else 1
    ico = trimesh.creation.icosphere(subdivisions=sub)
    hull = trimesh.convex.convex_hull(ico.vertices)
    inner = np.abs(np.einsum("ij,ij->i", hull.face_normals, hull.vertices[hull.faces[:, 0]]))
    return np.asarray(ico.vertices) * (radius / float(inner.min()))


def _slab(
    centres: list[tuple[float, float, float, float]], half_y: float, bevel: float
) -> trimesh.Trimesh:
    """A plate in the x-z plane, ``half_y`` [m] thick each side of y = 0, bounded by the hull
    of discs (x, z, radius, y offset) [m], its rims bevelled by ``bevel`` [m]."""
    rings = []
    for x, z, r, dy in centres:
        for y, rr in (
            (-half_y, r - bevel),
            (-half_y + bevel, r),
            (half_y - bevel, r),
            (half_y, r - bevel),
        ):
            rings.append(_circle("y", rr, y + dy, (x, 0.0, z)))
    return _hull(np.vstack(rings))


def _base_link() -> Parts:
    """Base frame: a foot plate with rounded corners, the round frame casting, the turntable
    bearing ring and the cable connection box at the back (-x)."""
    # a square plate with round corners: the hull of four bevelled discs
    foot = _hull(
        np.vstack(
            [
                _drum("z", 0.0, 0.05, 0.1, (sx * 0.23, sy * 0.23, 0.0), bevel=0.012).vertices
                for sx in (-1, 1)
                for sy in (-1, 1)
            ]
        )
    )
    casting = _drum("z", 0.05, 0.3, 0.37, bevel=0.03, end_radius=0.33)
    ring = _drum("z", 0.29, 0.33, 0.35, bevel=0.008)
    box = _rbox((-0.405, -0.13, 0.07), (-0.26, 0.13, 0.25), 0.02)
    plugs = [_drum("x", -0.405, -0.415, 0.032, (0.0, y, 0.16), bevel=0.005) for y in (-0.06, 0.06)]
    bolts = [
        _drum("z", 0.05, 0.07, 0.018, (sx * 0.25, sy * 0.25, 0.0), bevel=0.004)
        for sx in (-1, 1)
        for sy in (-1, 1)
    ]
    return {"dark": [foot, casting, box], "steel": [ring, *plugs, *bolts]}


def _link_1() -> Parts:
    """Rotating column: turntable, a casting that rises to the A2 axis (0.35, 0, 0.42), the A2
    gear housings, the A1 motor at the back, the A2 motor on the -y side and the counterbalance
    cylinder on the +y side, from a pivot at the back of the column to an eye at A2."""
    turntable = _drum("z", 0.0, 0.13, 0.38, bevel=0.025, end_radius=0.36)
    column = _hull(
        np.vstack(
            [
                _rbox((-0.2, -0.22, 0.1), (0.32, 0.22, 0.16), 0.04).vertices,
                _slab([(0.35, 0.42, 0.17, 0.0)], 0.21, 0.04).vertices,
                _slab([(0.05, 0.33, 0.1, 0.0)], 0.2, 0.04).vertices,
            ]
        )
    )
    hubs = [_drum("y", s * 0.2, s * 0.27, 0.2, (0.35, 0.0, 0.42), bevel=0.025) for s in (-1, 1)]
    a1_motor = _drum("z", 0.12, 0.42, 0.085, (-0.2, -0.1, 0.0), bevel=0.015)
    a1_cap = _drum("z", 0.42, 0.46, 0.06, (-0.2, -0.1, 0.0), bevel=0.01)
    a2_motor = _drum("y", -0.27, -0.46, 0.09, (0.2, 0.0, 0.55), bevel=0.015)
    a2_flange = _drum("y", -0.22, -0.28, 0.11, (0.2, 0.0, 0.55), bevel=0.01)
    a2_cap = _drum("y", -0.46, -0.5, 0.065, (0.2, 0.0, 0.55), bevel=0.01)
    # Counterbalance: housing from the rear pivot towards A2, piston rod to the eye at A2.
    pivot, eye = np.array([-0.3, 0.34, 0.3]), np.array([0.35, 0.34, 0.42])
    cb_dir = (eye - pivot) / np.linalg.norm(eye - pivot)
    housing = _along(pivot + 0.04 * cb_dir, pivot + 0.5 * cb_dir, 0.085, 0.015)
    rod = _along(pivot + 0.48 * cb_dir, eye, 0.03, 0.004)
    eye_boss = _drum("y", 0.29, 0.39, 0.06, (0.35, 0.0, 0.42), bevel=0.012)
    pivot_boss = _drum("y", 0.2, 0.39, 0.05, (pivot[0], 0.0, pivot[2]), bevel=0.01)
    return {
        "orange": [turntable, column, *hubs],
        "black": [a1_motor, a2_motor, housing],
        "dark": [a1_cap, a2_flange, a2_cap, pivot_boss],
        "steel": [rod, eye_boss],
    }


def _along(
    a: npt.NDArray[np.float64], b: npt.NDArray[np.float64], radius: float, bevel: float
) -> trimesh.Trimesh:
    """A bevelled round part of ``radius`` [m] from point ``a`` to point ``b`` [m]."""
    length = float(np.linalg.norm(b - a))
    mesh = _drum("z", 0.0, length, radius, bevel=bevel)
    z = (b - a) / length
    tf = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], z)
    tf[:3, 3] = a
    mesh.apply_transform(tf)
    return mesh


def _link_2() -> Parts:
    """Tapered rocker from the A2 hub (r 0.2) to the A3 hub (r 0.16), 1.25 m long."""
    rocker = _slab(
        [(0.0, 0.0, 0.19, 0.0), (0.0, 0.62, 0.135, 0.0), (0.0, 1.25, 0.155, 0.0)], 0.1, 0.03
    )
    cover = _drum("y", -0.1, -0.125, 0.12, (0.0, 0.0, 0.0), bevel=0.008)
    cover_top = _drum("y", 0.1, 0.125, 0.1, (0.0, 0.0, 1.25), bevel=0.008)
    return {"orange": [rocker, cover], "dark": [cover_top]}


def _link_3() -> Parts:
    """Arm: the A3 housing, a casting that carries the forearm tube to A4 (0.96, 0, -0.054),
    the A3 motor on the -y side and the A4-A6 motor pack at the back."""
    zc = -0.054
    housing = _hull(
        np.vstack(
            [
                _slab([(0.0, 0.0, 0.17, 0.0)], 0.15, 0.035).vertices,
                _rbox((0.25, -0.13, -0.17), (0.42, 0.13, 0.08), 0.05).vertices,
                _rbox((-0.28, -0.13, -0.13), (-0.1, 0.13, 0.1), 0.05).vertices,
            ]
        )
    )
    tube = _drum("x", 0.38, 0.96, 0.125, (0.0, 0.0, zc), bevel=0.0, end_radius=0.112)
    seam = _drum("x", 0.9, 0.96, 0.116, (0.0, 0.0, zc), bevel=0.004)
    a3_motor = _drum("y", -0.14, -0.32, 0.08, (-0.08, 0.0, 0.13), bevel=0.014)
    a3_cap = _drum("y", -0.32, -0.35, 0.055, (-0.08, 0.0, 0.13), bevel=0.008)
    pack = _rbox((-0.42, -0.13, -0.11), (-0.24, 0.13, 0.1), 0.03)
    motors = [
        _drum("x", -0.42, -0.56, 0.058, (0.0, y, z), bevel=0.012)
        for y, z in ((-0.065, -0.045), (0.065, -0.045), (0.0, 0.06))
    ]
    plugs = [
        _rbox((-0.52, y - 0.02, z + 0.05), (-0.46, y + 0.02, z + 0.075), 0.006)
        for y, z in ((-0.065, -0.045), (0.065, -0.045), (0.0, 0.06))
    ]
    return {
        "orange": [housing, tube],
        "dark": [seam, a3_cap, pack],
        "black": [a3_motor, *motors],
        "steel": plugs,
    }


def _link_4() -> Parts:
    """In-line wrist, A4 part: the rotating tube and the fork that carries A5 at x = 0.54."""
    tube = _drum("x", 0.005, 0.36, 0.11, bevel=0.01, end_radius=0.1)
    yoke = _hull(
        np.vstack(
            [
                _circle("x", 0.1, 0.34, (0.0, 0.0, 0.0)),
                _rbox((0.38, -0.105, -0.08), (0.42, 0.105, 0.08), 0.03).vertices,
            ]
        )
    )
    cheeks = []
    for s in (-1, 1):
        y0, y1 = (0.076, 0.105) if s > 0 else (-0.105, -0.076)
        cheeks.append(
            _hull(
                np.vstack(
                    [
                        _rbox((0.38, y0, -0.075), (0.44, y1, 0.075), 0.012).vertices,
                        _drum("y", y0, y1, 0.075, (0.54, 0.0, 0.0), bevel=0.01).vertices,
                    ]
                )
            )
        )
    return {"orange": [tube, yoke, *cheeks]}


def _link_5() -> Parts:
    """In-line wrist, A5 part: the rounded housing between the fork cheeks and its nose."""
    hub = _drum("y", -0.074, 0.074, 0.07, bevel=0.018)
    nose = _hull(
        np.vstack(
            [
                _circle("x", 0.066, 0.0, (0.0, 0.0, 0.0)),
                _drum("x", 0.12, 0.19, 0.062, bevel=0.01).vertices,
            ]
        )
    )
    caps = [_drum("y", s * 0.105, s * 0.115, 0.055, bevel=0.006) for s in (-1, 1)]
    return {"orange": [hub, nose], "dark": caps}


def _link_6() -> Parts:
    """Tool flange, ISO 9409-1-A125: a 125 mm disc with its centring spigot and bolt heads."""
    disc = _drum("x", 0.0, 0.028, 0.0625, bevel=0.004)
    spigot = _drum("x", 0.028, 0.034, 0.025, bevel=0.002)
    bolts = [
        _drum("x", 0.028, 0.034, 0.0065, (0.0, 0.05 * np.cos(a), 0.05 * np.sin(a)), bevel=0.0015)
        for a in np.arange(6) * np.pi / 3 + np.pi / 6
    ]
    return {"steel": [disc, spigot], "dark": bolts}


def _gripper_link() -> Parts:
    """Parallel gripper in the published palm box (0.15 x 0.20 x 0.10 m): an adapter plate on
    the flange, the gripper body with its jaw guide on the front face."""
    body = _rbox((-0.058, -0.1, -0.05), (0.055, 0.1, 0.05), 0.012)
    adapter = _drum("x", -0.075, -0.058, 0.07, bevel=0.004)
    guide = _rbox((0.05, -0.1, -0.032), (0.075, 0.1, 0.032), 0.006)
    ports = [_drum("z", 0.05, 0.058, 0.008, (-0.03, y, 0.0), bevel=0.002) for y in (-0.035, 0.035)]
    return {"dark": [guide], "alu": [body], "steel": [adapter, *ports]}


def _finger() -> Parts:
    """A gripper jaw in the published finger box (0.15 x 0.026 x 0.05 m): the base jaw in the
    guide, the finger with a bevelled tip; the retaining lip is the URDF's own visual box."""
    jaw = _rbox((-0.075, -0.013, -0.025), (-0.035, 0.013, 0.025), 0.004)
    finger = _hull(
        np.vstack(
            [
                _rbox((-0.04, -0.011, -0.022), (0.06, 0.011, 0.022), 0.004).vertices,
                _rbox((0.06, -0.011, -0.018), (0.075, 0.011, 0.018), 0.004).vertices,
            ]
        )
    )
    return {"dark": [jaw], "steel": [finger]}


#: Mesh builders by URDF link name: each returns its parts grouped by finish.
BUILDERS: dict[str, Callable[[], Parts]] = {
    "base_link": _base_link,
    "link_1": _link_1,
    "link_2": _link_2,
    "link_3": _link_3,
    "link_4": _link_4,
    "link_5": _link_5,
    "link_6": _link_6,
    "gripper_link": _gripper_link,
    "right_gripper_finger_link": _finger,
    "left_gripper_finger_link": _finger,
}


def _join(parts: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    mesh = trimesh.util.concatenate(parts)
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh


def build_parts(link: str, level: str = "fine") -> dict[str, trimesh.Trimesh]:
    """The visual mesh of URDF link ``link`` by finish (the main finish first), link frame [m],
    at ``level`` of detail (see :data:`LEVELS`)."""
    with _at_level(level):
        parts = BUILDERS[link]()
    order = [MAIN_FINISH[link], *(f for f in FINISHES if f != MAIN_FINISH[link])]
    return {f: _join(parts[f]) for f in order if parts.get(f)}


def collider_points(link: str) -> dict[str, npt.NDArray[np.float64]]:
    """Hull vertices [m] (n, 3), link frame, of one collider per finish of ``link``'s mesh (the
    finishes of :func:`build_parts`): the convex hull of that finish's parts built at the
    ``collide`` level, which encloses the finish's ``fine`` and ``draw`` vertices."""
    return {
        f: np.asarray(_hull(mesh.vertices).vertices, dtype=np.float64)
        for f, mesh in build_parts(link, "collide").items()
    }


def mesh_file(link: str, finish: str) -> str:
    """File name of the ``finish`` part of ``link``'s visual mesh."""
    return f"{link}.stl" if finish == MAIN_FINISH[link] else f"{link}__{finish}.stl"


def stl_bytes(mesh: trimesh.Trimesh) -> bytes:
    """Binary STL of ``mesh`` with a fixed header (so files are byte-identical across runs)."""
    tri = np.asarray(mesh.triangles, dtype=np.float32)
    normals = np.asarray(mesh.face_normals, dtype=np.float32)
    record = np.zeros(len(tri), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    record["n"] = normals
    record["v"] = tri
    header = b"kr210_sim procedural mesh".ljust(80, b" ")
    return header + np.uint32(len(tri)).tobytes() + record.tobytes()


def build_meshes(out_dir: Path | str = MESH_DIR) -> list[Path]:
    """Write every link's mesh parts (``<link>.stl``, ``<link>__<finish>.stl``) into
    ``out_dir``, and their ``draw`` level as ``draw_<name>`` beside them; return the paths
    written.

    A file that already holds the same bytes is left untouched.

    Raises:
        ConfigError: When ``out_dir`` or a mesh file cannot be written.
    """
    out = check_folder(out_dir)
    paths = []
    for link in BUILDERS:
        for level, prefix in (("fine", ""), ("draw", DRAW_PREFIX)):
            for finish, mesh in build_parts(link, level).items():
                path = out / (prefix + mesh_file(link, finish))
                data = stl_bytes(mesh)
                if not path.is_file() or path.read_bytes() != data:
                    write_bytes_atomic(path, data)
                paths.append(path)
    return paths
