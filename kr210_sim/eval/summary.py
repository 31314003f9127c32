"""The evaluation's summary, computed as episode records stream in, in bounded memory.

The summary is the same whatever order the records arrive in (workers and cluster nodes finish
episodes in any order, and a resumed evaluation reads half of them back from disk), so the report
is byte-identical between backends and after a resume:

- counts and maxima do not depend on order;
- cycle times are kept as a histogram of their exact values. Simulated cycle times are whole
  multiples of the control tick (rounded to 1 µs), so the histogram holds at most a few thousand
  entries however many episodes run, and it gives the exact mean, standard deviation and
  percentiles (NumPy's linear interpolation) with no rounding that depends on order;
- failure examples and failed episodes' records are the ones with the lowest episode numbers,
  kept in bounded heaps;
- with ``evaluate --perceive``, the perceived targets' position errors are kept as a histogram
  of their values as recorded (rounded to 1 µm), so the median, p95 and max are exact and
  order-free in the same way (:class:`PerceptionSummary`).
"""

from __future__ import annotations

import heapq
import math
from collections import Counter
from fractions import Fraction
from typing import Any

#: Example seeds kept per failure reason.
EXAMPLES_PER_REASON = 5
#: Records of failed episodes kept for the report (the lowest episode numbers).
FAILED_RECORDS = 1000
#: Failure reasons whose episodes never held the target (no creep to measure).
_NO_GRIP = ("unreachable", "grasp_missed")


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (95 % for the default ``z``)."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def percentile(histogram: dict[float, int], q: float) -> float:
    """The ``q``-th percentile of the values counted in ``histogram``.

    Same as ``numpy.percentile(values, q)`` (linear interpolation) over the expanded values.

    Args:
        histogram: Value -> how many times it occurs (at least one value).
        q: Percentile in [0, 100].
    """
    values = sorted(histogram)
    n = sum(histogram.values())
    h = (n - 1) * q / 100.0
    lo = math.floor(h)
    t = h - lo
    a = b = values[0]
    seen = 0
    found_a = False
    for v in values:  # the order statistics lo and lo + 1
        seen += histogram[v]
        if not found_a and seen > lo:
            a, found_a = v, True
        if seen > lo + 1:
            b = v
            break
    else:
        b = values[-1]
    d = b - a
    return b - d * (1 - t) if t >= 0.5 else a + d * t


def _moments(histogram: dict[float, int]) -> tuple[float, float]:
    """Exact mean and population standard deviation of the counted values."""
    n = sum(histogram.values())
    s1 = sum((Fraction(v) * c for v, c in histogram.items()), Fraction(0))
    s2 = sum((Fraction(v) ** 2 * c for v, c in histogram.items()), Fraction(0))
    mean = s1 / n
    return float(mean), math.sqrt(float(s2 / n - mean * mean))


class PerceptionSummary:
    """Accumulates the ``perception`` blocks of ``--perceive`` episodes (any order) into the
    summary's ``perception`` block, the same figures as ``run --perceive``'s
    (:func:`kr210_sim.score.report.perception_summary`)."""

    def __init__(self) -> None:
        self.episodes = 0
        self.recognised = 0
        self.second_looks = 0
        self.not_seen = 0
        self.errors: Counter[float] = Counter()
        self.cpu_total_ms = Fraction(0)  # exact: the mean does not depend on the order
        self.cpu_max_ms = 0.0

    def add(self, p: dict[str, Any]) -> None:
        """Count one episode's ``perception`` block."""
        self.episodes += 1
        self.recognised += bool(p["right_object"])
        self.second_looks += p["looks"] > 1
        self.not_seen += not p["seen"]
        if p["position_error_mm"] is not None:
            self.errors[float(p["position_error_mm"])] += 1
        self.cpu_total_ms += Fraction(float(p["cpu_time_ms"]))
        self.cpu_max_ms = max(self.cpu_max_ms, float(p["cpu_time_ms"]))

    def summary(self) -> dict[str, Any]:
        """Episodes perceived, recognised (the target seen and the estimate on it), the
        recognition rate with its 95 % Wilson interval, second looks, targets not seen, the
        position error of the seen targets [mm] (median, p95, max; None when none was seen) and
        the pipeline's CPU time per episode [ms] (mean, max: machine-measured)."""
        n = self.episodes
        lo, hi = wilson_interval(self.recognised, n)
        errors = None
        if self.errors:
            errors = {
                "median": round(percentile(self.errors, 50), 6),
                "p95": round(percentile(self.errors, 95), 6),
                "max": max(self.errors),
            }
        return {
            "episodes": n,
            "recognised": self.recognised,
            "recognition_rate": self.recognised / n if n else 0.0,
            "recognition_rate_ci95": [round(lo, 6), round(hi, 6)],
            "second_looks": self.second_looks,
            "not_seen": self.not_seen,
            "position_error_mm": errors,
            "cpu_time_ms": {
                "mean": float(self.cpu_total_ms / n) if n else 0.0,
                "max": self.cpu_max_ms,
            },
        }


