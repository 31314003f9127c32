"""Loading a cell model: a committed or given MJCF scene, or a cell file compiled on demand.

One entry for every command: :func:`model_for` (``--scene`` / ``--cell``) and :func:`model_at`
(a path that is either). A cell file is compiled through the MJCF builder
(:mod:`kr210_sim.cell.mjcf`), imported only then, so a run of the committed scene never loads
the builder or trimesh.
"""

from __future__ import annotations

import copy
import functools
import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from kr210_sim.cell.spec import CellConfig
from kr210_sim.cell.toml import load_cell
from kr210_sim.errors import ConfigError, Kr210SimError, SceneError
from kr210_sim.util.paths import SCENE_PATH

import mujoco  # isort: skip  (after kr210_sim so MUJOCO_GL is chosen first)


def load_model(path: Path | str | None = None) -> mujoco.MjModel:
    """Load a cell model: the MJCF at ``path``, or the committed scene when None.

    Raises:
        SceneError: When the file is missing, is a cell file (``.toml``) or MuJoCo rejects it.
    """
    path = Path(path) if path is not None else SCENE_PATH
    if path.is_dir():
        raise SceneError(f"scene {path} is a folder: give the MJCF file (e.g. {SCENE_PATH.name})")
    if path.exists() and not path.is_file():  # a FIFO would block MuJoCo's read for ever
        raise SceneError(
            f"scene {path} is not a regular file (a FIFO or a device): give an MJCF file"
        )
    if not path.is_file():
        raise SceneError(f"scene not found: {path} (run `python -m kr210_sim build-scene`)")
    if path.suffix.lower() == ".toml":  # MuJoCo would say "XML parse error" and no more
        raise SceneError(
            f"scene {path} is a cell file, not MJCF: give it with --cell (cell= in Python)"
        )
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except Exception as exc:
        reason = " ".join(str(exc).split())  # MuJoCo's messages span several lines
        raise SceneError(f"MuJoCo cannot load scene {path}: {reason}") from exc


def compile_cell(cell: CellConfig) -> mujoco.MjModel:
    """Compile a cell to a model, through MJCF text exactly as ``build-scene`` writes it (so the
    published cell compiles to the committed scene's model). Cached by the cell's value."""
    return _compile_cached(cell)


@functools.lru_cache(maxsize=8)
def _compile_cached(cell: CellConfig) -> mujoco.MjModel:
    from kr210_sim.cell.mjcf import scene_xml  # the builder, only when a cell is compiled

    xml = scene_xml(cell)
    try:
        return mujoco.MjModel.from_xml_string(xml)
    except Exception as exc:  # pragma: no cover - build_spec compiled it already
        raise Kr210SimError(f"cell {cell.name} does not load: {exc}") from exc


def model_at(path: Path | str | None) -> mujoco.MjModel:
    """The model of ``path``: a cell file (``.toml``) compiled, an MJCF scene loaded, or the
    committed scene for None (what recordings and evaluation workers name as their "scene").

    Raises:
        ConfigError: A bad cell file.
        SceneError: When the scene cannot be loaded.
    """
    if path is not None and Path(path).suffix.lower() == ".toml":
        return model_for(None, Path(path))
    return model_for(Path(path) if path is not None else None, None)


def model_for(scene: Path | None = None, cell: Path | None = None) -> mujoco.MjModel:
    """The model a command simulates: ``--cell`` compiled, ``--scene`` loaded, or the committed
    scene (a copy: callers may change it).

    Raises:
        ConfigError: When both are given, or the cell file is bad.
        SceneError: When the scene cannot be loaded.
    """
    if scene is not None and cell is not None:
        raise ConfigError("give --scene or --cell, not both (a cell compiles to a scene)")
    if cell is not None:
        return copy.copy(compile_cell(load_cell(cell)))
    return load_model(scene)


def model_identity(model: mujoco.MjModel) -> str:
    """The SHA-256 of the compiled model, hex: every array, option and size it holds, but not
    the file paths it was loaded from.

    Taken of the model as loaded, before a run changes it: the same scene or cell compiled by the
    same MuJoCo gives the same digest however its file was named (``scenes/kr210_cell.xml``, an
    absolute path, a copy under ``KR210_SIM_ROOT``) and however the model was built (from an
    MJCF file, a cell description or a spec), and any change that reaches the compiled model (a
    moved shelf, another mesh, a restyled material) gives another. MuJoCo's own saved model
    (``mj_saveModel``) holds the mesh file paths as spelled, so it is not used.
    """
    h = hashlib.sha256()
    for name in _identity_fields(model):
        value = getattr(model, name)
        h.update(name.encode())
        if isinstance(value, np.ndarray):
            h.update(f"{value.dtype.str}{value.shape}".encode())
            h.update(np.ascontiguousarray(value).tobytes())
        else:  # opt, vis, stat: MuJoCo's structs of numbers
            h.update(_struct_bytes(value))
    return h.hexdigest()


def _identity_fields(model: mujoco.MjModel) -> list[str]:
    """The model's array and struct attributes that :func:`model_identity` hashes, sorted."""
    skip = {"paths"}
    out = []
    for name in sorted(dir(model)):
        if name.startswith("_") or name in skip or name.endswith("_pathadr"):
            continue
        value = getattr(model, name, None)
        if isinstance(value, np.ndarray) or name in ("opt", "vis", "stat"):
            out.append(name)
    return out


def _struct_bytes(value: Any) -> bytes:
    """The numbers of one of MuJoCo's structs (and its nested structs), as bytes."""
    parts: list[bytes] = []
    for name in sorted(dir(value)):
        if name.startswith("_"):
            continue
        v = getattr(value, name)
        if callable(v):
            continue
        if isinstance(v, (int, float, bool, np.ndarray, np.generic)):
            parts.append(name.encode() + np.asarray(v).tobytes())
        elif not isinstance(v, (str, bytes)):
            parts.append(name.encode() + _struct_bytes(v))
    return b"".join(parts)
