"""The recogniser: an SVM on cluster features, and the versioned file it ships in.

The file is JSON, not a pickle: it holds the training set itself (each sample's feature
vector, rounded to 6 significant digits, and its label) with the format version, the training
seed and the sample count. Loading fits scikit-learn's SVM to it afresh (a few hundred samples:
about 0.1 s), seeded by the stored seed, so the file runs no code, does not depend on
scikit-learn's internal layout from one version to the next, and the same seed writes the same
bytes.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np
import numpy.typing as npt
from sklearn.calibration import CalibratedClassifierCV
from sklearn.pipeline import Pipeline, make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from kr210_sim.perception.features import N_FEATURES
from kr210_sim.perception.kinds import Kind

FloatArray = npt.NDArray[np.float64]

#: The model file's format; a file of another version is refused with a clear message.
FORMAT_VERSION = 1
#: The model that ships with the package (``python -m kr210_sim.perception.train`` rebuilds it).
DEFAULT_MODEL = "recogniser.json"


class ModelFileError(ValueError):
    """A model file that cannot be read: its message says why and how to rebuild it."""


@dataclass
class RecognitionModel:
    """A trained recogniser.

    Attributes:
        kinds: The kinds it tells apart (their labels are its classes).
        X: (N, :data:`N_FEATURES`) training features.
        y: (N,) training labels.
        seed: The training seed.
        samples: The number of scenes it was trained on.
    """

    kinds: tuple[Kind, ...]
    X: FloatArray
    y: tuple[str, ...]
    seed: int
    samples: int
    _svm: Pipeline | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.X.ndim != 2 or self.X.shape[1] != N_FEATURES or len(self.X) != len(self.y):
            raise ModelFileError(
                f"training set is {self.X.shape} with {len(self.y)} labels; "
                f"expected (N, {N_FEATURES}) with N labels"
            )
        if len(set(self.y)) < 2:
            raise ModelFileError("a recogniser needs samples of at least two kinds")

    @property
    def svm(self) -> Pipeline:
        """The SVM (scaled features, RBF kernel), its scores calibrated to probabilities by
        Platt's sigmoid on 3-fold cross-validation (unshuffled folds: deterministic), fitted on
        first use."""
        if self._svm is None:
            svm = make_pipeline(
                StandardScaler(),
                CalibratedClassifierCV(SVC(C=10.0, gamma="scale"), cv=3, ensemble=False),
            )
            svm.fit(self.X, np.asarray(self.y))
            self._svm = svm
        return self._svm

    @property
    def labels(self) -> tuple[str, ...]:
        """The classes, in the order of :meth:`probabilities`' columns."""
        return tuple(str(c) for c in self.svm.classes_)

    def probabilities(self, F: npt.ArrayLike) -> FloatArray:
        """(M, classes) probability of each class for each feature vector in ``F``."""
        return np.asarray(self.svm.predict_proba(np.atleast_2d(F)))

    def kind(self, label: str) -> Kind:
        """The kind of ``label``."""
        for k in self.kinds:
            if k.name == label:
                return k
        raise KeyError(f"unknown kind {label!r}; the model knows {[k.name for k in self.kinds]}")

    def to_json(self) -> str:
        """The model file's text (the same training set gives the same text)."""
        doc = {
            "format_version": FORMAT_VERSION,
            "seed": self.seed,
            "samples": self.samples,
            "n_features": N_FEATURES,
            "kinds": [
                {"name": k.name, "shape": k.shape, "size": list(k.size), "rgb": list(k.rgb)}
                for k in self.kinds
            ],
            "labels": list(self.y),
            "features": [[float(f"{v:.6g}") for v in row] for row in self.X],
        }
        return json.dumps(doc, separators=(",", ":")) + "\n"

    @classmethod
    def from_json(cls, text: str, source: str = "model file") -> RecognitionModel:
        """Read a model file's text.

        Raises:
            ModelFileError: When it is not a model file of this format version.
        """
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ModelFileError(f"{source} is not JSON ({exc.msg})") from exc
        version = doc.get("format_version") if isinstance(doc, dict) else None
        if version != FORMAT_VERSION:
            raise ModelFileError(
                f"{source} has format version {version!r}, this package reads "
                f"{FORMAT_VERSION}: rebuild it with python -m kr210_sim.perception.train"
            )
        try:
            kinds = tuple(
                Kind(k["name"], k["shape"], tuple(k["size"]), tuple(k["rgb"])) for k in doc["kinds"]
            )
            X = np.asarray(doc["features"], dtype=np.float64).reshape(-1, N_FEATURES)
            return cls(kinds, X, tuple(doc["labels"]), int(doc["seed"]), int(doc["samples"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelFileError(f"{source} is not a recogniser model: {exc}") from exc

    def save(self, path: Path | str) -> None:
        """Write the model file."""
        Path(path).write_text(self.to_json(), encoding="utf-8")


def load_model(path: Path | str | None = None) -> RecognitionModel:
    """A model file; the one that ships with the package when ``path`` is None.

    Raises:
        ModelFileError: When it is missing or not a model of this format version.
    """
    if path is None:
        res = resources.files("kr210_sim.perception").joinpath("data", DEFAULT_MODEL)
        try:
            text = res.read_text(encoding="utf-8")
        except FileNotFoundError as exc:
            raise ModelFileError(
                "the package's recogniser model is missing: "
                "build it with python -m kr210_sim.perception.train"
            ) from exc
        return RecognitionModel.from_json(text, f"the package's {DEFAULT_MODEL}")
    p = Path(path)
    if not p.is_file():
        raise ModelFileError(f"model file {p} does not exist")
    return RecognitionModel.from_json(p.read_text(encoding="utf-8"), str(p))
