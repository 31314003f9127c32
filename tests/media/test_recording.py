"""Recordings: what a run records, the container read back, and every bad recording refused."""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from kr210_sim.cell.load import load_model
from kr210_sim.cli import main
from kr210_sim.errors import RecordingError
from kr210_sim.jobs import run_job
from kr210_sim.media.recording import (
    VERSION,
    check_model,
    model_identity,
    read_recording,
)
from kr210_sim.score.report import strip_wall
from kr210_sim.sim.runner import RunConfig

CONFIG = RunConfig(cycles=2, seed=3, randomize=True)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Any]:
    """A two-cycle randomised run recorded at 30 Hz (its job result alongside)."""
    folder = tmp_path_factory.mktemp("rec")
    job = run_job(CONFIG, folder / "run.json", record=folder / "run.npz")
    return folder / "run.npz", job


def test_a_run_records_its_states_overlay_and_summary(recorded: tuple[Path, Any]) -> None:
    path, job = recorded
    rec = read_recording(path)
    # One frame per 1/30 s of simulated time, the closing bin shot included.
    assert rec.frames == job.record_frames
    assert abs(rec.frames - job.sim_time * 30) <= 1.5
    t = rec.arrays["time"]
    assert t[0] < 1 / 30 and np.allclose(np.diff(t), 1 / 30, atol=0.0021)
    model = load_model()
    assert rec.arrays["qpos"].shape == (rec.frames, model.nq)
    # The overlay's fields: cycles 0 -> 1 -> 2, score after each, the closing shot flagged.
    assert list(np.unique(rec.arrays["cycle"])) == [1, 2]
    assert rec.status(rec.frames - 1).done == 2 and rec.status(0).phase == "spawn"
    tail = rec.arrays["tail"]
    assert not tail[0] and tail[-1] and abs(tail.sum() / 30 - 2.5) < 0.1
    # Randomised targets: each spawn changes a cylinder's shape, which the recording keeps.
    # The first cylinder is spawned before the first frame; the second is a change.
    assert len(rec.arrays["shape_frame"]) == 2
    assert rec.arrays["shape_frame"][1] == np.argmax(rec.arrays["cycle"] == 2)
    for k, cycle in enumerate(job.report["cycles"]):
        radius = rec.arrays["shape"][k][:, 0]
        assert np.isclose(radius, cycle["target"]["spec"]["radius"], atol=1e-12).sum() == 1
    # Identity and summary.
    assert rec.meta["model_sha256"] == model_identity(model)
    assert rec.meta["summary"] == job.report["summary"]
    assert rec.meta["version"] == VERSION and rec.meta["run"]["randomize"] is True
    check_model(path, rec, model)
    # Compact: well under a few MB for ten cycles (here 2 cycles).
    assert path.stat().st_size < 200_000


def test_recording_leaves_the_report_unchanged(recorded: tuple[Path, Any], tmp_path: Path) -> None:
    _, job = recorded
    plain = run_job(CONFIG, tmp_path / "plain.json")
    assert strip_wall(plain.report) == strip_wall(job.report)


def test_model_identity_is_stable_and_sees_changes() -> None:
    a, b = load_model(), load_model()
    assert model_identity(a) == model_identity(b)
    c = copy.copy(a)
    c.geom_rgba[0] = (0.1, 0.2, 0.3, 1.0)  # a restyled geom is another model
    assert model_identity(c) != model_identity(a)


