"""What a cycle's observations mean: the outcome and its detail, metrics, and the report schema."""

from __future__ import annotations

from kr210_sim.score.report import build_report
from kr210_sim.score.result import CycleResult
from kr210_sim.score.scoring import Outcome, judge

__all__ = [
    "CycleResult",
    "Outcome",
    "build_report",
    "judge",
]
