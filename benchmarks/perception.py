"""Perception figures on seeded rendered scenes of the cluttered example cell.

For each scene (``render_samples``, seeds held out from the shipped model's): the fixed sensor's
look alone, then with the wrist camera's second look. Prints the target's recognition rate, the
recognition of every cluster (and its confusion matrix), the cylinder targets' position error
(median, p95, max) and the CPU time per look (rendering not included; reported apart).

    python benchmarks/perception.py [--scenes N] [--seed S]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np

import kr210_sim  # noqa: F401  (chooses the GL backend first)
from kr210_sim.cell.toml import load_cell
from kr210_sim.perception.bays import bay_box
from kr210_sim.perception.model import load_model
from kr210_sim.perception.pipeline import perceive, segment
from kr210_sim.perception.train import label_clusters
from kr210_sim.sensors.samples import render_samples

CELL = Path(__file__).resolve().parents[1] / "scenes" / "cells" / "cluttered.toml"


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print its figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=100)
    parser.add_argument("--seed", type=int, default=1000)
    args = parser.parse_args(argv)
    warnings.filterwarnings("ignore", category=FutureWarning)
    cell = load_cell(CELL)
    model = load_model()
    model.probabilities(model.X[:1])  # fit the SVM before the clock starts
    scenes: dict[int, dict[str, object]] = defaultdict(dict)
    t0 = time.perf_counter()
    sensors = tuple(s.name for s in cell.sensors)
    for s in render_samples(CELL, args.scenes, seed=args.seed, sensors=sensors):
        scenes[s.index][s.observation.sensor] = s
    render_s = time.perf_counter() - t0
    fixed, wrist = sensors[0], sensors[1]
    found = {"fixed": 0, "fixed+wrist": 0}
    errors: dict[str, list[float]] = {"fixed": [], "fixed+wrist": []}
    cpu: list[float] = []
    confident = 0
    labels = sorted(k.name for k in model.kinds)
    confusion = np.zeros((len(labels), len(labels) + 1), dtype=int)
    for looks in scenes.values():
        first = looks[fixed]
        truth = first.truth[first.target]  # type: ignore[attr-defined]
        box = bay_box(cell.shelf, first.slot)  # type: ignore[attr-defined]
        for name, obs in (
            ("fixed", [first.observation]),  # type: ignore[attr-defined]
            ("fixed+wrist", [first.observation, looks[wrist].observation]),  # type: ignore[attr-defined]
        ):
            p = perceive(obs, truth.label, box, model)
            if name == "fixed":
                cpu.extend(sum(look.timing.values()) for look in p.looks)
                confident += p.confident
            else:
                cpu.append(sum(p.looks[1].timing.values()))
            if p.target is None or p.target.pose is None:
                continue
            err = float(np.linalg.norm(p.target.pose.position - truth.position))
            if err < 0.03:
                found[name] += 1
            if truth.shape == "cylinder":
                errors[name].append(err)
        for sensor in (fixed, wrist):
            s = looks[sensor]
            look = perceive([s.observation], truth.label, box, model).looks[0]  # type: ignore[attr-defined]
            seg = segment(s.observation, box, np.random.default_rng(0))  # type: ignore[attr-defined]
            true = label_clusters(seg.points, seg.groups, list(s.truth), box)  # type: ignore[attr-defined]
            for d, t in zip(look.detections, true, strict=False):
                if t:
                    col = labels.index(d.label) if d.label in labels else len(labels)
                    confusion[labels.index(t), col] += 1
    n = len(scenes)
    print(f"scenes: {n} (seed {args.seed}), cell {CELL.name}; rendering {render_s:.1f} s wall")
    for name in found:
        e = np.array(errors[name]) * 1000.0
        print(
            f"{name:12s} target recognised and within 3 cm: {found[name]}/{n} "
            f"({100.0 * found[name] / n:.1f} %); cylinder position error [mm]: "
            f"median {np.median(e):.2f}, p95 {np.percentile(e, 95):.2f}, max {e.max():.2f} "
            f"({len(e)} cylinders)"
        )
    print(f"fixed look confident: {confident}/{n}")
    c = np.array(cpu) * 1000.0
    print(
        f"CPU per look [ms]: median {np.median(c):.1f}, p95 {np.percentile(c, 95):.1f}, "
        f"max {c.max():.1f} ({len(c)} looks, 640x480)"
    )
    total = confusion.sum()
    right = int(np.trace(confusion[:, : len(labels)]))
    print(f"every cluster's recognition: {right}/{total} ({100.0 * right / max(total, 1):.1f} %)")
    print("confusion (rows: truth, columns: recognised, last: other)")
    print("  " + " ".join(f"{lab[:8]:>8s}" for lab in labels))
    for lab, row in zip(labels, confusion, strict=True):
        print(f"  {lab[:12]:12s} " + " ".join(f"{v:8d}" for v in row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
