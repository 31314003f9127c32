"""Recordings: the states of a run at a fixed rate, enough to render it again from any camera.

A recording is a NumPy ``.npz`` file (compressed, read without pickle) holding, per frame ``i``
(taken every ``1 / rate`` of simulated time):

* ``time`` [s] and ``qpos`` (the model's whole position vector);
* what the video overlay shows: ``cycle``, ``slot``, ``done``, ``successes``, ``phase`` and
  ``event`` (indices into the ``phases`` and ``event_texts`` tables of the metadata), and
  ``tail`` (True during the closing shot of the bin);
* the shapes of the target cylinders, which a randomised run changes per cycle: ``shape`` rows
  (``geom_size``, ``geom_rbound``, ``geom_aabb`` of each geom in ``target_geoms``), one per
  change, in force from frame ``shape_frame``.

The ``meta`` entry is a JSON text: the format name and :data:`VERSION`, the MuJoCo version, the
model identity (:func:`model_identity`), the rate, the run's settings and the report's summary and
events. Reading checks all of it (:func:`read_recording`) and says in one line what is wrong.

Only positions are recorded: rendering a frame needs nothing else (:func:`apply_frame` sets
``qpos`` and the target shapes and runs MuJoCo's position stage).
"""

from __future__ import annotations

import json
import logging
import zipfile
import zlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.cell.load import model_identity
from kr210_sim.errors import ConfigError, RecordingError
from kr210_sim.util.outputs import atomic_path, check_writable, is_stream

import mujoco  # isort: skip

log = logging.getLogger(__name__)
FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.signedinteger]

#: Name of the container format, in the metadata.
FORMAT = "kr210_sim.media.recording"
#: Version of the container format this code writes and reads (2: the model identity leaves
#: out the file paths the model was loaded from).
VERSION = 2
#: Default frames per simulated second [Hz].
DEFAULT_RATE = 30
#: Simulated seconds of the closing bin shot at the end of a recorded run [s].
DEFAULT_TAIL = 2.5
#: Per-frame arrays (one row per frame) and the other arrays a recording must hold.
FRAME_KEYS = ("time", "qpos", "cycle", "slot", "done", "successes", "phase", "event", "tail")
SHAPE_KEYS = ("shape_frame", "shape", "target_geoms")
#: Model fields of a target geom that drawing reads and a randomised spawn changes:
#: geom_size (3), geom_rbound (1), geom_aabb (6).
SHAPE_WIDTH = 10


def target_shapes(model: mujoco.MjModel, geoms: IntArray) -> FloatArray:
    """The drawn shape of each geom in ``geoms``: ``(len(geoms), 10)`` rows of geom_size,
    geom_rbound and geom_aabb."""
    return np.concatenate(
        [model.geom_size[geoms], model.geom_rbound[geoms, None], model.geom_aabb[geoms]], axis=1
    )


def apply_frame(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    qpos: FloatArray,
    geoms: IntArray,
    shapes: FloatArray,
) -> None:
    """Put ``data`` in the recorded state: positions, target shapes, then MuJoCo's position stage
    (kinematics, cameras, lights: what drawing reads)."""
    data.qpos[:] = qpos
    model.geom_size[geoms] = shapes[:, 0:3]
    model.geom_rbound[geoms] = shapes[:, 3]
    model.geom_aabb[geoms] = shapes[:, 4:10]
    mujoco.mj_fwdPosition(model, data)


