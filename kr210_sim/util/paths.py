"""Where the project's files live: the URDF, its meshes and the generated scenes.

In the source tree (a clone, or an editable install) they are the top-level ``assets/`` and
``scenes/`` folders. A wheel or a plain ``pip install .`` ships the same two folders inside the
package (``kr210_sim/assets``, ``kr210_sim/scenes``; see ``[tool.setuptools]`` in
``pyproject.toml``), so the committed scene's relative ``meshdir`` resolves in both layouts.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

#: The package folder (``kr210_sim/``).
PACKAGE_DIR: Path = Path(__file__).resolve().parents[1]


def find_root(environ: Mapping[str, str] | None = None) -> Path:
    """The folder holding ``assets/`` and ``scenes/``.

    ``KR210_SIM_ROOT`` wins when set and not empty; else the data shipped inside an installed
    package; else the source tree the package sits in.

    Args:
        environ: Environment to read (default: :data:`os.environ`).
    """
    env = os.environ if environ is None else environ
    override = env.get("KR210_SIM_ROOT", "").strip()
    if override:
        return Path(override)
    if (PACKAGE_DIR / "assets").is_dir():
        return PACKAGE_DIR
    return PACKAGE_DIR.parent


#: Root of the project's data (the folder holding ``assets/`` and ``scenes/``): see
#: :func:`find_root`. Override with the ``KR210_SIM_ROOT`` environment variable.
ROOT: Path = find_root()
ASSETS_DIR: Path = ROOT / "assets" / "kr210"
URDF_PATH: Path = ASSETS_DIR / "kr210.urdf"
MESH_DIR: Path = ASSETS_DIR / "meshes"
SCENES_DIR: Path = ROOT / "scenes"
SCENE_PATH: Path = SCENES_DIR / "kr210_cell.xml"
