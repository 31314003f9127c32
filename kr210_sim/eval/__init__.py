"""Evaluating many episodes of our own controller: episodes, the local and Ray backends, the
result stream and its summary, the failures worth replaying.

May import everything below it in the flow (errors ... sim, media); beside :mod:`kr210_sim.view`,
:mod:`kr210_sim.envs` and :mod:`kr210_sim.grading`, it imports none of them. Grading a class
moved to :mod:`kr210_sim.grading` in 0.2.0; ``from kr210_sim.eval import GradeSettings`` (and
``find_students``, ``run_check``) still works until 0.3.0, with a DeprecationWarning.
"""

from __future__ import annotations

from kr210_sim._moved import moved_attribute
from kr210_sim.eval.evaluate import EvalConfig, EvalOutcome

__all__ = ["EvalConfig", "EvalOutcome"]


def __getattr__(name: str) -> object:
    """The names that moved to :mod:`kr210_sim.grading` in 0.2.0 (PEP 562), with a warning."""
    return moved_attribute(__name__, name)
