"""Offscreen rendering: the GL backend check, renderers sized to the scene, and stills.

Importing :mod:`kr210_sim` picks ``MUJOCO_GL=egl`` when no display is set, and imports mujoco
without OpenGL when ``MUJOCO_GL`` names a backend that cannot be loaded (the physics needs none);
when no backend works, :func:`make_renderer` raises :class:`RenderError` naming ``MUJOCO_GL`` and
what to install.
"""

from __future__ import annotations

import copy
import os
from pathlib import Path

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError, RenderError

import mujoco  # isort: skip

GL_HELP = (
    "no OpenGL backend for offscreen rendering (MUJOCO_GL={gl}): install Mesa's EGL "
    "(Debian/Ubuntu: apt-get install libegl1 libgl1-mesa-dri) and set MUJOCO_GL=egl, or "
    "install OSMesa (apt-get install libosmesa6) and set MUJOCO_GL=osmesa"
)


#: Largest frame side [px] (within every OpenGL implementation's renderbuffer limit).
MAX_FRAME = 8192


def camera_names(model: mujoco.MjModel) -> list[str]:
    """Names of the model's cameras."""
    return [model.camera(i).name for i in range(model.ncam)]


def check_camera(model: mujoco.MjModel, name: str) -> int:
    """Id of camera ``name``.

    Raises:
        ConfigError: When there is no such camera (the message lists the names that exist).
    """
    cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
    if cid < 0:
        raise ConfigError(f"no camera {name!r}; cameras: {', '.join(camera_names(model))}")
    return int(cid)


def check_frame_size(width: int, height: int) -> None:
    """Refuse a frame size no renderer takes.

    Raises:
        ConfigError: When the size is not whole numbers, not positive or larger than
            :data:`MAX_FRAME` per side.
    """
    for v in (width, height):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise ConfigError(
                f"frame size must be whole numbers of pixels, got {width!r}x{height!r}"
            )
    if width < 1 or height < 1:
        raise ConfigError(f"frame size must be positive, got {width}x{height}")
    if width > MAX_FRAME or height > MAX_FRAME:
        raise ConfigError(f"frame {width}x{height} is too large: at most {MAX_FRAME} px a side")


