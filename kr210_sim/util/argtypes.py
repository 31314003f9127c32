"""The values the command line takes: argparse ``type=`` functions, each a one-line message on
bad input (which :mod:`kr210_sim.cli`'s parser prints as ``error: ...`` with exit code 2).

Units: seconds for :func:`seconds`, a speed-up factor for :func:`speed`.
"""

from __future__ import annotations

import argparse
from typing import Any


def parsed(text: str, cast: type[int] | type[float], expected: str) -> Any:
    try:
        return cast(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None


def check(ok: bool, message: str) -> None:
    if not ok:
        raise argparse.ArgumentTypeError(message)


def positive_int(text: str) -> int:
    value: int = parsed(text, int, "a whole number")
    check(value >= 1, f"must be at least 1, got {value}")
    return value


def slot(text: str) -> int:
    value: int = parsed(text, int, "0-25")
    check(
        0 <= value <= 25, f"must be 0 (random) or a slot 1-rows x columns (at most 25), got {value}"
    )
    return value


def fraction(text: str) -> float:
    value: float = parsed(text, float, "a number in [0, 1]")
    check(0.0 <= value <= 1.0, f"must be in [0, 1], got {value}")
    return value


def count(text: str) -> int:
    value: int = parsed(text, int, "a whole number")
    check(value >= 0, f"must be >= 0, got {value}")
    return value


def seed(text: str) -> int:
    value: int = parsed(text, int, "a whole number")
    check(value >= 0, f"must be >= 0, got {value}")
    return value


def multiple_of_16(text: str) -> int:
    value = positive_int(text)
    check(value % 16 == 0, f"must be a multiple of 16, got {value}")
    return value


def fps(text: str) -> int:
    value = positive_int(text)
    check(value <= 120, f"must be 1-120, got {value}")
    return value


def seconds(text: str) -> float:
    value: float = parsed(text, float, "seconds")
    check(0.0 < value <= 86400.0, f"must be in (0, 86400] s, got {value}")
    return value


def speed(text: str) -> float:
    value: float = parsed(text, float, "a number")
    check(0.0 < value <= 1000.0, f"must be in (0, 1000], got {value}")
    return value


def port(text: str) -> int:
    value: int = parsed(text, int, "a port number")
    check(0 <= value <= 65535, f"must be 0-65535, got {value}")
    return value
