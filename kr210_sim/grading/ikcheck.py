"""``ik-check``: grade a user's IK function on fixed and random poses, with exact error figures.

The successor of the original exercise's debug script. Cases, by group:

* ``ik_debug``: the three cases of that script, ``IK_debug.py`` (:mod:`kr210_sim.grading.ik_debug`:
  a pose and the joint angles Gazebo showed for it; ``q_ref`` is those angles). For each, the
  report's ``ik_debug`` rows and the table give what the script printed: the wrist-centre
  error, the theta errors against Gazebo's angles and the end-effector error.
* ``cell``: the poses a run needs in the published cell, from the planner's own pose functions:
  standoff, grasp, lift and lifted standoff ("retreat") for each of the nine slots, and the drop
  pose for each drop spot. ``q_ref`` is the joint state the planner comes from (the ready pose
  for standoffs and drops, our IK's answer for the previous pose of the pick otherwise).
* ``zero``: q = 0 (gripper_link at (2.153, 0, 1.946); also a wrist singularity).
* ``singular``: poses with q5 at or near 0, where only q4 + q6 is defined.
* ``limits``: each joint 1 mrad inside its lower and its upper limit.
* ``random``: ``forward(q)`` of N seeded random joint states inside the limits.

For the non-cell groups ``q_ref`` is the joint state that generated the pose, so an IK that
picks the solution nearest ``q_ref`` moves no joint at all. Each answer is judged by
:func:`kr210_sim.sandbox.ik_guard.assess` (our forward kinematics); a case passes when the position
error is <= 1 mm, the orientation error <= 1 mrad and q is inside the limits. An answer that is
not the solution nearest ``q_ref`` (ours, :meth:`Kinematics.nearest`) by more than 0.1 rad in
some joint is flagged with the kind of branch change (a wrist flip, a 2 pi jump, another arm
branch), not failed: ``run`` fails such jumps only between neighbouring straight-line samples.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError, UnreachablePoseError
from kr210_sim.grading.diagnose import diagnose
from kr210_sim.grading.finding import finding_lines, notes_of, spared
from kr210_sim.grading.ik_debug import ik_debug_poses, ik_debug_rows, ik_debug_table
from kr210_sim.robot.description import ARM_JOINTS, RobotDescription, load_robot
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sandbox.ik_guard import (
    BATCH,
    MAX_LINE_STEP,
    ORIENTATION_TOL,
    POSITION_TOL,
    Assessment,
    assess,
    branch_change,
    call_many,
)
from kr210_sim.sandbox.user_ik import UserIk
from kr210_sim.util.interrupts import signal_name, winding_up
from kr210_sim.util.progress import ProgressLine, bar

if TYPE_CHECKING:
    import mujoco

FloatArray = npt.NDArray[np.float64]

#: Groups in the order the table lists them (and the cases are tried in).
GROUPS = ("ik_debug", "cell", "zero", "singular", "limits", "random")
#: Worst cases printed after the table.
WORST_SHOWN = 5
#: How far inside a joint limit the ``limits`` cases sit [rad].
LIMIT_MARGIN = 1e-3
#: A moderate joint state the ``singular`` and ``limits`` cases start from [rad].
BASE_Q = (0.3, 0.2, -0.3, 0.5, 0.6, -0.4)
#: q5 values of the ``singular`` group [rad].
SINGULAR_Q5 = (0.0, 1e-9, 1e-6, -1e-6, 1e-3, -1e-3, 1e-2)


@dataclass(frozen=True, slots=True)
class Case:
    """One pose to solve.

    Attributes:
        group: Group name (see :data:`GROUPS`).
        name: Case name, unique in the check.
        T: Requested gripper_link pose (4x4).
        q_ref: Joint state passed with it [rad].
    """

    group: str
    name: str
    T: FloatArray
    q_ref: FloatArray


def ik_debug_cases(kin: Kinematics) -> list[Case]:
    """The ``IK_debug.py`` cases ``kin``'s robot can reach, named ``IK_debug case 1`` to ``3``,
    with Gazebo's joint angles as ``q_ref``."""
    return [Case("ik_debug", f"IK_debug case {i}", T, q) for i, T, q in ik_debug_poses(kin)]


