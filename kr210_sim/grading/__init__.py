"""Grading a class: each student's IK checked, run and judged, in the jail, with a verdict an
instructor can take to a course.

* :mod:`~kr210_sim.grading.grade` grades a class folder
  (:func:`~kr210_sim.grading.grade.find_students`), one student at a time or on workers,
  into records (:mod:`~kr210_sim.grading.record`) and a roster (:mod:`~kr210_sim.grading.roster`);
* :mod:`~kr210_sim.grading.student` finds and identifies one student's solution;
* :mod:`~kr210_sim.grading.ikcheck` checks an IK on the exercise's poses
  (:func:`~kr210_sim.grading.ikcheck.run_check`), :mod:`~kr210_sim.grading.ik_debug` on the
  exercise's own ``IK_debug.py`` cases;
* :mod:`~kr210_sim.grading.diagnose` and :mod:`~kr210_sim.grading.finding` explain a failure in
  the student's terms, :mod:`~kr210_sim.grading.misses` names the failed cases and cycles no
  pattern explains, and :mod:`~kr210_sim.grading.explain` gives ``ik-check`` and ``run --ik``
  the same diagnoses; :mod:`~kr210_sim.grading.clock` times a student's own time and
  :mod:`~kr210_sim.grading.budget` sets what fits in it;
  :mod:`~kr210_sim.grading.leaderboard` ranks a class;
* :mod:`~kr210_sim.grading.gradebook` scores each verdict and writes the CSV an LMS gradebook
  imports (``grade --csv``), :mod:`~kr210_sim.grading.gradescope` one submission's Gradescope
  ``results.json`` (``grade --gradescope``); :mod:`~kr210_sim.grading.course` checks both
  before the grading and writes them after.

May import everything below it in the flow (errors, util, robot, exercise, sandbox, cell, plan,
score, sim); nothing imports it but the jobs, the API and the commands. Until 0.2.0 these
modules lived in :mod:`kr210_sim.eval` (the old paths still work, with a DeprecationWarning,
until 0.3.0).
"""

from __future__ import annotations

from kr210_sim.grading.grade import GradeSettings, find_students
from kr210_sim.grading.ikcheck import run_check

__all__ = ["GradeSettings", "find_students", "run_check"]
