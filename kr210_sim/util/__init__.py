"""Plumbing every command shares: where files live, atomic outputs, the console, signals, progress
lines, the values the command line takes."""

from __future__ import annotations

from kr210_sim.util.interrupts import Interrupted
from kr210_sim.util.outputs import check_writable, write_json_atomic
from kr210_sim.util.paths import ROOT, SCENE_PATH, URDF_PATH

__all__ = [
    "ROOT",
    "SCENE_PATH",
    "URDF_PATH",
    "Interrupted",
    "check_writable",
    "write_json_atomic",
]