def cell_cases(kin: Kinematics, model: mujoco.MjModel | None = None) -> list[Case]:
    """The gripper poses of every slot's cycle plan in the published cell (or ``model``'s; the
    nominal target, from the cell's ready pose; its drop pose is left to the drop-spot cases)
    and the drop pose of every drop spot, as the planner of ``kin``'s robot computes them."""
    from kr210_sim.cell.layout import CellLayout, ready_pose
    from kr210_sim.cell.load import load_model
    from kr210_sim.cell.spec import MotionConfig
    from kr210_sim.plan.planner import Planner
    from kr210_sim.sim.runner import RunConfig, sample_target

    model = model if model is not None else load_model()
    layout = CellLayout.from_model(model)
    ready = tuple(float(v) for v in ready_pose(model))
    # the poses need no collision checks
    planner = Planner(kin.robot, MotionConfig(ready_q=ready))  # type: ignore[arg-type]
    rng = np.random.default_rng(0)  # unused: the nominal target draws nothing
    cases: list[Case] = []
    for slot in range(1, layout.n_slots + 1):
        target = sample_target(rng, RunConfig(), layout, slot)
        plan = planner.plan_cycle(planner.ready_q, target.position, target.spec, layout.drop_spots)
        for step in plan.steps:  # q_ref: where the plan's move to the pose starts
            if step.T is not None and step.move is not None and step.pose != "drop":
                q_ref = step.move.trajectory.q_start.copy()
                cases.append(Case("cell", f"slot {slot} {step.pose}", step.T, q_ref))
    for i, drop in enumerate(layout.drop_spots, start=1):
        T = planner.drop_pose(drop, layout.target.radius)
        cases.append(Case("cell", f"drop spot {i}", T, planner.ready_q.copy()))
    return cases


def _from_q(kin: Kinematics, group: str, name: str, q: npt.ArrayLike) -> Case:
    qa = np.asarray(q, dtype=np.float64)
    return Case(group, name, kin.forward(qa), qa.copy())


def fixed_cases(kin: Kinematics) -> list[Case]:
    """The fixed set for ``kin``'s robot: ik_debug, cell, zero, singular and limits groups."""
    g = kin.geometry
    cases = ik_debug_cases(kin) + cell_cases(kin)
    cases.append(_from_q(kin, "zero", "q = 0", np.zeros(6)))
    for q5 in SINGULAR_Q5:
        q = np.array(BASE_Q)
        q[4] = q5
        cases.append(_from_q(kin, "singular", f"q5 = {q5:g}", q))
    for j in range(6):
        for side, value in (
            ("lower", g.lower[j] + LIMIT_MARGIN),
            ("upper", g.upper[j] - LIMIT_MARGIN),
        ):
            q = np.array(BASE_Q)
            q[j] = value
            cases.append(_from_q(kin, "limits", f"{ARM_JOINTS[j]} {side}", q))
    return cases


def random_cases(kin: Kinematics, n: int, seed: int) -> list[Case]:
    """``n`` poses from joint states drawn uniformly inside ``kin``'s limits (seeded)."""
    g = kin.geometry
    q = np.random.default_rng(seed).uniform(g.lower, g.upper, size=(n, 6))
    return [_from_q(kin, "random", f"random {i + 1}", q[i]) for i in range(n)]


def _num(x: float) -> float | None:
    return None if math.isnan(x) else float(x)


