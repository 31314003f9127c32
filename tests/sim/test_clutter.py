"""Clutter: drawn into every bay without overlaps, clear of the target's corridor, seeded; placed
at rest it stays put; the pick list dresses the target; a tidy cell is untouched."""

from __future__ import annotations

import itertools
import math

import mujoco
import numpy as np
import pytest

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.load import compile_cell, model_at
from kr210_sim.cell.toml import parse_cell
from kr210_sim.sim.clutter import (
    CORRIDOR_BEHIND,
    CORRIDOR_HALF_WIDTH,
    Clutter,
    _footprint,
    apart,
)
from kr210_sim.sim.runner import RunConfig, Runner
from kr210_sim.util.paths import SCENES_DIR

CLUTTERED = SCENES_DIR / "cells" / "cluttered.toml"


@pytest.fixture(scope="module")
def clutter() -> Clutter:
    model = model_at(CLUTTERED)
    return Clutter(model, CellLayout.from_model(model))


def _covered(fp: tuple, pts: np.ndarray, grow: float) -> np.ndarray:
    shape, centre, half, yaw = fp
    d = pts - centre
    if shape == "disc":
        return np.linalg.norm(d, axis=1) <= half[0] + grow
    c, s = math.cos(yaw), math.sin(yaw)
    lx, ly = c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]
    dx, dy = np.maximum(np.abs(lx) - half[0], 0), np.maximum(np.abs(ly) - half[1], 0)
    return np.hypot(dx, dy) <= grow


def test_apart_agrees_with_a_grid_of_points() -> None:
    """The footprint test against an independent one: two footprints are apart by ``gap`` when
    no point lies within gap/2 of both (on a 1 mm grid)."""
    rng = np.random.default_rng(0)
    xs = np.arange(-0.3, 0.3, 0.001)
    grid = np.stack(np.meshgrid(xs, xs), axis=-1).reshape(-1, 2)
    shapes = [("disc", (0.05, 0.05)), ("rect", (0.06, 0.04)), ("rect", (0.05, 0.05))]
    disagree = 0
    for _ in range(300):
        (sa, ha), (sb, hb) = shapes[rng.integers(3)], shapes[rng.integers(3)]
        a = (sa, rng.uniform(-0.1, 0.1, 2), ha, float(rng.uniform(-3, 3)))
        b = (sb, rng.uniform(-0.1, 0.1, 2), hb, float(rng.uniform(-3, 3)))
        gap = 0.01
        both = _covered(a, grid, gap / 2) & _covered(b, grid, gap / 2)
        if apart(a, b, gap) == bool(both.any()):
            # only a grid-sized sliver may tell them apart
            near = _covered(a, grid, gap / 2 + 0.0015) & _covered(b, grid, gap / 2 + 0.0015)
            tight = _covered(a, grid, gap / 2 - 0.0015) & _covered(b, grid, gap / 2 - 0.0015)
            disagree += int(near.any() == tight.any())
    assert disagree == 0


