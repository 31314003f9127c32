"""Evaluating many episodes: episodes, local and Ray backends, the result stream and summary, the
IK check, and grading a class of IK solutions (grade, student, diagnose, leaderboard)."""

from __future__ import annotations

from kr210_sim.eval.evaluate import EvalConfig, EvalOutcome
from kr210_sim.eval.grade import GradeSettings, find_students
from kr210_sim.eval.ikcheck import run_check

__all__ = [
    "EvalConfig",
    "EvalOutcome",
    "GradeSettings",
    "find_students",
    "run_check",
]
