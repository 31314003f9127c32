"""Procedural meshes: deterministic, present, and matching the collision geometry."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from kr210_sim.meshes import BUILDERS, build_meshes
from kr210_sim.paths import MESH_DIR


def test_build_is_byte_identical_and_committed_files_are_current(tmp_path: Path) -> None:
    a = build_meshes(tmp_path / "a")
    b = build_meshes(tmp_path / "b")
    for pa, pb in zip(a, b, strict=True):
        assert pa.read_bytes() == pb.read_bytes()
        assert (MESH_DIR / pa.name).read_bytes() == pa.read_bytes(), "run build-meshes"


def test_every_link_has_a_sound_mesh() -> None:
    for link in BUILDERS:
        mesh = trimesh.load(MESH_DIR / f"{link}.stl")
        assert len(mesh.faces) > 10 and mesh.area > 0
        assert len(mesh.faces) < 10_000


def test_palm_and_fingers_match_their_published_boxes() -> None:
    palm = trimesh.load(MESH_DIR / "gripper_link.stl").bounds
    assert np.allclose(palm, [[-0.075, -0.1, -0.05], [0.075, 0.1, 0.05]], atol=1e-6)
    finger = trimesh.load(MESH_DIR / "right_gripper_finger_link.stl").bounds
    assert np.allclose(finger, [[-0.075, -0.013, -0.025], [0.075, 0.013, 0.025]], atol=1e-6)
