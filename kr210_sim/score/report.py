"""Run reports: the JSON record, the per-cycle line and the summary table.

Reports are written atomically (:mod:`kr210_sim.util.outputs`), so an interrupted write never
leaves a half-written report behind. One naming rule says what varies between identical runs:
every field measured on the machine (wall-clock and CPU times, the real-time factor, how an
evaluation was spread over processes) is named ``wall_*`` or ``cpu_*``, and :func:`strip_wall`
drops exactly those, so the same seed gives the same report after it (tested for ``run``,
``evaluate`` and ``view``).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import asdict, is_dataclass
from typing import Any

import numpy as np

from kr210_sim.score.result import CycleResult, Event
from kr210_sim.util.interrupts import signal_name
from kr210_sim.util.versions import versions

__all__ = [
    "MEASURED_PREFIXES",
    "build_report",
    "cycle_line",
    "is_measured",
    "perception_summary",
    "strip_wall",
    "summarise",
    "summary_table",
]

#: Key prefixes of the fields measured on the machine rather than simulated (they vary between
#: identical runs; everything else is a function of the seed and the cell).
MEASURED_PREFIXES = ("wall_", "cpu_")


def is_measured(key: str) -> bool:
    """Whether a report key names a machine-measured figure (``wall_*`` or ``cpu_*``)."""
    return key.startswith(MEASURED_PREFIXES)


def summarise(results: Sequence[CycleResult], wall_time: float | None = None) -> dict[str, Any]:
    """Summary figures of a run.

    Args:
        results: The cycles run so far.
        wall_time: Wall-clock time of the run [s], if known.

    Returns:
        cycles, successes, success_rate, failures (reason -> count), cycle-time statistics [s],
        worst tracking error [deg], worst gripper error [mm], worst creep [mm], robot contacts,
        simulated time [s], and the wall-time figures.
    """
    n = len(results)
    ok = [r for r in results if r.success]
    times = np.array([r.cycle_time for r in results]) if n else np.zeros(0)
    grasped = [r.creep_mm for r in results if r.reason not in ("unreachable", "grasp_missed")]
    summary: dict[str, Any] = {
        "cycles": n,
        "successes": len(ok),
        "success_rate": (len(ok) / n) if n else 0.0,
        "failures": dict(sorted(Counter(r.reason for r in results if r.reason).items())),
        "cycle_time_mean": float(times.mean()) if n else 0.0,
        "cycle_time_max": float(times.max()) if n else 0.0,
        "cycle_time_min": float(times.min()) if n else 0.0,
        "max_tracking_error_deg": max(
            (max(r.max_tracking_error_deg) for r in results), default=0.0
        ),
        "max_gripper_tracking_error_mm": max(
            (r.max_gripper_tracking_error_mm for r in results), default=0.0
        ),
        "max_creep_mm": max(grasped, default=0.0),
        "env_contact_ticks": sum(r.env_contact_ticks for r in results),
        "grasp_retries": sum(max(r.grasp_attempts - 1, 0) for r in results),
        "sim_time": float(times.sum()) if n else 0.0,
        "detours": sum(r.detours for r in results),
    }
    if n:
        plan = np.array([r.wall_planning_time for r in results])
        summary["wall_planning_time_s"] = {"mean": float(plan.mean()), "max": float(plan.max())}
        cpu = np.array([r.cpu_planning_time for r in results])
        summary["cpu_planning_time_s"] = {"mean": float(cpu.mean()), "max": float(cpu.max())}
        ratio = np.array([r.bound_ratio for r in results if r.moves])
        if len(ratio):
            summary["motion_time_over_bound"] = {
                "mean": float(ratio.mean()),
                "max": float(ratio.max()),
            }
    perception = perception_summary(results)
    if perception is not None:
        summary["perception"] = perception
    if wall_time is not None:
        summary["wall_time_s"] = wall_time
        rtf = (summary["sim_time"] / wall_time) if wall_time > 0 else 0.0
        summary["wall_real_time_factor"] = rtf
    return summary


def _jsonable(obj: Any) -> Any:
    if is_dataclass(obj) and not isinstance(obj, type):
        return _jsonable(asdict(obj))
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _config(config: object) -> Any:
    """The run's settings as JSON; ``perceive`` only when on (a run without it keeps the
    report it always had)."""
    d = _jsonable(config)
    if isinstance(d, dict) and d.get("perceive") is False:
        del d["perceive"]
    return d


def perception_summary(results: Sequence[CycleResult]) -> dict[str, Any] | None:
    """The summary's ``perception`` block of a ``--perceive`` run (None without): the cycles
    perceived, the recognition rate (the target seen and the estimate on it), the position
    error of the seen targets [mm] (median, p95, max) and the pipeline's CPU time per cycle
    [ms] (mean, max)."""
    recs = [r.perception for r in results if r.perception is not None]
    if not recs:
        return None
    right = sum(bool(p["right_object"]) for p in recs)
    errs = np.array([p["position_error_mm"] for p in recs if p["position_error_mm"] is not None])
    cpu = np.array([p["cpu_time_ms"] for p in recs])
    out: dict[str, Any] = {
        "cycles": len(recs),
        "recognised": right,
        "recognition_rate": right / len(recs),
        "second_looks": sum(p["looks"] > 1 for p in recs),
        "position_error_mm": None,
        "cpu_time_ms": {"mean": float(cpu.mean()), "max": float(cpu.max())},
    }
    if len(errs):
        out["position_error_mm"] = {
            "median": float(np.median(errs)),
            "p95": float(np.percentile(errs, 95)),
            "max": float(errs.max()),
        }
    return out


def build_report(
    config: object,
    results: Sequence[CycleResult],
    wall_time: float | None,
    interrupted: BaseException | bool | None = None,
    events: Sequence[Event] = (),
    cell: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The JSON-ready report of a run.

    Args:
        config: The run's settings (:class:`kr210_sim.sim.runner.RunConfig`, a dataclass).
        results: The cycles that finished.
        wall_time: Wall-clock time of the run [s], if known.
        interrupted: The interrupt that stopped the run (or True), None/False when it ran to
            the end.
        events: What was done to the cylinders between cycles (bin emptied, shelf cleared).
        cell: The simulated cell (:meth:`kr210_sim.cell.layout.CellLayout.describe`).

    Returns:
        config, the cell, per-cycle records, events, summary, ``interrupted`` (bool) and
        ``interrupted_by`` (the signal's name or null), versions.
    """
    return {
        "kind": "kr210_sim.run",
        "config": _config(config),
        "cell": _jsonable(cell),
        "cycles": [r.to_dict() for r in results],
        "events": [e.to_dict() for e in events],
        "summary": summarise(results, wall_time),
        "interrupted": bool(interrupted),
        "interrupted_by": signal_name(interrupted if interrupted is not True else None)
        if interrupted
        else None,
        "versions": versions(),
    }


