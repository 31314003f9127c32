"""The single-pose closed-form IK of :mod:`kr210_sim.robot.ik_scalar`, compiled (angles in
[rad], lengths in [m])."""

from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

def inverse_one(T: Any, g: Any, /) -> npt.NDArray[np.float64]:
    """Every solution of one (4, 4) pose inside the limits: (k, 6) [rad], k = 0 ... 8."""

def nearest_one(T: Any, q_ref: Any, g: Any, /) -> list[float]:
    """The solution of one pose closest in time to ``q_ref``: six floats [rad], or empty."""

def hypot(x: float, y: float, /) -> float:
    """The native path's hypot of two floats, meant to equal :func:`math.hypot`."""

def setup(
    inverse_one: Callable[..., Any],
    nearest_one: Callable[..., Any],
    check_pose_flat: Callable[[list[float]], None],
    constants: Callable[[Any], tuple[Any, ...]],
    empty: Callable[..., Any],
    /,
) -> None:
    """The pure-Python functions the native ones fall back on, and ``numpy.empty``."""
