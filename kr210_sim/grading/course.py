"""The files ``grade`` hands a course: Gradescope's ``results.json`` (``--gradescope``,
:mod:`~kr210_sim.grading.gradescope`) and a gradebook CSV (``--csv``,
:mod:`~kr210_sim.grading.gradebook`).

Both are checked before any student is graded (:meth:`CourseOutputs.check`: writable, no
file another output or a student's file, and ``--gradescope`` for one submission only, as
Gradescope runs its autograder once per submission), so a grading of hours never ends in an
output that cannot be written; and both are written from the grade's report once it is done,
or interrupted (:meth:`CourseOutputs.write`: of the students graded).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kr210_sim.errors import ConfigError


@dataclass(frozen=True, slots=True)
class CourseOutputs:
    """Where ``grade --gradescope`` and ``--csv`` write (None: not asked for).

    Attributes:
        gradescope: Gradescope's ``results.json``.
        csv: The gradebook CSV.
    """

    gradescope: Path | None = None
    csv: Path | None = None

    def check(self, submissions: Sequence[str | Path], others: Mapping[str, Path | None]) -> None:
        """Refuse, before anyone is graded, what could not be written as asked.

        Args:
            submissions: The grade's SUBMISSION arguments.
            others: The grade's other outputs by option (``--report``, ``--html``).

        Raises:
            ConfigError: Naming the option and what to do.
        """
        if self.gradescope is None and self.csv is None:
            return
        from kr210_sim.grading.roster import find_students
        from kr210_sim.sandbox.user_ik import spec_file
        from kr210_sim.util.outputs import check_distinct, check_writable

        students = find_students(submissions)
        if self.gradescope is not None and len(students) != 1:
            raise ConfigError(
                f"--gradescope writes one submission's results.json, and {len(students)} "
                "students were found: give the one submission's folder or file "
                "(see examples/gradescope)"
            )
        outputs = {**others, "--gradescope": self.gradescope, "--csv": self.csv}
        check_distinct(
            outputs, {f"student {s.name}": spec_file(s.spec) for s in students if s.spec}
        )
        for path in (self.gradescope, self.csv):
            if path is not None:
                check_writable(path)

    def write(self, report: Mapping[str, Any]) -> list[str]:
        """Write what was asked for from a grade's ``report``; a line per file written (the
        results.json only when its student was graded).

        Raises:
            ConfigError: A file cannot be written.
        """
        said = []
        if self.csv is not None:
            from kr210_sim.grading.gradebook import write_gradebook

            said.append(f"gradebook: {write_gradebook(self.csv, report)}")
        if self.gradescope is not None and report["students"]:
            from kr210_sim.grading.gradescope import write_results

            said.append(f"gradescope: {write_results(self.gradescope, report)}")
        return said
