"""``perceive --out look.png``: one row of three panels per look, each the sensor's size; the
depth colour-mapped with missing pixels black; each cluster labelled on its object."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from kr210_sim.cli import main
from kr210_sim.media.look_panels import HEADER_PX, label_anchor, to_pixels, write_look_panels
from kr210_sim.sensors.glance import Glance, glance
from kr210_sim.util.paths import SCENES_DIR

CELL = SCENES_DIR / "cells" / "cluttered.toml"


@pytest.fixture(scope="module")
def drawn(tmp_path_factory: pytest.TempPathFactory) -> tuple[Glance, Any, np.ndarray]:
    """A randomised cluttered cycle's look (seed 7: three clusters in slot 9), drawn."""
    g = glance(CELL, seed=7, randomize=True)
    path = tmp_path_factory.mktemp("look") / "look.png"
    labels = write_look_panels(path, g.observations, g.percept, "test")
    return g, labels, np.asarray(Image.open(path).convert("RGB"))


def _panel(png: np.ndarray, g: Glance, row: int, col: int) -> np.ndarray:
    w, h = g.observations[0].intrinsics.width, g.observations[0].intrinsics.height
    top = row * (h + HEADER_PX) + HEADER_PX
    return png[top : top + h, col * w : (col + 1) * w].astype(int)


def test_each_look_is_a_row_of_three_panels_of_the_sensors_size(drawn: Any) -> None:
    g, _, png = drawn
    obs = g.observations[0]
    w, h = obs.intrinsics.width, obs.intrinsics.height
    assert png.shape == (len(g.observations) * (h + HEADER_PX), 3 * w, 3)
    rgb = _panel(png, g, 0, 0)
    assert np.abs(rgb - obs.rgb.astype(int)).mean() < 1.0  # the colour image, pixel for pixel
    depth = _panel(png, g, 0, 1)
    missing = obs.depth == 0
    assert missing.sum() > 100  # the D415 model drops pixels
    assert (depth[missing].max(axis=1) <= 8).mean() > 0.99  # missing: black
    valid = depth[~missing]
    assert (valid.max(axis=1) > 40).mean() > 0.99  # a colour for every measured depth
    assert np.abs(depth - rgb).mean() > 30  # colour-mapped, not the colour image again


def test_each_cluster_is_labelled_on_its_object(drawn: Any) -> None:
    g, labels, png = drawn
    for row, seen in enumerate(g.percept.looks):  # every look's clusters, in order
        assert [lab.detection for lab in labels if lab.look == row] == list(
            range(len(seen.detections))
        )
    picked = [lab for lab in labels if lab.text.endswith("[pick]")]
    assert len(picked) == 1 and picked[0].text.startswith(g.label)
    row = picked[0].look  # the look the pick was fitted from (the wrist camera's, when taken)
    obs, look = g.observations[row], g.percept.looks[row]
    # the pick's label stands on the target as the truth has it (its top, projected)
    truth = next(o for o in g.truth if o.body == g.target_body)
    top = truth.position + truth.R[:, 2] * truth.size[1] / 2.0
    (u, v) = to_pixels(obs, top)[0]
    assert np.hypot(picked[0].u - u, picked[0].v - v) < 15.0
    d = look.detections[picked[0].detection]
    assert np.allclose(to_pixels(obs, label_anchor(d))[0], (picked[0].u, picked[0].v))
    # the text is drawn there, just above the object: those pixels are not the dimmed image
    panel = _panel(png, g, row, 2)
    dimmed = (obs.rgb.astype(np.float32) * 0.35).astype(int)
    iu, iv = round(picked[0].u), round(picked[0].v)
    above = (slice(max(iv - 16, 0), iv - 4), slice(max(iu - 20, 0), iu + 20))
    assert np.abs(panel[above] - dimmed[above]).max(axis=2).mean() > 40
    # far from every cluster (the bottom-left corner) the panel is the dimmed image
    corner = (slice(h0 := obs.intrinsics.height - 60, h0 + 50), slice(10, 60))
    assert np.abs(panel[corner] - dimmed[corner]).max() <= 2


def test_a_look_is_scored_against_the_truth(drawn: Any) -> None:
    g, _, _ = drawn
    r = g.record
    assert r.label == g.label and r.looks == len(g.observations) >= 1
    assert r.seen and r.right_object and r.position_error_mm is not None
    assert r.clusters == tuple(len(look.detections) for look in g.percept.looks)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--out", "look.txt"], "perceive writes a PNG"),
        (["--slot", "12", "--out", "x.png"], "slot must be 0 (random) or 1-9"),
        (["--cell", "nowhere.toml", "--out", "x.png"], "nowhere.toml"),
    ],
)
def test_perceive_refuses_bad_input_in_one_line(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [a if not a.endswith((".png", ".txt")) else str(tmp_path / a) for a in argv]
    assert main(["perceive", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