@pytest.mark.parametrize("seed", range(6))
def test_draws_fill_the_bays_without_overlaps_and_keep_the_corridor_clear(
    clutter: Clutter, seed: int
) -> None:
    layout = clutter.layout
    rng = np.random.default_rng(seed)
    slot = int(rng.integers(1, 10))
    txy = layout.slots[slot - 1][:2] + rng.uniform(-0.03, 0.03, 2)
    placed = clutter.draw(rng, slot, txy, 0.05, "red_can")
    assert clutter.spec is not None
    lo, hi = clutter.spec.per_bay
    per_bay = {s: [p for p in placed if p.slot == s] for s in range(1, 10)}
    assert sum(len(v) for v in per_bay.values()) >= 9
    assert all(lo <= len(v) <= hi for v in per_bay.values())
    assert not any(p.kind == "red_can" for p in placed)
    assert len({(p.kind, p.index) for p in placed}) == len(placed)
    prints = []
    for p in placed:
        kind = clutter.kinds[p.kind]
        board = layout.slots[p.slot - 1]
        assert p.position[2] == pytest.approx(board[2] + kind.half_extents[2])
        local = layout.shelf.local(p.position)
        hx, hy, _ = kind.half_extents
        turn = p.yaw - math.atan2(layout.shelf.R[1, 0], layout.shelf.R[0, 0])
        ex = abs(math.cos(turn)) * hx + abs(math.sin(turn)) * hy if kind.shape == "box" else hx
        assert -layout.shelf.half[0] < local[0] - ex and local[0] + ex < layout.shelf.half[0] - 0.02
        assert abs(local[1] - layout.shelf.local(board)[1]) < 0.4
        prints.append((p.slot, _footprint(kind, np.array(p.position[:2]), p.yaw)))
    for (sa, a), (sb, b) in itertools.combinations(prints, 2):
        if sa == sb:
            assert apart(a, b, clutter.spec.gap[0] - 1e-9)
    # the target's corridor: nothing within its strip, from the robot to just behind it
    heading = math.atan2(txy[1], txy[0])
    u = np.array([math.cos(heading), math.sin(heading)])
    w = np.array([-u[1], u[0]])
    for s, fp in prints:
        if s != slot:
            continue
        pts = np.array(
            [
                fp[1] + r * np.array([math.cos(a), math.sin(a)])
                for r in (0.0, 0.02, 0.04)
                for a in np.linspace(0, 6.28, 24)
            ]
        )
        inside = _covered(fp, pts, 0.0)
        along, across = (pts - txy) @ u, (pts - txy) @ w
        blocked = inside & (along < CORRIDOR_BEHIND) & (np.abs(across) < CORRIDOR_HALF_WIDTH)
        assert not blocked.any()
    r1 = clutter.draw(np.random.default_rng([seed, 1]), slot, txy, 0.05, "red_can")
    r2 = clutter.draw(np.random.default_rng([seed, 1]), slot, txy, 0.05, "red_can")
    assert r1 == r2


@pytest.mark.slow
def test_placed_clutter_stays_put_and_the_target_is_dressed_as_the_pick_list_says() -> None:
    model = model_at(CLUTTERED)
    runner = Runner(RunConfig(cycles=4, seed=5, randomize=True), model)
    for index in (1, 2):
        sample, k = runner.start_cycle(index, runner.slot_for_cycle())
        placed = runner.clutter.placed
        assert len(placed) >= 9
        g = runner.cell.handles.target_geoms[k]
        kind = ("target", "red_can")[index - 1]
        assert runner.clutter.kind == kind
        if kind == "red_can":
            assert sample.spec.radius == 0.045 and sample.spec.length == 0.22
            assert np.allclose(model.geom_rgba[g, :3], (0.85, 0.1, 0.08))
        else:
            assert np.allclose(model.geom_rgba[g, :3], (0.1, 0.35, 0.95))
        runner.idle(1.0)
        data = runner.cell.data
        assert not any(w.number for w in data.warning)
        for p in placed:
            b = model.body(f"clutter_{p.kind}_{p.index}").id
            moved = np.linalg.norm(data.xpos[b] - p.position)
            tilt = math.degrees(math.acos(min(1.0, abs(data.xmat[b].reshape(3, 3)[2, 2]))))
            assert moved < 0.003 and tilt < 1.0, (p, moved, tilt)
        pos, _ = runner.cell.target_pose(k)
        assert np.linalg.norm(pos - np.array(sample.position)) < 0.003
        mujoco.mj_forward(model, data)


def test_a_shelf_turned_half_round_is_cluttered_inside_its_bays() -> None:
    kinds = "[[objects]]" + CLUTTERED.read_text().split("[[objects]]", 1)[1]
    text = (SCENES_DIR / "cells" / "other_side.toml").read_text() + "\n" + kinds
    model = compile_cell(parse_cell(text, "turned.toml"))
    layout = CellLayout.from_model(model)
    assert abs(layout.shelf.R[0, 0]) < 1e-9  # turned
    clutter = Clutter(model, layout)
    assert clutter.spec is not None
    for seed in range(10):
        placed = clutter.draw(np.random.default_rng(seed), 2, layout.slots[1][:2], 0.05)
        assert len(placed) >= layout.n_slots
        prints = []
        for p in placed:
            kind = clutter.kinds[p.kind]
            local = layout.shelf.local(p.position)
            board = layout.shelf.local(layout.slots[p.slot - 1])
            assert abs(local[0]) + kind.footprint_radius < layout.shelf.half[0] + 0.02
            assert abs(local[1] - board[1]) < 0.4 and local[2] > board[2]
            prints.append((p.slot, _footprint(kind, np.array(p.position[:2]), p.yaw)))
        for (sa, a), (sb, b) in itertools.combinations(prints, 2):
            assert sa != sb or apart(a, b, clutter.spec.gap[0] - 1e-9)
