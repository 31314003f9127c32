"""The recogniser of a cell: the shipped one when it knows the cell's kinds, else one trained on
the cell's own rendered scenes, once, and kept in a cache.

The package ships a recogniser trained on the cluttered example cell
(:func:`~kr210_sim.perception.model.load_model`). A cell of other kinds (another colour, size or
shape, a kind of its own) cannot be told apart by it: :func:`recogniser_for` then renders
:data:`TRAIN_SCENES` seeded scenes of the cell itself (:func:`~kr210_sim.sensors.samples.
render_samples`, both sensors, as the shipped model was trained) and trains on them, about half a
minute on two cores. The model is written to the cache (:func:`cache_dir`) under a name that is a
hash of everything the training saw: the kinds, the sensors, the shelf, the target and its
randomisation, the clutter, and this package's version. The next run of the same cell reads it
in milliseconds; a cache that cannot be written costs only the training again.
"""

from __future__ import annotations

import hashlib
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from kr210_sim.cell.layout import CellLayout
from kr210_sim.cell.sensing import TARGET_KIND, TARGET_RGB
from kr210_sim.cell.sensing_layout import clutter_of, kinds_of, pick_list_of, sensors_of
from kr210_sim.errors import ConfigError
from kr210_sim.perception.kinds import Kind
from kr210_sim.perception.model import ModelFileError, RecognitionModel, load_model
from kr210_sim.perception.train import training_set_from_looks
from kr210_sim.sensors.samples import render_samples
from kr210_sim.sim.perceived import layout_bay
from kr210_sim.util.outputs import commit, discard, temp_beside
from kr210_sim.util.versions import package_version

import mujoco  # isort: skip

#: Scenes a cell's own recogniser is trained on (the shipped model's count), and their seed.
TRAIN_SCENES, TRAIN_SEED = 120, 0
#: How close a cell's kind must be to a shipped one to be told apart by the shipped model:
#: colour (each channel, 0-1) and size [m].
RGB_TOLERANCE, SIZE_TOLERANCE = 0.02, 0.002

#: Fewest clusters of a kind it is trained on (the SVM's calibration is 3-fold).
MIN_SAMPLES = 3

#: This process's recognisers, by the hash of what they were trained for.
_MEMO: dict[str, RecognitionModel] = {}


def cell_kinds(model: mujoco.MjModel) -> tuple[Kind, ...]:
    """The kinds of a compiled cell: its target cylinder (at the cell's nominal size) and its
    ``[[objects]]`` kinds, in the cell file's order."""
    t = CellLayout.from_model(model).target
    own = Kind(TARGET_KIND, "cylinder", (t.radius, t.length), TARGET_RGB)
    return (own, *(Kind.of(k) for k in kinds_of(model)))


def knows(recogniser: RecognitionModel, kinds: tuple[Kind, ...]) -> bool:
    """Whether ``recogniser`` was trained on every one of ``kinds``: the same name and shape,
    the colour within :data:`RGB_TOLERANCE` and the size within :data:`SIZE_TOLERANCE` (the
    target's size aside: recognisers are trained on targets of the randomised sizes)."""
    for kind in kinds:
        try:
            own = recogniser.kind(kind.name)
        except KeyError:
            return False
        if own.shape != kind.shape or not np.allclose(own.rgb, kind.rgb, atol=RGB_TOLERANCE):
            return False
        if kind.name != TARGET_KIND and not np.allclose(own.size, kind.size, atol=SIZE_TOLERANCE):
            return False
    return {k.name for k in kinds} <= set(recogniser.y)


