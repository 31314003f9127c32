"""Reading one table of a cell file: typed values with one-line errors, and the bounds every
cell-file figure is checked against (used by :mod:`kr210_sim.cell.toml` and
:mod:`kr210_sim.cell.sensing_toml`)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from kr210_sim.errors import ConfigError

#: Largest length and largest |coordinate| in a cell file [m]: a cell is a room (a shelf 1e300 m
#: high hung every compile in a loop over its height).
MAX_LENGTH = 20.0
#: Smallest size of anything in a cell file [m] (MuJoCo rejects a 1e-300 m radius).
MIN_LENGTH = 1e-3
#: Bounds of the target's mass [kg] and friction coefficient.
MASS_RANGE = (1e-4, 100.0)
FRICTION_RANGE = (1e-3, 10.0)
#: Bounds of every yaw [deg].
YAW_RANGE = (-360.0, 360.0)


class Reader:
    """Reads typed values out of one table of a cell file, with one-line errors."""

    def __init__(self, path: Path, section: str, table: Any, keys: set[str]) -> None:
        self.path, self.section = path, section
        if not isinstance(table, dict):
            self.fail("", f"a table ([{section}])", table)
        unknown = sorted(set(table) - keys)
        if unknown:
            raise ConfigError(
                f"{path}: {section} has an unknown key {unknown[0]!r} "
                f"(keys: {', '.join(sorted(keys))})"
            )
        self.table: dict[str, Any] = table

    def fail(self, key: str, expected: str, got: Any) -> None:
        where = f"{self.section} {key}".strip()
        raise ConfigError(f"{self.path}: {where}: expected {expected}, got {got!r}")

    def _get(self, key: str, default: Any) -> Any:
        if key not in self.table:
            if default is None:
                raise ConfigError(f"{self.path}: {self.section} {key}: missing (required)")
            return default
        return self.table[key]

    def number(
        self,
        key: str,
        default: float | None = None,
        bounds: tuple[float, float] = (MIN_LENGTH, MAX_LENGTH),
        unit: str = "[m]",
    ) -> float:
        """A number within ``bounds`` (default: a positive length [m] up to
        :data:`MAX_LENGTH`)."""
        v = self._get(key, default)
        lo, hi = bounds
        if not is_number(v) or not lo <= v <= hi:
            what = "a positive number" if lo > 0 else "a number"
            self.fail(key, f"{what} {unit} from {lo:g} to {hi:g}", v)
        return float(v)

    def integer(self, key: str, lo: int, hi: int) -> int:
        v = self._get(key, None)
        if not isinstance(v, int) or isinstance(v, bool) or not lo <= v <= hi:
            self.fail(key, f"a whole number from {lo} to {hi}", v)
        return int(v)

    def vector(self, key: str, n: int, positive: bool = False, default: Any = None) -> list[float]:
        """``n`` numbers: positive lengths (``positive``) or coordinates, each within
        :data:`MAX_LENGTH` [m]."""
        v = self._get(key, default)
        lo, hi = (MIN_LENGTH, MAX_LENGTH) if positive else (-MAX_LENGTH, MAX_LENGTH)
        ok = isinstance(v, list) and len(v) == n and all(is_number(x) for x in v)
        if not ok or not all(lo <= x <= hi for x in v):
            kind = "positive numbers" if positive else "numbers"
            self.fail(key, f"a list of {n} {kind} [m], each from {lo:g} to {hi:g}", v)
        return [float(x) for x in v]

    def range_(
        self, key: str, default: tuple[float, float], bounds: tuple[float, float]
    ) -> tuple[float, float]:
        v = self._get(key, list(default))
        lo, hi = bounds
        ok = isinstance(v, list) and len(v) == 2 and all(is_number(x) for x in v)
        if not ok or not lo <= v[0] <= v[1] <= hi:
            self.fail(key, f"[low, high] with {lo:g} <= low <= high <= {hi:g}", v)
        return (float(v[0]), float(v[1]))


def is_number(v: Any) -> bool:
    """A finite int or float (not a bool)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