@dataclass(frozen=True, slots=True)
class FrameStatus:
    """What the overlay shows at one frame (see :func:`kr210_sim.media.video.overlay_lines`).

    Attributes:
        time: Simulated time [s].
        cycle: Cycle number (0 before the first).
        cycles: Cycles in the run.
        slot: Slot of the cycle (0 before the first).
        phase: Phase name.
        done: Cycles finished.
        successes: Cycles that succeeded.
        event: Text of the event between cycles being shown, or "".
        seen: With ``--perceive``, what the cycle's look recognised ("" before a look or
            without perception; not kept in recordings).
        seen_at: Where it was estimated [m] (world), or None.
    """

    time: float
    cycle: int
    cycles: int
    slot: int
    phase: str
    done: int
    successes: int
    event: str
    seen: str = ""
    seen_at: tuple[float, float, float] | None = None

    def as_status(self) -> dict[str, object]:
        """The runner-style status dict (``Runner.status``)."""
        return {
            "cycle": self.cycle,
            "cycles": self.cycles,
            "slot": self.slot,
            "phase": self.phase,
            "done": self.done,
            "successes": self.successes,
            "event": self.event,
            "seen": self.seen,
        }

    def lines(self) -> list[str]:
        """The overlay's text lines."""
        from kr210_sim.media.video import overlay_lines

        return overlay_lines(self.as_status(), self.time)


def _status_of(status: Mapping[str, object], time: float) -> FrameStatus:
    def num(key: str) -> int:
        return int(status.get(key, 0))  # type: ignore[call-overload]

    return FrameStatus(
        time=time,
        cycle=num("cycle"),
        cycles=num("cycles"),
        slot=num("slot"),
        phase=str(status.get("phase", "")),
        done=num("done"),
        successes=num("successes"),
        event=str(status.get("event", "") or ""),
        seen=str(status.get("seen", "") or ""),
        seen_at=_point(status.get("seen_at")),
    )


def _point(value: object) -> tuple[float, float, float] | None:
    """A status's ``seen_at`` as a point [m], or None."""
    if value is None:
        return None
    x, y, z = (float(c) for c in value)  # type: ignore[attr-defined]
    return (x, y, z)


@dataclass(frozen=True)
class Recording:
    """A recorded run (see the module docstring for the arrays).

    Attributes:
        arrays: The arrays, by name.
        meta: The metadata (JSON-ready).
    """

    arrays: dict[str, npt.NDArray[Any]]
    meta: dict[str, Any]

    @property
    def frames(self) -> int:
        """Number of frames."""
        return len(self.arrays["time"])

    @property
    def rate(self) -> float:
        """Frames per simulated second [Hz]."""
        return float(self.meta["rate"])

    @property
    def target_geoms(self) -> IntArray:
        """Ids of the geoms whose shapes are recorded."""
        return self.arrays["target_geoms"].astype(np.int32)

    def shapes_at(self, i: int) -> FloatArray:
        """The target shapes in force at frame ``i``: ``(len(target_geoms), 10)``."""
        k = int(np.searchsorted(self.arrays["shape_frame"], i, side="right")) - 1
        shapes: FloatArray = self.arrays["shape"][max(k, 0)]
        return shapes

    def status(self, i: int) -> FrameStatus:
        """What the overlay shows at frame ``i``."""
        a = self.arrays
        return FrameStatus(
            time=float(a["time"][i]),
            cycle=int(a["cycle"][i]),
            cycles=int(self.meta["cycles"]),
            slot=int(a["slot"][i]),
            phase=str(self.meta["phases"][int(a["phase"][i])]),
            done=int(a["done"][i]),
            successes=int(a["successes"][i]),
            event=str(self.meta["event_texts"][int(a["event"][i])]),
        )


