"""What the Python API's functions return: a read-only :class:`Report` of each kind, and the
:class:`RunInterrupted` that carries the report of the work a signal stopped.

Each report holds exactly the JSON its command writes (:attr:`Report.data`, :meth:`Report.to_dict`,
:meth:`Report.to_json`) and typed views of it. :mod:`kr210_sim.api` makes them.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from kr210_sim.util.interrupts import Interrupted
from kr210_sim.util.outputs import report_json

if TYPE_CHECKING:
    from kr210_sim.score.result import CycleResult

__all__ = ["EvalReport", "GradeReport", "IkCheckReport", "Report", "RunInterrupted", "RunReport"]


@dataclass(frozen=True)
class Report:
    """A report as the CLI writes it, read-only.

    Attributes:
        data: The JSON-ready report (use :meth:`to_dict` for a copy you may change).
        path: Where it was written (None: not written).
    """

    data: Mapping[str, Any] = field(repr=False)
    path: Path | None = None

    @property
    def summary(self) -> Mapping[str, Any]:
        """The report's ``summary`` block (read-only view)."""
        return MappingProxyType(self.data["summary"])

    def to_dict(self) -> dict[str, Any]:
        """A deep copy of the report: exactly the JSON the CLI writes, as Python objects."""
        return copy.deepcopy(dict(self.data))

    def to_json(self) -> str:
        """The report as the text the CLI writes to its report file."""
        return report_json(dict(self.data))


@dataclass(frozen=True)
class RunReport(Report):
    """What :func:`~kr210_sim.api.run` did.

    Attributes:
        cycles: One typed record per cycle (``success``, ``reason``, ``detail``, ``cycle_time``,
            ...; see :class:`~kr210_sim.score.result.CycleResult`).
        video_path: The MP4 written, or None.
        video_frames: Frames in it.
        video_error: Why the video could not be made (then :func:`~kr210_sim.api.run` raised),
            or None.
        plot_paths: PNG plots written.
        record_path: The recording written (``record=``), or None.
        record_frames: Frames in it.
    """

    cycles: tuple[CycleResult, ...] = ()
    video_path: Path | None = None
    video_frames: int = 0
    video_error: str | None = None
    plot_paths: tuple[Path, ...] = ()
    record_path: Path | None = None
    record_frames: int = 0

    @property
    def interrupted_by(self) -> str | None:
        """The signal that stopped the run early (``"SIGINT"``, ``"SIGTERM"``, ...), or None."""
        value = self.data["interrupted_by"]
        return str(value) if value is not None else None

    def passed(self, min_success: float = 0.8) -> bool:
        """Whether the success rate reaches ``min_success`` (the CLI's pass bar)."""
        return bool(self.summary["success_rate"] >= min_success)


@dataclass(frozen=True)
class EvalReport(Report):
    """What :func:`~kr210_sim.api.evaluate` did: the summary and the failed episodes' records
    (with a report path, every episode's record is in the episodes file beside it,
    ``data["episodes_file"]``)."""

    @property
    def failed_episodes(self) -> tuple[Mapping[str, Any], ...]:
        """One read-only record per failed episode (``seed``, ``reason``, ``detail``, ...)."""
        return tuple(MappingProxyType(e) for e in self.data["failed_episodes"])


@dataclass(frozen=True)
class IkCheckReport(Report):
    """What :func:`~kr210_sim.api.ik_check` did.

    Attributes:
        text: The table, worst cases and verdict the CLI prints.
        plot_paths: PNG plots written.
    """

    text: str = ""
    plot_paths: tuple[Path, ...] = ()

    @property
    def cases(self) -> tuple[Mapping[str, Any], ...]:
        """One read-only record per case (``position_error_m``, ``passed``, ...)."""
        return tuple(MappingProxyType(c) for c in self.data["cases"])

    @property
    def passed(self) -> bool:
        """Every case planned was tried (no signal stopped the check) and passed."""
        s = self.summary
        return self.data.get("interrupted") is None and bool(s["passed"] == s["cases"])


@dataclass(frozen=True)
class GradeReport(Report):
    """What :func:`~kr210_sim.api.grade` did: the leaderboard (``data`` is the JSON
    ``grade --report`` writes).

    Attributes:
        text: The table and verdict the CLI prints.
        html_path: The page written (``html=``), or None.
    """

    text: str = ""
    html_path: Path | None = None

    @property
    def students(self) -> tuple[Mapping[str, Any], ...]:
        """One read-only record per student, in leaderboard order (``name``, ``verdict``,
        ``detail``, ``ik_check``, ``run``, ``diagnosis``, ...)."""
        return tuple(MappingProxyType(s) for s in self.data["students"])

    @property
    def verdicts(self) -> Mapping[str, str]:
        """Each student's verdict by name (read-only)."""
        return MappingProxyType({s["name"]: s["verdict"] for s in self.data["students"]})

    @property
    def passed(self) -> bool:
        """Every student passed (and the grading ran to the end)."""
        return bool(self.summary["all_passed"])


class RunInterrupted(Interrupted):
    """Ctrl-C or a termination signal stopped a run, an evaluation or a grading; the report of
    what finished was written (when a path was given) and is in :attr:`report`.

    Args:
        signum: The signal's number.
        report: The report of the cycles, episodes or students that finished.
    """

    def __init__(self, signum: int, report: Report) -> None:
        super().__init__(signum)
        self.report = report
