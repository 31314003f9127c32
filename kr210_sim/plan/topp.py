"""Time-optimal path parametrisation (TOPP) of a sampled joint path under velocity and
acceleration limits: the lower bound a planned move's duration is measured against.

The path is given by joint states along it; its parameter ``s`` is the cumulative chord length
between them, and its derivatives ``q'(s)``, ``q''(s)`` are second-order finite differences.
At each state ``i`` the squared path speed ``x_i = sdot^2`` must keep every joint within its
velocity limit (``|q'_j| sqrt(x) <= v_j``), and the path acceleration ``u_i`` on the interval to
the next state (``x_{i+1} = x_i + 2 u_i ds_i``) every joint within its acceleration limit
(``|q'_j u + q''_j x| <= a_j``). This is the discretisation of reachability-analysis TOPP
(TOPP-RA, Pham & Pham 2018, the algorithm of the ``toppra`` package): a backward pass finds,
state by state from the rest at the end, the largest speed from which the rest of the path can
still be followed (each step a two-variable linear programme, solved exactly by eliminating the
acceleration, Fourier-Motzkin); a forward pass from rest at the start then takes the largest
acceleration that stays within it. Between states the acceleration is constant, so the time
of interval ``i`` is ``2 ds_i / (sqrt(x_i) + sqrt(x_{i+1}))``.

It needs numpy only: the ``toppra`` package imports scipy and matplotlib (1.5 s, on the first
planned move of a run) and is used in the tests as a cross-check.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import PlanningError

FloatArray = npt.NDArray[np.float64]

#: Chord length below which two consecutive states count as one [rad].
_SAME = 1e-9


def _largest_speed(
    d1: FloatArray, d2: FloatArray, a_max: FloatArray, ds: float, x_next: float
) -> float:
    """The largest ``x`` (squared path speed) at a state with path derivatives ``d1``, ``d2``
    from which some acceleration ``u`` within the limits reaches ``[0, x_next]`` over ``ds``.

    Every constraint is ``alpha u + beta x <= gamma``; eliminating ``u`` pairs each lower bound
    of ``u`` with each upper bound (Fourier-Motzkin), leaving bounds on ``x``.
    """
    alpha = np.concatenate([d1, -d1, [2.0 * ds, -2.0 * ds]])
    beta = np.concatenate([d2, -d2, [1.0, -1.0]])
    gamma = np.concatenate([a_max, a_max, [x_next, 0.0]])
    limit = math.inf
    flat = np.abs(alpha) < 1e-12  # no u: beta x <= gamma
    pos = flat & (beta > 0)
    if pos.any():
        limit = float(np.min(gamma[pos] / beta[pos]))
    up, lo = alpha > 1e-12, alpha < -1e-12
    # u <= c + d x (upper rows), u >= c + d x (lower rows), c = gamma / alpha, d = -beta / alpha
    c_up, d_up = gamma[up] / alpha[up], -beta[up] / alpha[up]
    c_lo, d_lo = gamma[lo] / alpha[lo], -beta[lo] / alpha[lo]
    e = d_lo[:, None] - d_up[None, :]  # (d_lo - d_up) x <= c_up - c_lo
    f = c_up[None, :] - c_lo[:, None]
    bounded = e > 1e-15
    if bounded.any():
        limit = min(limit, float(np.min(f[bounded] / e[bounded])))
    return max(limit, 0.0)


def _largest_acceleration(d1: FloatArray, d2: FloatArray, a_max: FloatArray, x: float) -> float:
    """The largest path acceleration at squared path speed ``x`` within the joints' limits."""
    moving = np.abs(d1) > 1e-12
    if not moving.any():
        return math.inf
    a, b, c = d1[moving], d2[moving], a_max[moving]
    # -c <= a u + b x <= c: u <= (c - b x) / a for a > 0, u <= (-c - b x) / a for a < 0
    return float(np.min(np.where(a > 0, (c - b * x) / a, (-c - b * x) / a)))


def time_optimal_duration(q: npt.ArrayLike, v_max: FloatArray, a_max: FloatArray) -> float:
    """Shortest duration of the path through the joint states ``q`` (n, 6) [rad], from rest to
    rest, at the velocity limits ``v_max`` [rad/s] and acceleration limits ``a_max`` [rad/s^2]
    (see the module doc) [s].

    Raises:
        PlanningError: When the path cannot be followed at any speed (a limit of 0 somewhere).
    """
    qs = np.asarray(q, dtype=np.float64)
    step = np.linalg.norm(np.diff(qs, axis=0), axis=1)
    qs = qs[np.concatenate([[True], step > _SAME])]
    if len(qs) < 2:
        return 0.0
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(qs, axis=0), axis=1))])
    ds = np.diff(s)
    d1 = np.gradient(qs, s, axis=0)
    d2 = np.gradient(d1, s, axis=0)
    with np.errstate(divide="ignore"):
        x_v = np.min((v_max / np.abs(d1)) ** 2, axis=1)
    n = len(s)
    k = np.empty(n)  # the largest squared speed from which the rest of the path can be followed
    k[-1] = 0.0
    for i in range(n - 2, -1, -1):
        k[i] = min(x_v[i], _largest_speed(d1[i], d2[i], a_max, float(ds[i]), float(k[i + 1])))
    x = np.zeros(n)
    for i in range(n - 1):
        u = _largest_acceleration(d1[i], d2[i], a_max, float(x[i]))
        u = min(u, (k[i + 1] - x[i]) / (2.0 * ds[i]))
        x[i + 1] = min(max(x[i] + 2.0 * ds[i] * u, 0.0), k[i + 1])
    speed = np.sqrt(x)
    pace = speed[:-1] + speed[1:]
    if np.any(pace <= 0.0):
        raise PlanningError("the path cannot be followed at any speed within the limits")
    return float(np.sum(2.0 * ds / pace))
