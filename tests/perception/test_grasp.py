"""The grasp's heading: radial when clear, off the radial around a neighbour, none when boxed in."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kr210_sim.perception.grasp import GripperEnvelope, choose_grasp


def disc(centre: tuple[float, float, float], r: float, n: int = 200) -> np.ndarray:
    """Points on an upright circle of radius ``r`` [m] at ``centre``, over +-5 cm of height."""
    a = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    z = np.linspace(-0.05, 0.05, 5)
    A, Z = np.meshgrid(a, z)
    return np.column_stack(
        (
            centre[0] + r * np.cos(A.ravel()),
            centre[1] + r * np.sin(A.ravel()),
            centre[2] + Z.ravel(),
        )
    )


TARGET = (2.5, 0.0, 1.0)


def test_nothing_around_gives_the_radial_heading() -> None:
    g, why = choose_grasp(TARGET, np.zeros((0, 3)), [], np.zeros(0, dtype=np.intp))
    assert g is not None and why == ""
    assert g.offset_deg == 0.0 and g.yaw == pytest.approx(0.0)
    assert g.clearance == math.inf


def test_a_neighbour_in_front_turns_the_heading() -> None:
    """A can 17 cm in front of the target, 9 cm to the left: the radial corridor is blocked,
    a heading to the right of it clears, the nearest such."""
    pts = disc((2.33, 0.09, 1.0), 0.035)
    g, _ = choose_grasp(TARGET, pts, ["can"], np.zeros(len(pts), dtype=np.intp))
    assert g is not None and g.offset_deg != 0.0
    env = GripperEnvelope()
    rel = pts - TARGET
    u = rel[:, 0] * math.cos(g.yaw) + rel[:, 1] * math.sin(g.yaw)
    w = -rel[:, 0] * math.sin(g.yaw) + rel[:, 1] * math.cos(g.yaw)
    ahead = u <= env.tip_past_axis + env.margin
    assert np.all(np.abs(w[ahead]) > env.open_gap / 2 + env.finger + env.margin)
    previous = g.offset_deg - math.copysign(5.0, g.offset_deg)
    yaw = math.radians(previous)
    w = -rel[:, 0] * math.sin(yaw) + rel[:, 1] * math.cos(yaw)
    u = rel[:, 0] * math.cos(yaw) + rel[:, 1] * math.sin(yaw)
    assert np.any(np.abs(w[u <= 0.07]) <= env.open_gap / 2 + env.finger + env.margin)


def test_a_neighbour_behind_or_below_does_not_block() -> None:
    """Behind the fingertips, or under the fingers' height: clear radially."""
    behind = disc((2.7, 0.0, 1.0), 0.04)
    low = disc((2.35, 0.0, 0.85), 0.04)
    pts = np.vstack((behind, low))
    g, _ = choose_grasp(TARGET, pts, ["a", "b"], np.repeat([0, 1], len(behind)))
    assert g is not None and g.offset_deg == 0.0


def test_boxed_in_says_what_blocks() -> None:
    ring = np.vstack(
        [
            disc((2.5 - 0.2 * math.cos(a), 0.2 * math.sin(a), 1.0), 0.04)
            for a in np.radians(np.arange(-60, 61, 20))
        ]
    )
    owners = np.repeat(np.arange(7) % 2, len(ring) // 7)
    g, why = choose_grasp(TARGET, ring, ["crate", "ball"], owners)
    assert g is None
    assert why.startswith("no heading within 45 deg of the radial clears: blocked by ")
    assert "crate" in why and "ball" in why
