"""The cell: its specification, cell files (TOML), the MJCF builder, dressing, and the layout read
back from a model."""

from __future__ import annotations

from kr210_sim.cell.handles import CellHandles
from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import load_model, model_at, model_for
from kr210_sim.cell.spec import CellConfig, MotionConfig
from kr210_sim.cell.toml import load_cell

__all__ = [
    "CellConfig",
    "CellHandles",
    "CellLayout",
    "MotionConfig",
    "load_cell",
    "load_model",
    "model_at",
    "model_for",
]
