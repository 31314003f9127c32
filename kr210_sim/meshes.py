"""Procedural visual meshes of the KR210 links, generated with trimesh.

Each mesh is built in its URDF link frame from cylinders, boxes and spheres (unions by
concatenation: these meshes are visual only) and written as binary STL. Generation is
deterministic: the same code writes byte-identical files. Colours come from the URDF materials.
``python -m kr210_sim build-meshes`` regenerates ``assets/kr210/meshes/``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import trimesh

from kr210_sim.outputs import check_folder, write_bytes_atomic
from kr210_sim.paths import MESH_DIR

#: Facets around a cylinder.
SECTIONS = 40


def _union(parts: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    """Concatenate meshes into one (no boolean: the meshes are visual only)."""
    mesh = trimesh.util.concatenate(parts)
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh


def _cyl(
    axis: str,
    radius: float,
    start: float,
    end: float,
    at: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> trimesh.Trimesh:
    """A cylinder of ``radius`` [m] along ``axis`` ("x", "y" or "z") from ``start`` to ``end`` [m]
    (coordinates along the axis), its axis through ``at`` (the other two coordinates)."""
    length = end - start
    mesh = trimesh.creation.cylinder(radius=radius, height=length, sections=SECTIONS)
    centre = np.array(at, dtype=float)
    idx = "xyz".index(axis)
    centre[idx] = (start + end) / 2.0
    if axis == "x":
        mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    elif axis == "y":
        mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    mesh.apply_translation(centre)
    return mesh


def _box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> trimesh.Trimesh:
    """An axis-aligned box between corners ``lo`` and ``hi`` [m]."""
    lo_a, hi_a = np.array(lo, float), np.array(hi, float)
    mesh = trimesh.creation.box(extents=hi_a - lo_a)
    mesh.apply_translation((lo_a + hi_a) / 2.0)
    return mesh


def _rounded_box(
    lo: tuple[float, float, float], hi: tuple[float, float, float], radius: float
) -> trimesh.Trimesh:
    """A box with its four edges parallel to y rounded by ``radius`` [m] (two boxes and four
    cylinders)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    r = radius
    parts = [
        _box((x0 + r, y0, z0), (x1 - r, y1, z1)),
        _box((x0, y0, z0 + r), (x1, y1, z1 - r)),
    ]
    for x in (x0 + r, x1 - r):
        for z in (z0 + r, z1 - r):
            parts.append(_cyl("y", r, y0, y1, (x, 0.0, z)))
    return _union(parts)


def _base_link() -> trimesh.Trimesh:
    return _union(
        [
            _cyl("z", 0.42, 0.0, 0.05),
            _cyl("z", 0.34, 0.05, 0.28),
            _cyl("z", 0.38, 0.28, 0.33),
        ]
    )


def _link_1() -> trimesh.Trimesh:
    return _union(
        [
            _cyl("z", 0.39, 0.0, 0.16),
            _rounded_box((-0.05, -0.24, 0.12), (0.44, 0.24, 0.5), 0.08),
            _cyl("y", 0.2, -0.25, 0.25, (0.35, 0.0, 0.42)),
            _cyl("z", 0.13, 0.16, 0.42, (-0.12, 0.0, 0.0)),  # joint_1 motor, behind the column
        ]
    )


def _link_2() -> trimesh.Trimesh:
    return _union(
        [
            _cyl("y", 0.19, -0.11, 0.11),
            _rounded_box((-0.12, -0.1, 0.0), (0.12, 0.1, 1.25), 0.05),
            _cyl("y", 0.16, -0.11, 0.11, (0.0, 0.0, 1.25)),
        ]
    )


def _link_3() -> trimesh.Trimesh:
    return _union(
        [
            _cyl("y", 0.17, -0.14, 0.14),
            _rounded_box((-0.42, -0.14, -0.17), (0.32, 0.14, 0.15), 0.06),
            _cyl("x", 0.12, 0.3, 0.96, (0.0, 0.0, -0.054)),
            # axis 4-6 motors at the back of the forearm housing
            _cyl("x", 0.06, -0.5, -0.4, (0.0, -0.08, -0.03)),
            _cyl("x", 0.06, -0.5, -0.4, (0.0, 0.08, -0.03)),
            _cyl("x", 0.06, -0.5, -0.4, (0.0, 0.0, 0.08)),
        ]
    )


def _link_4() -> trimesh.Trimesh:
    return _union(
        [
            _cyl("x", 0.11, 0.0, 0.38),
            _box((0.36, -0.1, -0.07), (0.46, 0.1, 0.07)),
            _box((0.4, 0.075, -0.06), (0.58, 0.105, 0.06)),
            _box((0.4, -0.105, -0.06), (0.58, -0.075, 0.06)),
        ]
    )


def _link_5() -> trimesh.Trimesh:
    return _union(
        [
            _cyl("y", 0.07, -0.075, 0.075),
            _cyl("x", 0.065, 0.0, 0.17),
        ]
    )


def _link_6() -> trimesh.Trimesh:
    return _union(
        [
            _cyl("x", 0.075, 0.0, 0.02),
            _cyl("x", 0.05, 0.02, 0.035),
        ]
    )


def _gripper_link() -> trimesh.Trimesh:
    return _union(
        [
            _rounded_box((-0.075, -0.1, -0.05), (0.075, 0.1, 0.05), 0.015),
        ]
    )


def _finger() -> trimesh.Trimesh:
    return _box((-0.075, -0.013, -0.025), (0.075, 0.013, 0.025))


#: Mesh builders by URDF link name.
BUILDERS: dict[str, Callable[[], trimesh.Trimesh]] = {
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


def build_mesh(link: str) -> trimesh.Trimesh:
    """The visual mesh of URDF link ``link``, in its link frame [m]."""
    mesh = BUILDERS[link]()
    mesh.merge_vertices()
    return mesh


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
    """Write every link mesh as ``<link>.stl`` into ``out_dir``; return the paths written.

    A file that already holds the same bytes is left untouched.

    Raises:
        ConfigError: When ``out_dir`` or a mesh file cannot be written.
    """
    out = check_folder(out_dir)
    paths = []
    for link in BUILDERS:
        path = out / f"{link}.stl"
        data = stl_bytes(build_mesh(link))
        if not path.is_file() or path.read_bytes() != data:
            write_bytes_atomic(path, data)
        paths.append(path)
    return paths
