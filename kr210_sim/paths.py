"""Where the project's files live: the URDF, its meshes and the generated scenes."""

from __future__ import annotations

import os
from pathlib import Path

#: Root of the project tree (the folder holding ``assets/`` and ``scenes/``). Override with the
#: ``KR210_SIM_ROOT`` environment variable when the package is installed away from its sources.
ROOT: Path = Path(os.environ.get("KR210_SIM_ROOT", Path(__file__).resolve().parents[1]))
ASSETS_DIR: Path = ROOT / "assets" / "kr210"
URDF_PATH: Path = ASSETS_DIR / "kr210.urdf"
MESH_DIR: Path = ASSETS_DIR / "meshes"
SCENES_DIR: Path = ROOT / "scenes"
SCENE_PATH: Path = SCENES_DIR / "kr210_cell.xml"
