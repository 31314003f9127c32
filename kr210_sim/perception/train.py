"""Train the recogniser on seeded samples and write its model file.

``python -m kr210_sim.perception.train --seed S --samples N --out FILE``: N cluttered bays
(:mod:`kr210_sim.perception.synthetic_bay`, each seen from the fixed sensor's viewpoint and from
the wrist camera's, with a D415's noise), every cluster labelled by the object it covers, its
features computed as :func:`~kr210_sim.perception.pipeline.perceive` computes them. The same
seed and count give the same file. A cell's rendered scenes (what the shipped model is trained
on) are the sensors' to draw: ``python -m kr210_sim train-recogniser --cell FILE``
(:mod:`kr210_sim.sensors.recognisers`), through :func:`training_set_from_looks`.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.perception.camera import Intrinsics
from kr210_sim.perception.cloud import BayBox
from kr210_sim.perception.features import features
from kr210_sim.perception.kinds import Kind
from kr210_sim.perception.model import RecognitionModel
from kr210_sim.perception.pipeline import Segments, segment
from kr210_sim.perception.synthetic import observe
from kr210_sim.perception.synthetic_bay import (
    DEFAULT_BAY,
    DEFAULT_KINDS,
    Truth,
    clutter,
    fixed_camera,
    shelf_primitives,
    wrist_camera,
)

FloatArray = npt.NDArray[np.float64]

#: The sensors' image: 640 x 480 at a 50 deg vertical field of view (the fixed sensor's).
INTRINSICS = Intrinsics.from_fovy(640, 480, 50.0)


def scene(
    rng: np.random.Generator, kinds: Sequence[Kind] = DEFAULT_KINDS, box: BayBox = DEFAULT_BAY
) -> tuple[list, list[Truth]]:
    """A seeded cluttered bay: a target of a random kind and 1-4 distractors of the others.

    Returns:
        The primitives (shelf and objects) and where each object stands.
    """
    order = rng.permutation(len(kinds))
    target = kinds[int(order[0])]
    n = int(rng.integers(1, 5))
    others = [kinds[int(i)] for i in rng.choice(order[1:], size=min(n, len(kinds) - 1))]
    prims, truths = clutter(rng, box, target, others)
    return shelf_primitives(box) + prims, truths


def label_clusters(
    points: FloatArray, groups: list[npt.NDArray[np.intp]], truths: list[Truth], box: BayBox
) -> list[str]:
    """Each cluster's label: the object whose axis its centroid lies nearest horizontally,
    within 3 cm of its footprint ("" for none)."""
    out = []
    for idx in groups:
        c = box.to_base(points[idx].mean(axis=0))
        best, label = np.inf, ""
        for t in truths:
            r = t.size[0] if t.shape != "box" else 0.5 * math.hypot(t.size[0], t.size[1])
            d = float(np.hypot(*(c[:2] - t.position[:2])))
            if d < r + 0.03 and d < best:
                best, label = d, t.label
        out.append(label)
    return out


def _add_look(
    seg: Segments, truths: list[Any], box: BayBox, X: list[FloatArray], y: list[str]
) -> None:
    """Append the features and label of each of a look's clusters that covers an object."""
    for idx, label in zip(
        seg.groups, label_clusters(seg.points, seg.groups, truths, box), strict=True
    ):
        if label:
            X.append(features(seg.points[idx], seg.colours[idx]))
            y.append(label)


def training_set(
    seed: int, samples: int, kinds: Sequence[Kind] = DEFAULT_KINDS
) -> tuple[FloatArray, list[str]]:
    """Features and labels of every labelled cluster of ``samples`` seeded scenes, two looks
    each (the fixed sensor and the wrist camera)."""
    rng = np.random.default_rng(seed)
    X: list[FloatArray] = []
    y: list[str] = []
    for _ in range(samples):
        prims, truths = scene(rng, kinds)
        for T in (fixed_camera(DEFAULT_BAY), wrist_camera(DEFAULT_BAY, truths[0].position)):
            obs, _ = observe(prims, INTRINSICS, T, rng)
            _add_look(segment(obs, DEFAULT_BAY, rng), truths, DEFAULT_BAY, X, y)
    return np.array(X), y


def training_set_from_looks(
    looks: Iterable[Any], bay_of: Callable[[int], BayBox]
) -> tuple[FloatArray, list[str]]:
    """Features and labels of every labelled cluster of rendered looks.

    Args:
        looks: Objects with ``observation``, ``truth`` (objects with ``label``, ``shape``,
            ``size`` and ``position``) and ``slot`` (the bay looked at), as
            ``kr210_sim.sensors.samples.render_samples`` yields them.
        bay_of: The bay's box of a slot.
    """
    rng = np.random.default_rng(0)
    X: list[FloatArray] = []
    y: list[str] = []
    for look in looks:
        box = bay_of(look.slot)
        _add_look(segment(look.observation, box, rng), list(look.truth), box, X, y)
    return np.array(X), y


def train(seed: int, samples: int, kinds: Sequence[Kind] = DEFAULT_KINDS) -> RecognitionModel:
    """A recogniser trained on ``samples`` seeded scenes."""
    X, y = training_set(seed, samples, kinds)
    return RecognitionModel(tuple(kinds), X, tuple(y), seed, samples)


def main(argv: Sequence[str] | None = None) -> int:
    """The training command on the ray caster's bays; 0 on success, 2 on a usage error (a
    cell's rendered scenes: ``python -m kr210_sim train-recogniser --cell FILE``)."""
    parser = argparse.ArgumentParser(
        prog="python -m kr210_sim.perception.train",
        description="Train the recogniser on seeded cluttered bays and write its model file.",
    )
    parser.add_argument("--seed", type=int, default=0, help="training seed (default 0)")
    parser.add_argument("--samples", type=int, default=150, help="scenes (default 150)")
    parser.add_argument("--out", type=Path, required=True, help="the model file to write")
    args = parser.parse_args(argv)
    if args.samples < 2:
        print(f"error: --samples must be at least 2, got {args.samples}", file=sys.stderr)
        return 2
    if not args.out.parent.is_dir():
        print(f"error: {args.out.parent} is not a directory", file=sys.stderr)
        return 2
    model = train(args.seed, args.samples)
    model.save(args.out)
    counts = {k: model.y.count(k) for k in sorted(set(model.y))}
    print(f"wrote {args.out}: {len(model.y)} clusters from {args.samples} scenes {counts}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