def strip_wall(obj: Any) -> Any:
    """A copy of a report without its machine-measured fields (:func:`is_measured`): what
    identical runs must agree on."""
    if isinstance(obj, dict):
        return {k: strip_wall(v) for k, v in obj.items() if not is_measured(str(k))}
    if isinstance(obj, list):
        return [strip_wall(v) for v in obj]
    return obj


def cycle_line(r: CycleResult, total: int) -> str:
    """One line per cycle: number, slot, result, cycle time, tracking error, creep."""
    width = len(str(total))
    result = "ok  " if r.success else f"FAIL {r.reason}"
    retry = f"  retries {r.grasp_attempts - 1}" if r.grasp_attempts > 1 else ""
    return (
        f"[{r.index:>{width}}/{total}] slot {r.slot}  {result:<24} "
        f"cycle {r.cycle_time:5.2f} s  track {max(r.max_tracking_error_deg):5.3f} deg  "
        f"creep {r.creep_mm:5.2f} mm{retry}"
        + (f"  ({r.detail})" if r.detail and not r.success else "")
    )


def recognised(perception: dict[str, Any], of: int) -> str:
    """A summary's ``perception`` block in one line: recognised of ``of`` (cycles or episodes),
    and the position error's median / p95 / max [mm] (none when nothing was recognised)."""
    e = perception["position_error_mm"]
    err = (
        f"; error median / p95 / max {e['median']:.1f} / {e['p95']:.1f} / {e['max']:.1f} mm"
        if e
        else ""
    )
    return f"{perception['recognised']}/{of}{err}"


def summary_table(summary: dict[str, Any]) -> str:
    """A small plain-text summary table."""
    rows = [
        ("cycles", f"{summary['cycles']}"),
        ("successes", f"{summary['successes']} ({100 * summary['success_rate']:.0f} %)"),
        ("failures", ", ".join(f"{k} {v}" for k, v in summary["failures"].items()) or "none"),
        (
            "cycle time mean / max",
            f"{summary['cycle_time_mean']:.2f} / {summary['cycle_time_max']:.2f} s",
        ),
        ("worst joint tracking error", f"{summary['max_tracking_error_deg']:.3f} deg"),
        (
            "worst tracking error at gripper",
            f"{summary['max_gripper_tracking_error_mm']:.2f} mm",
        ),
        ("worst creep in the grip", f"{summary['max_creep_mm']:.2f} mm"),
        ("robot-cell contact ticks", f"{summary['env_contact_ticks']}"),
    ]
    if "motion_time_over_bound" in summary:
        b = summary["motion_time_over_bound"]
        rows.insert(
            4, ("moves / their lower bound", f"{b['mean']:.2f} / {b['max']:.2f} (mean / max)")
        )
    if "perception" in summary:
        p = summary["perception"]
        rows.append(("recognised", recognised(p, p["cycles"])))
    if "wall_time_s" in summary:
        wall, rtf = summary["wall_time_s"], summary["wall_real_time_factor"]
        factor = f"{rtf:.0f}" if rtf >= 10 else f"{rtf:.2g}"  # never "0x" for a slow run
        rows.append(("wall time", f"{wall:.2f} s ({factor}x real time)"))
    w = max(len(k) for k, _ in rows)
    return "\n".join(f"  {k:<{w}}  {v}" for k, v in rows)