def test_model_identity_does_not_depend_on_how_the_scene_path_is_spelled(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import os
    import shutil

    from kr210_sim.cell.load import model_at
    from kr210_sim.util.paths import ROOT, SCENE_PATH

    ours = model_identity(load_model())
    monkeypatch.chdir(ROOT)
    assert model_identity(model_at("scenes/kr210_cell.xml")) == ours
    monkeypatch.chdir(ROOT / "kr210_sim")
    assert model_identity(model_at(os.path.relpath(SCENE_PATH))) == ours
    copy_root = tmp_path / "copy"  # KR210_SIM_ROOT pointing at a copy of the data
    shutil.copytree(ROOT / "assets", copy_root / "assets")
    shutil.copytree(ROOT / "scenes", copy_root / "scenes")
    assert model_identity(load_model(copy_root / "scenes" / "kr210_cell.xml")) == ours
    # The published cell file compiles to the committed scene's model, and so is its identity.
    assert model_identity(model_at(ROOT / "scenes" / "cells" / "published.toml")) == ours


def test_a_recording_names_its_scene_by_an_absolute_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from kr210_sim.media.recording import run_meta

    monkeypatch.chdir(tmp_path)
    meta = run_meta(CONFIG, "0" * 64, Path("cells/mine.toml"), None)
    assert meta["scene"] == str(tmp_path / "cells" / "mine.toml")


def _rewrite(
    src: Path,
    dst: Path,
    meta: Any = None,
    drop: str = "",
    arrays_: dict[str, Any] | None = None,
) -> Path:
    with np.load(src) as npz:
        arrays = {k: npz[k] for k in npz.files if k != drop}
    arrays.update(arrays_ or {})
    if meta is not None:
        arrays["meta"] = np.array(json.dumps(meta))
    with open(dst, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    return dst


def _meta(path: Path) -> dict[str, Any]:
    with np.load(path) as npz:
        return json.loads(str(npz["meta"]))  # type: ignore[no-any-return]


def _bad_recordings(src: Path, folder: Path) -> dict[str, tuple[Path, str]]:
    data = src.read_bytes()
    truncated = folder / "truncated.npz"
    truncated.write_bytes(data[: len(data) // 2])
    text = folder / "text.npz"
    text.write_text("not a recording")
    meta = _meta(src)
    return {
        "truncated": (truncated, "truncated or not an .npz"),
        "text": (text, "truncated or not an .npz"),
        "missing file": (folder / "none.npz", "no such file"),
        "version": (
            _rewrite(src, folder / "v2.npz", {**meta, "version": VERSION + 1}),
            f"format version {VERSION + 1}; this kr210_sim reads version {VERSION}",
        ),
        "format": (
            _rewrite(src, folder / "fmt.npz", {**meta, "format": "other"}),
            "not a kr210_sim recording",
        ),
        "no meta": (_rewrite(src, folder / "nometa.npz", drop="meta"), "no 'meta' entry"),
        "missing qpos": (_rewrite(src, folder / "noq.npz", drop="qpos"), "lacks 'qpos'"),
        "missing shapes": (_rewrite(src, folder / "nos.npz", drop="shape"), "lacks 'shape'"),
        "other scene": (
            _rewrite(src, folder / "scene.npz", {**meta, "model_sha256": "0" * 64}),
            "recorded with another scene or cell",
        ),
        "other mujoco": (
            _rewrite(src, folder / "mj.npz", {**meta, "mujoco": "3.2.0"}),
            "recorded with MuJoCo 3.2.0",
        ),
        # Damaged by hand: each was a traceback (or, rate 0, exit 0 without a video).
        "meta a list": (_rewrite(src, folder / "list.npz", [meta]), "metadata is a JSON list"),
        "nq a string": (
            _rewrite(src, folder / "nq.npz", {**meta, "nq": "x"}),
            "nq 'x' is not a whole number",
        ),
        "phases a number": (
            _rewrite(src, folder / "ph.npz", {**meta, "phases": 3}),
            "phases is not a list of texts",
        ),
        "phase strings": (
            _rewrite(src, folder / "phs.npz", meta, arrays_={"phase": _phase_texts(src)}),
            "'phase' holds <U5, not whole numbers",
        ),
        "rate 0": (
            _rewrite(src, folder / "rate.npz", {**meta, "rate": 0}),
            "rate 0 is not 1-1000 frames per second",
        ),
        "rate negative": (
            _rewrite(src, folder / "rateneg.npz", {**meta, "rate": -30.0}),
            "rate -30.0 is not 1-1000 frames per second",
        ),
    }


def _phase_texts(src: Path) -> np.ndarray:
    with np.load(src) as npz:
        return np.array(["spawn"] * len(npz["phase"]))


def test_bad_recordings_are_one_line_and_exit_2(
    recorded: tuple[Path, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    src, _ = recorded
    for name, (path, message) in _bad_recordings(src, tmp_path).items():
        video = tmp_path / f"{path.stem}.mp4"
        assert main(["replay", str(path), "--video", str(video)]) == 2, name
        err = capsys.readouterr().err
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1 and "Traceback" not in err, (name, err)
        assert lines[0].startswith("kr210_sim: error: ") and message in lines[0], (name, err)
        assert not video.exists()
        if path.exists():  # view --replay reads it the same way, before any viewer starts
            assert main(["view", "--replay", str(path), "--web"]) == 2, name
            err = capsys.readouterr().err
            assert "Traceback" not in err and message in err, (name, err)
    with pytest.raises(RecordingError, match="lacks 'qpos'"):
        read_recording(tmp_path / "noq.npz")


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--report", "{d}/r.npz", "--record", "{d}/r.npz"], "--record and --report name the same"),
        (["--record", "{d}/run.mp4"], "recording path must end in .npz"),
        (["--record-rate", "10"], "--record-rate needs --record"),
        (["--render-workers", "2"], "--render-workers needs --video"),
    ],
)
def test_recording_options_are_checked_before_the_run(
    tmp_path: Path, extra: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["run", "--cycles", "1", "--report", str(tmp_path / "r.json")]
    assert main([*argv, *(a.format(d=tmp_path) for a in extra)]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "r.json").exists()
