"""Loading a cell model: a committed or given MJCF scene, or a cell file compiled on demand.

One entry for every command: :func:`model_for` (``--scene`` / ``--cell``) and :func:`model_at`
(a path that is either). A cell file is compiled through the MJCF builder
(:mod:`kr210_sim.cell.mjcf`), imported only then, so a run of the committed scene never loads
the builder or trimesh.
"""

from __future__ import annotations

import copy
import functools
from pathlib import Path

from kr210_sim.cell.spec import CellConfig
from kr210_sim.cell.toml import load_cell
from kr210_sim.errors import ConfigError, Kr210SimError, SceneError
from kr210_sim.util.paths import SCENE_PATH

import mujoco  # isort: skip  (after kr210_sim so MUJOCO_GL is chosen first)


def load_model(path: Path | str | None = None) -> mujoco.MjModel:
    """Load a cell model: the MJCF at ``path``, or the committed scene when None.

    Raises:
        SceneError: When the file is missing or MuJoCo rejects it.
    """
    path = Path(path) if path is not None else SCENE_PATH
    if path.is_dir():
        raise SceneError(f"scene {path} is a folder: give the MJCF file (e.g. {SCENE_PATH.name})")
    if not path.is_file():
        raise SceneError(f"scene not found: {path} (run `python -m kr210_sim build-scene`)")
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