def make_renderer(model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """An offscreen renderer for ``model`` at ``width`` x ``height`` [px].

    The model's offscreen buffer (``vis.global_.offwidth/offheight``, a render-only field) is
    enlarged to fit when the frame is bigger than the scene's default.

    Raises:
        ConfigError: When the size is not positive or larger than :data:`MAX_FRAME` per side.
        RenderError: When no OpenGL backend can be started.
    """
    check_frame_size(width, height)
    from kr210_sim.util import gl as backend

    gl = os.environ.get("MUJOCO_GL", "unset")
    if backend.GL_IMPORT_ERROR is not None:
        raise RenderError(GL_HELP.format(gl=gl) + f" [{backend.GL_IMPORT_ERROR}]")
    glob = model.vis.global_
    glob.offwidth, glob.offheight = max(glob.offwidth, width), max(glob.offheight, height)
    try:
        return mujoco.Renderer(model, height=height, width=width)
    except Exception as exc:
        if backend.GL_CHOSEN_LATE:
            raise RenderError(
                "mujoco was imported before kr210_sim, so it did not see MUJOCO_GL=egl: "
                "import kr210_sim first, or set MUJOCO_GL=egl in the environment"
            ) from exc
        raise RenderError(GL_HELP.format(gl=gl) + f" [{type(exc).__name__}: {exc}]") from exc


#: Suffix of the robot's ``draw`` level mesh assets (:mod:`kr210_sim.cell.robot_model` writes
#: them; the runtime does not import the builder).
DRAW_SUFFIX = "_draw"


#: Tessellation of the built-in shapes at the draw level: (slices around a cylinder, stacks
#: along it, quads along a box face's side), against MuJoCo's defaults 28, 16, 4 (the scene's,
#: kept for stills and ``--quality high``). The stacks and quads only subdivide flat sides for
#: per-vertex lighting; a frame from the overview or bin camera differs from the fine one in
#: under 0.3 % of its pixels (the target cylinders' outlines) and costs 5-15 % less CPU
#: (``benchmarks/render_cost.py``: 18.1 -> 16.9 ms in one sitting).
DRAW_BUILTINS = (20, 2, 2)


def draw_level(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of ``model`` drawn at the video's level of detail: lighter robot meshes, coarser
    built-in shapes, and textures as their mean colour.

    Every visual geom (contype and conaffinity 0) whose mesh ``<name>`` has a ``<name>_draw``
    twin in the model draws the twin instead: about half the triangles (6,376 against 13,112
    for the robot), indistinguishable at 640x480 from the fixed cameras. Every material with a
    2D colour texture draws :func:`flat_textures`' mean colour instead. Built-in shapes
    (cylinders, boxes) are tessellated as :data:`DRAW_BUILTINS` says. Only render-side fields
    change (``geom_dataid`` of non-colliding geoms, material colours and textures,
    ``vis.quality``): the copy steps exactly as ``model``.
    """
    out = copy.copy(model)
    names = {model.mesh(i).name: i for i in range(model.nmesh)}
    for g in range(model.ngeom):
        if model.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH:
            continue
        if model.geom_contype[g] or model.geom_conaffinity[g]:
            continue
        twin = names.get(model.mesh(int(model.geom_dataid[g])).name + DRAW_SUFFIX)
        if twin is not None:
            out.geom_dataid[g] = twin
    flat_textures(out)
    quality = out.vis.quality
    quality.numslices, quality.numstacks, quality.numquads = DRAW_BUILTINS
    return out


def flat_textures(model: mujoco.MjModel) -> list[str]:
    """Draw every material's 2D colour texture as its mean colour (in place; render-side fields
    only): the material's ``rgba`` is multiplied by the texture's mean and the texture dropped.

    The floor's texture is a 2 mm speckle (a 256 px texture repeated twice a metre) that the
    mipmaps average to its mean over the few centimetres a 640x480 overview pixel covers;
    sampling it cost 13-22 % of a frame (two passes over most of the picture; 23.2 -> 18.1 ms
    in ``benchmarks/render_cost.py``). Applied to
    the model before its renderer is made (the GL context copies the texture ids).

    Returns:
        The names of the materials changed.
    """
    role = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)
    changed = []
    for m in range(model.nmat):
        t = int(model.mat_texid[m, role])
        if t < 0 or model.tex_type[t] != mujoco.mjtTexture.mjTEXTURE_2D:
            continue
        n = int(model.tex_nchannel[t])
        size = int(model.tex_width[t]) * int(model.tex_height[t]) * n
        adr = int(model.tex_adr[t])
        texels = np.asarray(model.tex_data[adr : adr + size]).reshape(-1, n)
        mean = texels[:, :3].mean(axis=0) / 255.0 if n >= 3 else np.repeat(texels.mean() / 255.0, 3)
        model.mat_rgba[m, :3] = model.mat_rgba[m, :3] * mean
        model.mat_texid[m, role] = -1
        changed.append(model.material(m).name)
    return changed


def shadow_casters(model: mujoco.MjModel) -> npt.NDArray[np.bool_]:
    """Per geom: does it cast a shadow that can show? Everything but the world body's own
    geoms (floor, hall walls, markings: flat or far, their shadows fall on nothing in view)."""
    return np.asarray(model.geom_bodyid != 0)


def limit_shadows(scene: mujoco.MjvScene, casters: npt.NDArray[np.bool_]) -> None:
    """Switch off shadow casting of the scene's geoms that are not ``casters`` (by geom id);
    call after every ``update_scene``. The shadow pass then draws only what casts."""
    geom = mujoco.mjtObj.mjOBJ_GEOM
    for i in range(scene.ngeom):
        g = scene.geoms[i]
        if g.objtype == geom and not casters[g.objid]:
            g.castshadow = 0


def render_frame(
    renderer: mujoco.Renderer, data: mujoco.MjData, camera: int | str, shadows: bool = True
) -> npt.NDArray[np.uint8]:
    """Render one RGB frame (height, width, 3) of ``data`` from ``camera``."""
    renderer.update_scene(data, camera=camera)
    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
    return renderer.render()


def snapshot(
    out: Path | str,
    camera: str = "overview",
    width: int = 1280,
    height: int = 720,
    model: mujoco.MjModel | None = None,
) -> Path:
    """Render a still of the cell (arm at its ready pose, a target in every slot) to a PNG.

    Args:
        out: PNG path.
        camera: Camera name.
        width: Width [px].
        height: Height [px].
        model: The cell model (default: the committed scene).

    Returns:
        The path written.
    """
    import imageio.v3 as iio

    from kr210_sim.cell.handles import CellHandles
    from kr210_sim.cell.layout import CellLayout
    from kr210_sim.cell.load import load_model
    from kr210_sim.cell.spec import MotionConfig
    from kr210_sim.util.outputs import check_writable, write_bytes_atomic

    path = check_writable(out)
    model = model if model is not None else load_model()
    check_camera(model, camera)
    layout = CellLayout.from_model(model)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    h = CellHandles.from_model(model)
    data.qpos[h.arm_qpos] = MotionConfig().ready_q
    for k in range(min(layout.n_slots, len(h.target_qpos))):
        a = int(h.target_qpos[k])
        data.qpos[a : a + 3] = layout.slots[k] + (0.0, 0.0, layout.target.length / 2.0)
        data.qpos[a + 3 : a + 7] = (1.0, 0.0, 0.0, 0.0)
    mujoco.mj_forward(model, data)
    renderer = make_renderer(model, width, height)
    try:
        frame = render_frame(renderer, data, camera)
    finally:
        renderer.close()
    return write_bytes_atomic(path, iio.imwrite("<bytes>", frame, extension=".png"))
