"""Procedural meshes: deterministic, committed, closed, small, and inside the published boxes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from kr210_sim.robot.meshes import (
    BUILDERS,
    MAIN_FINISH,
    build_meshes,
    build_parts,
    collider_points,
    mesh_file,
)
from kr210_sim.util.paths import MESH_DIR


def test_build_is_byte_identical_and_committed_files_are_current(tmp_path: Path) -> None:
    a = build_meshes(tmp_path / "a")
    b = build_meshes(tmp_path / "b")
    for pa, pb in zip(a, b, strict=True):
        assert pa.read_bytes() == pb.read_bytes()
        assert (MESH_DIR / pa.name).read_bytes() == pa.read_bytes(), "run build-meshes"
    assert sorted(p.name for p in a) == sorted(p.name for p in MESH_DIR.glob("*.stl"))


def test_every_mesh_file_is_a_closed_solid_within_budget() -> None:
    total = 0
    for path in sorted(MESH_DIR.glob("*.stl")):
        mesh = trimesh.load(path)
        assert mesh.is_watertight, path.name
        assert mesh.is_winding_consistent and mesh.volume > 0, path.name
        assert 10 < len(mesh.faces) < 10_000, path.name
        total += path.stat().st_size
    assert total < 5_000_000


def test_each_link_has_its_urdf_visual_as_the_main_finish() -> None:
    for link in BUILDERS:
        parts = build_parts(link)
        assert next(iter(parts)) == MAIN_FINISH[link]
        assert mesh_file(link, MAIN_FINISH[link]) == f"{link}.stl"
        assert (MESH_DIR / f"{link}.stl").is_file()
    assert set(build_parts("link_1")) >= {"orange", "black", "steel"}  # motors, counterbalance


def test_gripper_body_and_jaws_stay_in_their_published_boxes() -> None:
    body = build_parts("gripper_link")
    lo, hi = (
        np.vstack([body["alu"].bounds, body["dark"].bounds]).min(0),
        np.vstack([body["alu"].bounds, body["dark"].bounds]).max(0),
    )
    assert np.all(lo >= [-0.075 - 1e-9, -0.1 - 1e-9, -0.05 - 1e-9])
    assert np.all(hi <= [0.075 + 1e-9, 0.1 + 1e-9, 0.05 + 1e-9])
    finger = trimesh.load(MESH_DIR / "right_gripper_finger_link.stl").bounds
    jaw = trimesh.load(MESH_DIR / "right_gripper_finger_link__dark.stl").bounds
    both = np.vstack([finger, jaw])
    assert np.allclose(
        [both.min(0), both.max(0)], [[-0.075, -0.013, -0.025], [0.075, 0.013, 0.025]], atol=1e-3
    )


def test_draw_level_halves_the_triangles_and_colliders_enclose_both_levels() -> None:
    """The video's meshes carry about half the triangles; each collider's hull holds every
    vertex of its finish at both drawn levels and stands at most 7 mm proud of the fine hull."""
    fine_faces = draw_faces = points = fine_points = 0
    for link in BUILDERS:
        fine, draw = build_parts(link), build_parts(link, "draw")
        for finish, pts in collider_points(link).items():
            hull = trimesh.convex.convex_hull(pts)
            normals = hull.face_normals
            offsets = np.einsum("ij,ij->i", normals, hull.vertices[hull.faces[:, 0]])
            for mesh in (fine[finish], draw[finish]):
                assert (mesh.vertices @ normals.T - offsets).max() < 1e-6, (link, finish)
            fine_hull = trimesh.convex.convex_hull(fine[finish].vertices)
            proud = -trimesh.proximity.signed_distance(fine_hull, pts).min()
            assert proud < 0.007, (link, finish, proud)
            points += len(pts)
            fine_points += len(fine_hull.vertices)
            fine_faces += len(fine[finish].faces)
            draw_faces += len(draw[finish].faces)
    assert draw_faces < 0.6 * fine_faces  # 6,376 of 13,112
    assert points < 0.4 * fine_points  # 1,224 of 3,280