def signature(model: mujoco.MjModel, scenes: int = TRAIN_SCENES, seed: int = TRAIN_SEED) -> str:
    """The hash (hex) of all that a recogniser trained on ``model``'s scenes depends on."""
    layout = CellLayout.from_model(model)
    parts = [
        f"kr210_sim {package_version()}",
        f"scenes {scenes} seed {seed}",
        repr(cell_kinds(model)),
        repr(tuple(sorted(sensors_of(model).items()))),
        repr(clutter_of(model)),
        repr(pick_list_of(model)),
        repr(layout.target),
        repr(layout.randomization),
        np.round(np.asarray(layout.slots, dtype=np.float64), 6).tobytes().hex(),
        repr((layout.shelf.center.round(6).tolist(), layout.shelf.R.round(6).tolist())),
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def cache_dir() -> Path:
    """Where trained recognisers are kept: ``$KR210_CACHE``, else ``$XDG_CACHE_HOME/kr210_sim``,
    else ``~/.cache/kr210_sim``."""
    if os.environ.get("KR210_CACHE"):
        return Path(os.environ["KR210_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "kr210_sim"


def train_for(
    model: mujoco.MjModel, scenes: int = TRAIN_SCENES, seed: int = TRAIN_SEED
) -> RecognitionModel:
    """A recogniser trained on ``scenes`` seeded rendered scenes of ``model``'s cell, each seen
    by its fixed sensors and from the wrist camera's second-look pose.

    Raises:
        ConfigError: When the cell has no sensors or fewer than two kinds were seen.
    """
    sensors = tuple(sensors_of(model))
    if not sensors:
        raise ConfigError("the cell has no sensors to train a recogniser with")
    layout = CellLayout.from_model(model)
    looks = render_samples(model, scenes, seed=seed, sensors=sensors)
    X, y = training_set_from_looks(looks, lambda slot: layout_bay(layout, slot))
    # a kind seen fewer than MIN_SAMPLES times cannot be calibrated (3-fold): left out, unseen
    keep = np.array([y.count(label) >= MIN_SAMPLES for label in y], dtype=bool)
    X, y = X[keep] if len(X) else X, [label for label, k in zip(y, keep, strict=True) if k]
    try:
        return RecognitionModel(cell_kinds(model), X, tuple(y), seed, scenes)
    except ModelFileError as exc:
        raise ConfigError(f"cannot train a recogniser on this cell: {exc}") from exc


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def recogniser_for(
    model: mujoco.MjModel,
    cache: Path | None = None,
    say: Callable[[str], None] = _say,
    scenes: int = TRAIN_SCENES,
) -> RecognitionModel:
    """The recogniser for ``model``'s cell.

    Args:
        model: The compiled cell.
        cache: Where trained recognisers are kept (default :func:`cache_dir`).
        say: Where the lines announcing a training go (stderr).
        scenes: How many scenes a training renders.

    Returns:
        The shipped model when it :func:`knows` the cell's kinds; else the cell's own, read from
        the cache or trained now (and then written to the cache, atomically).

    Raises:
        ConfigError: When a model must be trained and cannot be.
    """
    key = signature(model, scenes)
    if key in _MEMO:
        return _MEMO[key]
    if "shipped" not in _MEMO:
        _MEMO["shipped"] = load_model()
    kinds = cell_kinds(model)
    if knows(_MEMO["shipped"], kinds):
        _MEMO[key] = _MEMO["shipped"]
        return _MEMO[key]
    path = (cache or cache_dir()) / f"recogniser-{key[:20]}.json"
    try:
        _MEMO[key] = load_model(path)
        return _MEMO[key]
    except (ModelFileError, OSError):
        pass  # none yet (or unreadable): train one
    names = ", ".join(k.name for k in kinds)
    say(
        f"perception: the shipped recogniser does not know this cell's kinds ({names}); "
        f"training one on {scenes} rendered scenes of the cell (once, about {scenes // 4} s)"
    )
    t0 = time.perf_counter()
    trained = train_for(model, scenes)
    missing = [k for k in dict.fromkeys(pick_list_of(model)) if k not in set(trained.y)]
    if missing:
        raise ConfigError(
            f"cannot train a recogniser on this cell: no look saw its pick kind "
            f"{', '.join(missing)} (are the sensors pointed at the shelf?)"
        )
    where = _store(trained, path)
    say(f"perception: trained in {time.perf_counter() - t0:.0f} s; {where}")
    _MEMO[key] = trained
    return trained


def _store(trained: RecognitionModel, path: Path) -> str:
    """Write ``trained`` to ``path`` atomically; what became of it, in words."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = temp_beside(path)
    except (OSError, ConfigError) as exc:
        return f"not cached ({exc})"
    try:
        tmp.write_text(trained.to_json(), encoding="utf-8")
        commit(tmp, path)
    except (OSError, ConfigError) as exc:
        discard(tmp)
        return f"not cached ({exc})"
    return f"cached in {path}"