def case_record(kin: Kinematics, case: Case, a: Assessment) -> dict[str, Any]:
    """The report's record of one case (its branch compared with ``kin``'s nearest answer)."""
    branch = ""
    if a.q is not None:  # compare with the answer nearest q_ref (ours)
        try:
            branch = branch_change(a.q, kin.nearest(case.T, case.q_ref))
        except UnreachablePoseError:  # pragma: no cover - every case is reachable
            branch = ""
    return {
        "group": case.group,
        "name": case.name,
        "position": [round(float(v), 6) for v in case.T[:3, 3]],
        "q_ref": [round(float(v), 9) for v in case.q_ref],
        "q": None if a.q is None else [float(v) for v in a.q],
        "passed": a.passed,
        "problem": a.problem or None,
        "error": a.error or None,
        "returned_none": a.returned_none,
        "position_error_m": _num(a.position_error),
        "orientation_error_rad": _num(a.orientation_error),
        "wrist_centre_error_m": _num(a.wrist_centre_error),
        "within_limits": a.within_limits,
        "wrapped_joints": [ARM_JOINTS[j] for j in a.wrapped],
        "max_joint_move_rad": _num(a.max_move),
        "max_joint_move_joint": ARM_JOINTS[a.max_move_joint] if a.max_move_joint >= 0 else None,
        "branch_change": branch or None,
        "wall_time_s": a.call_time,
    }


def _badness(r: dict[str, Any]) -> float:
    """How far a case is from passing: inf when there is no answer, else the larger of the
    errors in units of their limits (plus 1 when q leaves the limits)."""
    if r["q"] is None:
        return math.inf
    return max(
        r["position_error_m"] / POSITION_TOL, r["orientation_error_rad"] / ORIENTATION_TOL
    ) + (0.0 if r["within_limits"] else 1.0)


def _worst(records: list[dict[str, Any]], key: str) -> float | None:
    values = [r[key] for r in records if r[key] is not None]
    return max(values) if values else None


