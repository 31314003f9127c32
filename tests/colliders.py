"""Does the robot's collision geometry enclose its visual meshes? (Measured, per link.)

The contact monitor and the planner's collision checks only see colliders; a link whose visual
mesh sticks out of them can strike the cell unseen. :func:`stick_out` measures, per link, the
largest distance of a visual vertex outside the link's colliders, using the convex hull MuJoCo
itself computed for each mesh collider (``mesh_graph``).
"""

from __future__ import annotations

import mujoco
import numpy as np

FloatArray = np.ndarray


def hull_planes(model: mujoco.MjModel, geom: int) -> tuple[np.ndarray, np.ndarray]:
    """Outward normals (n, 3) and offsets (n,) of a mesh geom's convex hull, in the geom frame,
    from the hull MuJoCo computed and collides with (``mesh_graph``)."""
    mesh = model.geom_dataid[geom]
    adr = model.mesh_graphadr[mesh]
    g = model.mesh_graph[adr:]
    nv, nf = int(g[0]), int(g[1])
    # layout: numvert, numface, vert_edgeadr[nv], vert_globalid[nv], edge_localid[nv + 3 nf],
    # face_globalid[3 nf]
    start = 2 + 2 * nv + nv + 3 * nf
    faces = g[start : start + 3 * nf].reshape(nf, 3)
    a, k = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
    verts = model.mesh_vert[a : a + k]
    tri = verts[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    d = np.einsum("ij,ij->i", n, tri[:, 0])
    centre = verts.mean(axis=0)
    flip = (n @ centre - d) > 0  # make every normal point away from the inside
    n[flip], d[flip] = -n[flip], -d[flip]
    return n, d


def outside(model: mujoco.MjModel, data: mujoco.MjData, geom: int, p: np.ndarray) -> np.ndarray:
    """Distance [m] of world points ``p`` (k, 3) outside collider ``geom`` (0 inside)."""
    R = data.geom_xmat[geom].reshape(3, 3)
    local = (p - data.geom_xpos[geom]) @ R
    size = model.geom_size[geom]
    t = model.geom_type[geom]
    if t == mujoco.mjtGeom.mjGEOM_BOX:
        return np.linalg.norm(np.maximum(np.abs(local) - size, 0.0), axis=1)
    if t == mujoco.mjtGeom.mjGEOM_CYLINDER:
        radial = np.maximum(np.linalg.norm(local[:, :2], axis=1) - size[0], 0.0)
        axial = np.maximum(np.abs(local[:, 2]) - size[1], 0.0)
        return np.hypot(radial, axial)
    if t == mujoco.mjtGeom.mjGEOM_MESH:
        n, d = hull_planes(model, geom)
        return np.maximum((local @ n.T - d).max(axis=1), 0.0)
    raise ValueError(f"collider type {t} not handled")


def stick_out(model: mujoco.MjModel, with_hulls: bool = True) -> dict[str, float]:
    """Largest visual-vertex distance [m] outside each link's colliders, at the home pose."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    out: dict[str, float] = {}
    for b in range(model.nbody):
        geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == b]
        visuals = [
            g
            for g in geoms
            if model.geom_contype[g] == 0 and model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH
        ]
        colliders = [
            g
            for g in geoms
            if model.geom_contype[g] != 0
            and (with_hulls or model.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH)
        ]
        if not visuals or not colliders:
            continue
        worst = 0.0
        for v in visuals:
            mesh = model.geom_dataid[v]
            a, k = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
            R = data.geom_xmat[v].reshape(3, 3)
            p = model.mesh_vert[a : a + k] @ R.T + data.geom_xpos[v]
            dist = np.min([outside(model, data, c, p) for c in colliders], axis=0)
            worst = max(worst, float(dist.max()))
        out[model.body(b).name] = worst
    return out
