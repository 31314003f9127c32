"""The recogniser of a cell: the shipped one for the kinds it knows, else one trained on the
cell's own rendered scenes, announced, cached, read back, and picking the cell's own kinds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from kr210_sim.cell.load import model_at
from kr210_sim.cli import main
from kr210_sim.perception.model import load_model
from kr210_sim.perception.pipeline import perceive
from kr210_sim.sensors import recognisers
from kr210_sim.sensors.recognisers import cell_kinds, knows, recogniser_for, signature
from kr210_sim.sensors.samples import render_samples
from kr210_sim.sim.perceived import layout_bay

CELLS = Path(__file__).resolve().parents[2] / "scenes" / "cells"
CLUTTERED = (CELLS / "cluttered.toml").read_text()


def _cell(tmp_path: Path, name: str, *edits: tuple[str, str]) -> Path:
    """The cluttered cell with ``edits`` (old, new) made to its text."""
    text = CLUTTERED
    for old, new in edits:
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


PURPLE = (
    ('name = "red_can"  ', 'name = "purple_can"'),
    ('"target", "red_can"', '"target", "purple_can"'),
    ("color = [0.85, 0.1, 0.08]", "color = [0.55, 0.1, 0.75]"),
)


@pytest.fixture(autouse=True)
def _fresh_memo() -> None:
    recognisers._MEMO.clear()


def test_the_shipped_model_knows_the_cluttered_cells_kinds_and_no_others(tmp_path: Path) -> None:
    shipped = load_model()
    assert knows(shipped, cell_kinds(model_at(CELLS / "cluttered.toml")))
    # the target at another nominal size: trained on the randomised sizes, still known
    bigger = _cell(tmp_path, "bigger", ("radius = 0.05\n", "radius = 0.055\n"))
    assert knows(shipped, cell_kinds(model_at(bigger)))
    recoloured = _cell(tmp_path, "recoloured", PURPLE[2])
    resized = _cell(tmp_path, "resized", ("size = [0.045, 0.22]", "size = [0.045, 0.16]"))
    renamed = _cell(tmp_path, "renamed", *PURPLE[:2])
    for path in (recoloured, resized, renamed):
        assert not knows(shipped, cell_kinds(model_at(path))), path.name


def test_the_cluttered_cell_gets_the_shipped_model_and_nothing_is_written(tmp_path: Path) -> None:
    said: list[str] = []
    got = recogniser_for(model_at(CELLS / "cluttered.toml"), tmp_path, said.append)
    assert got.to_json() == load_model().to_json()
    assert said == [] and list(tmp_path.iterdir()) == []


def test_a_cell_of_its_own_kinds_is_trained_once_cached_and_picked_from(tmp_path: Path) -> None:
    """A purple can the shipped model never saw: trained on the cell's scenes (announced on
    one line, then its time and where it went), written to the cache, read back by a fresh
    process without training, and the purple can found where it stands in held-out scenes."""
    model = model_at(_cell(tmp_path, "purple", *PURPLE))
    cache, said = tmp_path / "cache", []
    trained = recogniser_for(model, cache, said.append, scenes=24)
    assert len(said) == 2 and "does not know this cell's kinds" in said[0]
    assert "purple_can" in said[0] and "cached in" in said[1]
    assert {"purple_can", "target"} <= set(trained.labels) and "red_can" not in trained.labels
    files = list(cache.iterdir())
    assert [f.name for f in files] == [f"recogniser-{signature(model, 24)[:20]}.json"]
    assert recogniser_for(model, cache, said.append, scenes=24) is trained  # this process's
    recognisers._MEMO.clear()  # as a new process: read from the cache, not trained
    again = recogniser_for(model, cache, said.append, scenes=24)
    assert len(said) == 2 and again.to_json() == trained.to_json()
    found = tried = 0
    for s in render_samples(model, 6, seed=900, sensors=("shelf_rgbd",)):
        truth = s.truth[s.target]
        if truth.label != "purple_can":
            continue
        tried += 1
        p = perceive(
            [s.observation],
            "purple_can",
            layout_bay(recognisers.CellLayout.from_model(model), s.slot),
            again,
        )
        if p.target is not None and np.linalg.norm(p.target.pose.position - truth.position) < 0.03:
            found += 1
    assert tried >= 2 and found == tried


def test_a_cache_that_cannot_be_written_costs_only_the_training(tmp_path: Path) -> None:
    model = model_at(_cell(tmp_path, "purple", *PURPLE))
    blocker = tmp_path / "a file"
    blocker.write_text("")
    said: list[str] = []
    trained = recogniser_for(model, blocker / "cache", said.append, scenes=8)
    assert "purple_can" in trained.labels
    assert said[-1].startswith("perception: trained in ") and "not cached (" in said[-1]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--cell", "nowhere.toml", "--out", "m.json"], "nowhere.toml"),
        (["--cell", "cell.xml", "--out", "m.json"], "give a cell file (.toml)"),
        (["--cell", "CELL", "--out", "m.json", "--scenes", "0"], "--scenes"),
        (["--cell", "CELL", "--out", "DIR"], "is a folder; give a file path"),
    ],
)
def test_train_recogniser_refuses_bad_input_in_one_line(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "cell.xml").write_text("<mujoco/>")
    argv = [str(CELLS / "cluttered.toml") if a == "CELL" else a for a in argv]
    argv = [str(tmp_path) if a == "DIR" else a for a in argv]
    argv = [
        str(tmp_path / a)
        if a.endswith((".json", ".xml")) or ("/" not in a and a.endswith(".toml"))
        else a
        for a in argv
    ]
    try:
        code = main(["train-recogniser", *argv])
    except SystemExit as exc:  # argparse's own usage errors
        code = exc.code  # type: ignore[assignment]
    assert code == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_train_recogniser_writes_what_run_would_train(tmp_path: Path) -> None:
    """The command's file is the recogniser ``recogniser_for`` trains for the cell, byte for
    byte (the same scenes, the same seed)."""
    path = _cell(tmp_path, "purple", *PURPLE)
    out = tmp_path / "m.json"
    assert main(["train-recogniser", "--cell", str(path), "--out", str(out), "--scenes", "8"]) == 0
    trained = recogniser_for(model_at(path), tmp_path / "cache", lambda _: None, scenes=8)
    assert out.read_text() == trained.to_json()