class StateRecorder:
    """A cell step hook that takes the state every ``1 / rate`` of simulated time.

    Frames are taken at the first physics step at or after ``k / rate`` (as the video's frames
    always were). Each frame is kept (``keep``) for :meth:`recording` and/or handed to ``sink``
    (the parallel renderer: ``sink(qpos, shapes, status, tail)``).

    Args:
        model: The cell model.
        target_geoms: Ids of the target cylinders' geoms.
        status: The runner's live status dict (read at every frame).
        rate: Frames per simulated second [Hz].
        keep: Keep the frames in memory for :meth:`recording`.
        sink: Called with every frame as it is taken.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        target_geoms: IntArray,
        status: Mapping[str, object],
        rate: float = DEFAULT_RATE,
        keep: bool = True,
        sink: Callable[[FloatArray, FloatArray, FrameStatus, bool], None] | None = None,
    ) -> None:
        if not 1 <= rate <= 1000:
            raise ConfigError(f"record rate must be 1-1000 frames per second, got {rate}")
        self.model = model
        self.geoms = np.asarray(target_geoms, dtype=np.int32)
        self.status = status
        self.rate = float(rate)
        self.keep = keep
        self.sink = sink
        #: True during the closing shot (set by the job before its last idle).
        self.tail = False
        self.frames = 0
        self._next_t = 0.0
        self._qpos: list[FloatArray] = []
        self._status: list[FrameStatus] = []
        self._tail: list[bool] = []
        self._shape_frame: list[int] = []
        self._shapes: list[FloatArray] = []
        self._last_shapes: FloatArray | None = None

    def __call__(self, cell: Any) -> None:
        """Step hook: take a frame when one is due."""
        data = cell.data
        if data.time + 1e-9 >= self._next_t:
            self.capture(data)

    def capture(self, data: mujoco.MjData) -> None:
        """Take one frame of ``data`` now (and schedule the next one)."""
        qpos = data.qpos.copy()
        shapes = target_shapes(self.model, self.geoms)
        status = _status_of(self.status, float(data.time))
        if self.keep:
            if self._last_shapes is None or not np.array_equal(shapes, self._last_shapes):
                self._shape_frame.append(self.frames)
                self._shapes.append(shapes)
            self._qpos.append(qpos)
            self._status.append(status)
            self._tail.append(self.tail)
        self._last_shapes = shapes
        self.frames += 1
        self._next_t = self.frames / self.rate
        if self.sink is not None:
            self.sink(qpos, shapes, status, self.tail)

    def recording(self, meta: Mapping[str, Any]) -> Recording:
        """The frames kept so far as a :class:`Recording` with ``meta`` (the rate, phase and
        event tables and the cycle count are filled in here)."""
        st = self._status
        phases = sorted({s.phase for s in st})
        events = ["", *sorted({s.event for s in st} - {""})]
        nq = self.model.nq
        T = len(self.geoms)
        if not self._shapes:
            self._shape_frame.append(0)
            self._shapes.append(target_shapes(self.model, self.geoms))
        arrays: dict[str, npt.NDArray[Any]] = {
            "time": np.array([s.time for s in st], dtype=np.float64),
            "qpos": np.array(self._qpos, dtype=np.float64).reshape(len(st), nq),
            "cycle": np.array([s.cycle for s in st], dtype=np.int32),
            "slot": np.array([s.slot for s in st], dtype=np.int32),
            "done": np.array([s.done for s in st], dtype=np.int32),
            "successes": np.array([s.successes for s in st], dtype=np.int32),
            "phase": np.array([phases.index(s.phase) for s in st], dtype=np.int16),
            "event": np.array([events.index(s.event) for s in st], dtype=np.int16),
            "tail": np.array(self._tail, dtype=bool),
            "shape_frame": np.array(self._shape_frame, dtype=np.int64),
            "shape": np.array(self._shapes, dtype=np.float64).reshape(-1, T, SHAPE_WIDTH),
            "target_geoms": self.geoms.copy(),
        }
        cycles = int(self.status.get("cycles", 0))  # type: ignore[call-overload]
        full = {
            **meta,
            "format": FORMAT,
            "version": VERSION,
            "mujoco": mujoco.__version__,
            "rate": self.rate,
            "cycles": cycles,
            "nq": nq,
            "phases": phases,
            "event_texts": events,
        }
        return Recording(arrays, full)


def check_recording_path(path: Path) -> Path:
    """Refuse, before anything runs, a recording path that cannot be written.

    Raises:
        ConfigError: Not ending in ``.npz``, a pipe or device, or unwritable.
    """
    if path.suffix.lower() != ".npz":
        raise ConfigError(f"recording path must end in .npz, got {path}")
    check_writable(path)
    if is_stream(path):
        raise ConfigError(f"--record {path}: a recording needs a regular file")
    return path


def write_recording(path: Path | str, recording: Recording) -> Path:
    """Write ``recording`` to ``path`` (compressed ``.npz``) atomically.

    Raises:
        ConfigError: When the file cannot be written.
    """
    p = Path(path)
    meta = np.array(json.dumps(recording.meta, sort_keys=True))
    with atomic_path(p, suffix=".npz") as tmp, open(tmp, "wb") as fh:
        np.savez_compressed(fh, meta=meta, **recording.arrays)  # type: ignore[arg-type]
    return p


def _fail(path: Path | str, what: str) -> RecordingError:
    return RecordingError(f"{path}: {what}")


def read_recording(path: Path | str) -> Recording:
    """Read and check a recording.

    Raises:
        RecordingError: When the file is missing, truncated or not a recording, has an unknown
            format version, lacks an array or has arrays that disagree (one line each).
    """
    p = Path(path)
    if not p.is_file():
        raise _fail(p, "no such file" if not p.exists() else "not a file")
    try:
        with np.load(p, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, KeyError) as exc:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise _fail(p, f"not a readable recording (truncated or not an .npz: {reason})") from exc
    if "meta" not in arrays:
        raise _fail(p, "not a kr210_sim recording (no 'meta' entry)")
    try:
        meta = json.loads(str(arrays.pop("meta")))
    except (json.JSONDecodeError, TypeError) as exc:
        raise _fail(p, f"its metadata is not JSON ({exc})") from exc
    if not isinstance(meta, dict):
        raise _fail(p, f"not a kr210_sim recording (its metadata is a JSON {type(meta).__name__})")
    if meta.get("format") != FORMAT:
        raise _fail(p, f"not a kr210_sim recording (format {meta.get('format')!r})")
    version = meta.get("version")
    if version != VERSION:
        raise _fail(
            p,
            f"recording format version {version!r}; this kr210_sim reads version {VERSION}: "
            "record it again, or replay it with the kr210_sim that wrote it",
        )
    missing = [k for k in (*FRAME_KEYS, *SHAPE_KEYS) if k not in arrays]
    missing += [k for k in ("mujoco", "model_sha256", "rate", "cycles", "nq") if k not in meta]
    missing += [k for k in ("phases", "event_texts") if k not in meta]
    if missing:
        raise _fail(p, f"damaged recording: it lacks {', '.join(repr(k) for k in missing)}")
    _check_meta(p, meta)
    _check_consistent(p, arrays, meta)
    return Recording(arrays, meta)


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _check_meta(p: Path, meta: dict[str, Any]) -> None:
    """Refuse metadata of the wrong types or out of range (a hand-edited or damaged file)."""
    rate = meta["rate"]
    if not isinstance(rate, (int, float)) or isinstance(rate, bool) or not 1 <= rate <= 1000:
        raise _fail(p, f"damaged recording: rate {rate!r} is not 1-1000 frames per second")
    for key in ("nq", "cycles"):
        if not _is_int(meta[key]) or meta[key] < (1 if key == "nq" else 0):
            raise _fail(p, f"damaged recording: {key} {meta[key]!r} is not a whole number")
    for key in ("phases", "event_texts"):
        table = meta[key]
        if not isinstance(table, list) or not all(isinstance(x, str) for x in table):
            raise _fail(p, f"damaged recording: {key} is not a list of texts")
    for key in ("mujoco", "model_sha256"):
        if not isinstance(meta[key], str):
            raise _fail(p, f"damaged recording: {key} {meta[key]!r} is not a text")
    scene = meta.get("scene")
    if scene is not None and not isinstance(scene, str):
        raise _fail(p, f"damaged recording: scene {scene!r} is not a path")


def _check_consistent(p: Path, a: dict[str, npt.NDArray[Any]], meta: dict[str, Any]) -> None:
    n = len(a["time"]) if a["time"].ndim else 0
    if n == 0:
        raise _fail(p, "the recording holds no frames")
    for k in FRAME_KEYS:
        if a[k].ndim == 0 or a[k].shape[:1] != (n,):
            raise _fail(p, f"damaged recording: {k!r} has {a[k].shape[:1]} rows, time has {n}")
    numeric = ("time", "qpos", "shape")
    whole = ("cycle", "slot", "done", "successes", "phase", "event", "shape_frame", "target_geoms")
    for k in numeric:
        if a[k].dtype.kind not in "iuf":
            raise _fail(p, f"damaged recording: {k!r} holds {a[k].dtype}, not numbers")
    for k in (*whole, "tail"):
        if a[k].dtype.kind not in "iub":
            raise _fail(p, f"damaged recording: {k!r} holds {a[k].dtype}, not whole numbers")
        if a[k].size and int(a[k].min()) < 0:
            raise _fail(p, f"damaged recording: {k!r} holds a negative number")
    if a["qpos"].shape != (n, int(meta["nq"])):
        raise _fail(p, f"damaged recording: qpos is {a['qpos'].shape}, expected ({n}, nq)")
    T = len(a["target_geoms"]) if a["target_geoms"].ndim == 1 else -1
    if T < 0 or a["shape"].ndim != 3 or a["shape"].shape[1:] != (T, SHAPE_WIDTH):
        raise _fail(p, f"damaged recording: shape is {a['shape'].shape}")
    if (
        a["shape_frame"].ndim != 1
        or len(a["shape_frame"]) != len(a["shape"])
        or not len(a["shape"])
    ):
        raise _fail(p, "damaged recording: shape_frame and shape disagree")
    if int(a["phase"].max(initial=0)) >= len(meta["phases"]):
        raise _fail(p, "damaged recording: a phase index is out of range")
    if int(a["event"].max(initial=0)) >= len(meta["event_texts"]):
        raise _fail(p, "damaged recording: an event index is out of range")
    if not np.all(np.isfinite(a["qpos"])) or not np.all(np.diff(a["time"]) > 0):
        raise _fail(p, "damaged recording: positions not finite or times not increasing")
    if not np.all(np.isfinite(a["time"])) or not np.all(np.isfinite(a["shape"])):
        raise _fail(p, "damaged recording: times or shapes not finite")


def check_model(path: Path | str, recording: Recording, model: mujoco.MjModel) -> None:
    """Refuse to render ``recording`` with ``model`` unless it was made with the same MuJoCo
    version and the same compiled model (scene or cell).

    Raises:
        RecordingError: Naming what differs and what to do.
    """
    meta = recording.meta
    if meta["mujoco"] != mujoco.__version__:
        raise _fail(
            path,
            f"recorded with MuJoCo {meta['mujoco']}, this is MuJoCo {mujoco.__version__}: "
            f"replay it with mujoco=={meta['mujoco']}",
        )
    if model.nq != int(meta["nq"]) or meta["model_sha256"] != model_identity(model):
        made = meta.get("scene")
        option = "--cell" if made and Path(made).suffix.lower() == ".toml" else "--scene"
        made_with = f" (made with {option} {made})" if made else ""
        raise _fail(
            path,
            f"recorded with another scene or cell{made_with}: model sha256 "
            f"{str(meta['model_sha256'])[:12]}, this one {model_identity(model)[:12]}; pass "
            "the scene or cell file it was made with as --scene",
        )
    T = recording.target_geoms
    if len(T) and (T.min() < 0 or T.max() >= model.ngeom):
        raise _fail(path, "damaged recording: target geom ids outside the model")


def run_meta(
    config: Any,
    identity: str,
    scene: Path | None,
    report: Mapping[str, Any] | None,
    video: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The metadata of a run's recording: settings, model identity, report summary and events."""
    from kr210_sim.util.versions import package_version

    meta: dict[str, Any] = {
        "kr210_sim": package_version(),
        "model_sha256": identity,
        "scene": str(Path(scene).resolve()) if scene is not None else None,
        "run": {"seed": config.seed, "slot": config.slot, "randomize": config.randomize},
    }
    if report is not None:
        meta["summary"] = report.get("summary", {})
        meta["events"] = report.get("events", [])
        meta["interrupted"] = bool(report.get("interrupted", False))
    if video is not None:
        meta["video"] = dict(video)
    return meta