class EpisodeSummary:
    """Accumulates episode records (any order, each episode once) into the report's summary.

    Args:
        failed_records: How many failed episodes' records to keep (lowest episode numbers).
    """

    def __init__(self, failed_records: int = FAILED_RECORDS) -> None:
        self.episodes = 0
        self.successes = 0
        self.grasp_retries = 0
        self.retries_recovered = 0
        self.max_creep_mm = 0.0
        self.max_tracking_error_deg = 0.0
        self.cycle_times: Counter[float] = Counter()
        self._counts: Counter[str] = Counter()
        # per reason: a max-heap (by -episode) of the lowest-numbered examples
        self._examples: dict[str, list[tuple[int, dict[str, Any]]]] = {}
        self._failed: list[tuple[int, dict[str, Any]]] = []
        self._failed_cap = failed_records
        #: The perceived episodes' figures (``evaluate --perceive``; none counted otherwise).
        self.perception = PerceptionSummary()

    @property
    def failed(self) -> int:
        """Failed episodes so far."""
        return self.episodes - self.successes

    def add(self, r: dict[str, Any]) -> None:
        """Count one episode's record (see :func:`kr210_sim.eval.episode.episode_record`)."""
        self.episodes += 1
        self.grasp_retries += r["grasp_attempts"] - 1
        self.max_tracking_error_deg = max(
            self.max_tracking_error_deg, max(r["max_tracking_error_deg"], default=0.0)
        )
        if r.get("perception") is not None:
            self.perception.add(r["perception"])
        if r["reason"] not in _NO_GRIP:
            self.max_creep_mm = max(self.max_creep_mm, r["creep_mm"])
        if r["success"]:
            self.successes += 1
            self.retries_recovered += r["grasp_attempts"] > 1
            self.cycle_times[r["cycle_time"]] += 1
            return
        self._counts[r["reason"]] += 1
        example = {"seed": r["seed"], "slot": r["slot"], "detail": r["detail"]}
        _keep_lowest(
            self._examples.setdefault(r["reason"], []), r["episode"], example, EXAMPLES_PER_REASON
        )
        _keep_lowest(self._failed, r["episode"], r, self._failed_cap)

    def failed_records(self) -> list[dict[str, Any]]:
        """Records of the failed episodes kept, by episode number."""
        return _by_episode(self._failed)

    def summary(self) -> dict[str, Any]:
        """Success rate with its 95 % Wilson interval, failures with examples, cycle-time stats;
        with ``--perceive`` also ``perception`` (:meth:`PerceptionSummary.summary`)."""
        n, ok = self.episodes, self.successes
        lo, hi = wilson_interval(ok, n)
        failures = {
            reason: {"count": self._counts[reason], "examples": _by_episode(heap)}
            for reason, heap in sorted(self._examples.items())
        }
        stats = {"mean": 0.0, "std": 0.0, "p50": 0.0, "p95": 0.0, "max": 0.0}
        if self.cycle_times:
            mean, std = _moments(self.cycle_times)
            stats = {
                "mean": mean,
                "std": std,
                "p50": percentile(self.cycle_times, 50),
                "p95": percentile(self.cycle_times, 95),
                "max": max(self.cycle_times),
            }
        out: dict[str, Any] = {
            "episodes": n,
            "successes": ok,
            "success_rate": ok / n if n else 0.0,
            "success_rate_ci95": [round(lo, 6), round(hi, 6)],
            "failures": failures,
            "grasp_retries": self.grasp_retries,
            "retries_recovered": self.retries_recovered,
            "cycle_time": {k: round(v, 6) for k, v in stats.items()},
            "max_creep_mm": self.max_creep_mm,
            "max_tracking_error_deg": self.max_tracking_error_deg,
        }
        if self.perception.episodes:
            out["perception"] = self.perception.summary()
        return out


def _keep_lowest(
    heap: list[tuple[int, dict[str, Any]]], episode: int, item: dict[str, Any], cap: int
) -> None:
    """Keep in ``heap`` (a max-heap by episode, stored negated) the ``cap`` lowest episodes."""
    if len(heap) < cap:
        heapq.heappush(heap, (-episode, item))
    elif cap and -heap[0][0] > episode:
        heapq.heapreplace(heap, (-episode, item))


def _by_episode(heap: list[tuple[int, dict[str, Any]]]) -> list[dict[str, Any]]:
    """The items of a :func:`_keep_lowest` heap, by episode number."""
    return [item for _, item in sorted(heap, key=lambda entry: -entry[0])]