def summarise(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Summary: counts, pass rate, worst errors, per-group figures, time per call [s]."""
    n = len(records)
    passed = sum(r["passed"] for r in records)
    times = np.array([r["wall_time_s"] for r in records]) if n else np.zeros(1)
    groups: dict[str, Any] = {}
    for name in GROUPS:
        rs = [r for r in records if r["group"] == name]
        if not rs:
            continue
        groups[name] = {
            "cases": len(rs),
            "passed": sum(r["passed"] for r in rs),
            "max_position_error_m": _worst(rs, "position_error_m"),
            "max_orientation_error_rad": _worst(rs, "orientation_error_rad"),
            "branch_changes": sum(r["branch_change"] is not None for r in rs),
        }
    return {
        "cases": n,
        "passed": passed,
        "pass_rate": passed / n if n else 0.0,
        "max_position_error_m": _worst(records, "position_error_m"),
        "max_orientation_error_rad": _worst(records, "orientation_error_rad"),
        "max_wrist_centre_error_m": _worst(records, "wrist_centre_error_m"),
        "raised": sum(r["error"] is not None for r in records),
        "returned_none": sum(r["returned_none"] for r in records),
        "outside_limits": sum(r["q"] is not None and not r["within_limits"] for r in records),
        "branch_changes": sum(r["branch_change"] is not None for r in records),
        "groups": groups,
        "wall_time_s": {
            "per_call_mean": float(times.mean()),
            "per_call_max": float(times.max()),
            "total": float(times.sum()),
        },
    }


def check(
    kin: Kinematics,
    ik: UserIk,
    cases: list[Case],
    progress: TextIO | None = None,
    records: list[dict[str, Any]] | None = None,
) -> list[dict[str, Any]]:
    """Call ``ik`` on every case and judge each answer with ``kin``; one record per case (an IK
    that takes batches, a ROS-form server, is asked :data:`~kr210_sim.sandbox.ik_guard.BATCH`
    cases per request).

    Args:
        kin: The kinematics that judge the answers.
        ik: The IK under check.
        cases: The poses, tried in this order.
        progress: Stream for the progress line (None: stderr).
        records: A list the records are appended to as they come (so the caller keeps those of
            the cases done when a signal stops the check); None: a new one.
    """
    line = ProgressLine(progress or sys.stderr)
    line.last = line.start  # the first line only after an interval: quick checks stay quiet
    shown = False
    records = [] if records is None else records
    step = BATCH if ik.batch is not None else 1
    for first in range(0, len(cases), step):
        chunk = cases[first : first + step]
        got = call_many(ik, [c.T for c in chunk], [c.q_ref for c in chunk])
        for case, (raw, dt) in zip(chunk, got, strict=True):
            records.append(
                case_record(
                    kin,
                    case,
                    assess(kin, case.T, case.q_ref, raw, dt, no_q_ref=ik.batch is not None),
                )
            )
        i = first + len(chunk)
        if line.due() or (shown and i == len(cases)):
            shown = True
            line.show(f"ik-check {bar(i / len(cases))} {i}/{len(cases)} cases")
    if shown:
        line.end()
    return records


def build_report(
    spec: str,
    n_random: int,
    seed: int,
    records: list[dict[str, Any]],
    wall_time: float,
    kin: Kinematics | None = None,
    planned: int | None = None,
    interrupted: BaseException | None = None,
    diagnosis: list[dict[str, str]] | None = None,
) -> dict[str, Any]:
    """The JSON-ready report of a check.

    Args:
        spec: The IK's SPEC.
        n_random: Random cases asked for.
        seed: Their seed.
        records: One per case tried.
        wall_time: Wall time of the check [s].
        kin: The kinematics that judged it, for the ``ik_debug`` rows (None: the committed
            robot's).
        planned: Cases the check was to try (None: as many as ``records``).
        interrupted: The interrupt that stopped it after ``len(records)`` cases, or None.
        diagnosis: The findings, as ``grade`` makes them
            (:func:`~kr210_sim.grading.diagnose.diagnose`; None: none made).
    """
    from kr210_sim.util.versions import versions

    return {
        "kind": "kr210_sim.ik_check",
        "config": {
            "ik": spec,
            "random_cases": n_random,
            "seed": seed,
            "position_tol_m": POSITION_TOL,
            "orientation_tol_rad": ORIENTATION_TOL,
            "branch_change_threshold_rad": MAX_LINE_STEP,
        },
        "summary": summarise(records),
        "cases_planned": len(records) if planned is None else planned,
        "interrupted": None if interrupted is None else signal_name(interrupted),
        "ik_debug": ik_debug_rows(kin or Kinematics(load_robot()), records),
        "diagnosis": diagnosis or [],
        "cases": records,
        "wall_time_s": wall_time,
        "versions": versions(),
    }


def _mm(x: float | None) -> str:
    return "-" if x is None else f"{1000 * x:.3g}"


def table(report: dict[str, Any]) -> str:
    """The plain-text result: a table by group, the worst cases and the verdict line."""
    s = report["summary"]
    head = f"  {'group':<9}{'cases':>7}{'passed':>8}{'worst pos [mm]':>16}"
    head += f"{'worst ori [mrad]':>18}{'branch changes':>16}"
    rows = [head]
    for name, gs in s["groups"].items():
        rows.append(
            f"  {name:<9}{gs['cases']:>7}{gs['passed']:>8}{_mm(gs['max_position_error_m']):>16}"
            f"{_mm(gs['max_orientation_error_rad']):>18}{gs['branch_changes']:>16}"
        )
    rows += ik_debug_table(report.get("ik_debug", []))
    t = s["wall_time_s"]
    rows.append(
        f"  time per call: mean {1e6 * t['per_call_mean']:.1f} us, max "
        f"{1e6 * t['per_call_max']:.1f} us ({s['cases']} calls, {t['total']:.3f} s)"
    )
    failing = sorted((r for r in report["cases"] if not r["passed"]), key=_badness, reverse=True)
    if failing:
        rows.append(f"  worst cases ({len(failing)} failed):")
        for r in failing[:WORST_SHOWN]:
            rows.append(f"    {r['name']:<22} at {r['position']}: {r['problem']}")
    flagged = [r for r in report["cases"] if r["branch_change"] is not None]
    if flagged:
        kinds = sorted({r["branch_change"] for r in flagged})
        rows.append(
            f"  {len(flagged)} answers are not the solution nearest q_ref ({', '.join(kinds)}; "
            f"e.g. {flagged[0]['name']}): run fails such a jump only between neighbouring "
            "straight-line samples"
        )
    if report.get("spared_cases"):
        rows.append(
            f"  {report['spared_cases']} of the failed cases grade does not fail a ROS-form "
            "server for (the exact singular wrist, q5 = 0, or a pose only another branch "
            "reaches inside the limits): it is sent no joint state"
        )
    rows += finding_lines(report.get("diagnosis") or [])
    verdict = "PASS" if s["passed"] == s["cases"] else "FAIL"
    if report.get("interrupted"):
        planned = report["cases_planned"]
        rows.append(
            f"  interrupted ({report['interrupted']}) after {s['cases']} of {planned} cases: "
            "the figures are those of the cases tried"
        )
        verdict = "INTERRUPTED"
    rows.append(
        f"{verdict}: {s['passed']}/{s['cases']} cases within {1000 * POSITION_TOL:g} mm and "
        f"{1000 * ORIENTATION_TOL:g} mrad, inside the joint limits"
    )
    return "\n".join(rows)


#: Most random poses in one check (each keeps its record in memory and in the report).
MAX_RANDOM_CASES = 1_000_000
#: The plots ``--plots DIR`` writes.
PLOT_FILES = ("ik_error_histograms.png", "ik_error_workspace.png")


def write_plots(out_dir: Path, records: list[dict[str, Any]]) -> list[Path]:
    """Error histograms and error against position in the workspace (PNG); their paths.

    Raises:
        ConfigError: When ``out_dir`` cannot be created or written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot create the plot folder {out_dir}: {exc.strerror}") from exc
    floor = 1e-16  # exact answers plot at the floor of the log axis
    with_q = [r for r in records if r["q"] is not None]
    pos = np.array([max(r["position_error_m"], floor) for r in with_q])
    ori = np.array([max(r["orientation_error_rad"], floor) for r in with_q])
    paths: list[Path] = []

    def save(fig: Any, name: str) -> None:
        path = out_dir / name
        try:
            fig.savefig(path, dpi=110)
        except OSError as exc:
            raise ConfigError(f"cannot write {path}: {exc.strerror}") from exc
        finally:
            plt.close(fig)
        paths.append(path)

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, values, tol, label in (
        (axes[0], pos, POSITION_TOL, "position error [m]"),
        (axes[1], ori, ORIENTATION_TOL, "orientation error [rad]"),
    ):
        if len(values):
            lo = math.floor(math.log10(min(values.min(), tol))) - 1
            hi = math.ceil(math.log10(max(values.max(), tol))) + 1
            ax.hist(values, bins=np.logspace(lo, hi, 4 * (hi - lo) + 1), color="C0")
        ax.axvline(tol, color="r", ls="--", lw=1, label=f"pass limit {tol:g}")
        ax.set_xscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel("cases")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    n_none = len(records) - len(with_q)
    fig.suptitle(
        f"IK errors against forward kinematics ({len(with_q)} answers"
        + (f", {n_none} without an answer)" if n_none else ")")
    )
    fig.tight_layout()
    save(fig, PLOT_FILES[0])

    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    xyz = np.array([r["position"] for r in with_q]).reshape(-1, 3)
    colour = np.log10(pos) if len(pos) else np.zeros(0)
    failed = np.array([not r["passed"] for r in with_q], dtype=bool)
    for ax, (i, j), names in ((axes[0], (0, 1), "xy"), (axes[1], (0, 2), "xz")):
        sc = ax.scatter(xyz[:, i], xyz[:, j], c=colour, s=8, cmap="viridis", vmin=-16, vmax=0)
        ax.scatter(xyz[failed, i], xyz[failed, j], s=40, facecolors="none", edgecolors="r", lw=0.8)
        ax.set_xlabel(f"{names[0]} [m]")
        ax.set_ylabel(f"{names[1]} [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    axes[0].set_title("top view")
    axes[1].set_title("side view (failed cases circled red)")
    fig.colorbar(sc, ax=axes, label="log10 position error [m]")
    save(fig, PLOT_FILES[1])
    return paths


@dataclass(frozen=True, slots=True)
class CheckResult:
    """What ``ik-check`` produced.

    Attributes:
        report: The JSON-ready report.
        text: The table, worst cases and verdict.
        plot_paths: PNG plots written.
    """

    report: dict[str, Any]
    text: str
    plot_paths: tuple[Path, ...]
    interrupted: KeyboardInterrupt | None = None

    @property
    def passed(self) -> bool:
        """Every case planned was tried and passed."""
        s = self.report["summary"]
        return self.interrupted is None and bool(s["passed"] == s["cases"])


def run_check(
    ik: UserIk,
    n_random: int = 1000,
    seed: int = 0,
    report_path: Path | None = None,
    plots_dir: Path | None = None,
    progress: TextIO | None = None,
    robot: RobotDescription | None = None,
) -> CheckResult:
    """Check ``ik`` on the fixed cases and ``n_random`` random ones; write report and plots.

    The cases are poses of ``robot`` (default: the committed URDF), and its kinematics judge
    the answers. The report's ``diagnosis`` and the text name the mistakes as ``grade`` does
    (:func:`~kr210_sim.grading.diagnose.diagnose`, with the notes a ROS-form server sent).
    Ctrl-C, SIGTERM or SIGHUP stops the check: the report (and the plots) of the
    cases tried so far are written whole, marked ``interrupted``, and the result carries the
    interrupt.

    Raises:
        ConfigError: When the report or plot paths cannot be written (checked first).
    """
    from kr210_sim.util.outputs import check_distinct, check_writable, write_json_atomic

    if not 0 <= n_random <= MAX_RANDOM_CASES:
        raise ConfigError(
            f"cases must be a whole number from 0 to {MAX_RANDOM_CASES:,}, got {n_random!r}"
        )
    if report_path is not None:
        check_writable(report_path)
    if plots_dir is not None and plots_dir.exists() and not plots_dir.is_dir():
        raise ConfigError(f"cannot write plots into {plots_dir}: it is a file, not a folder")
    outputs = {f"--plots {n}": plots_dir / n for n in PLOT_FILES} if plots_dir is not None else {}
    check_distinct({"--report": report_path, **outputs}, {"--ik": ik.source})
    wall0 = time.perf_counter()
    kin = Kinematics(robot if robot is not None else load_robot())
    records: list[dict[str, Any]] = []
    interrupted: KeyboardInterrupt | None = None
    cases: list[Case] = []
    try:
        cases = fixed_cases(kin) + random_cases(kin, n_random, seed)
        check(kin, ik, cases, progress, records)
    except KeyboardInterrupt as exc:  # Ctrl-C, SIGTERM, SIGHUP (kr210_sim.util.interrupts)
        interrupted = exc
    with winding_up(interrupted):  # further signals wait until the report is written
        planned = len(fixed_cases(kin)) + n_random if interrupted is not None else None
        wall = time.perf_counter() - wall0
        poses = [c.T for c in cases[: len(records)]]
        found = diagnose(kin, records, poses, (), notes_of(ik), no_q_ref=ik.batch is not None)
        diagnosis = [f.to_dict() for f in found]
        report = build_report(
            ik.spec, n_random, seed, records, wall, kin, planned, interrupted, diagnosis
        )
        report["spared_cases"] = sum(spared(r, ros=ik.batch is not None) for r in records)
        if report_path is not None:
            write_json_atomic(report_path, report)
        plots = tuple(write_plots(plots_dir, records)) if plots_dir is not None else ()
    return CheckResult(report, table(report), plots, interrupted)
