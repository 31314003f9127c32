"""The viewer's picture in a real headless Chromium (software WebGL) against the offscreen render
of the same camera: as bright at either ``--quality``, and a plain (freely drawing) Chromium
shows the connected page, not a dark one."""

from __future__ import annotations

import io
import os
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from chromium import Chromium, ViewProcess, find_chromium, screenshot_command

from kr210_sim.jobs import snapshot_job
from kr210_sim.view.studio import FAST_OFF

import mujoco  # isort: skip

#: Page size [px]: the snapshot is rendered at the same size.
WIDTH, HEIGHT = 640, 400
#: Rows compared: below the demo panel (which ends above row 210 at this size) and above
#: Studio's status bar (the last 32 rows).
ROWS = slice(215, HEIGHT - 40)
#: Largest relative difference of mean luminance, viewer against offscreen render. Measured
#: 2026-12-06: 0.502 against 0.508 (1.2 %) at either quality; before the fix, fast was 0.135
#: (73 % darker).
BRIGHTNESS_TOL = 0.15


def _image(png: bytes) -> npt.NDArray[np.float64]:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(np.float64) / 255.0


def luminance(img: npt.NDArray[np.float64]) -> float:
    """Mean relative luminance (Rec. 709 weights of the sRGB values) [0-1]."""
    return float((img[..., :3] @ np.array([0.2126, 0.7152, 0.0722])).mean())


def connected(img: npt.NDArray[np.float64]) -> bool:
    """Studio's status bar shows its green dot ("Controlling"), not the grey one of
    "Connecting..." or "Downloading model"."""
    corner = img[HEIGHT - 32 :, :24] * 255
    r, g, b = corner[..., 0], corner[..., 1], corner[..., 2]
    return int(((g - r > 60) & (g - b > 60)).sum()) > 10


@pytest.fixture(scope="module")
def offscreen(tmp_path_factory: pytest.TempPathFactory) -> float:
    """Luminance of ``snapshot --camera overview`` (the camera the free camera starts on)."""
    out = tmp_path_factory.mktemp("snap") / "overview.png"
    snapshot_job(out, "overview", WIDTH, HEIGHT)
    return luminance(_image(out.read_bytes())[ROWS])


def _need_chromium() -> None:
    if find_chromium() is None:
        why = "no Chromium here (bash .ci/run installs chromium-headless-shell)"
        if os.environ.get("KR210_REQUIRE_CHROMIUM"):
            pytest.fail(why, pytrace=False)
        pytest.skip(why)


@pytest.fixture
def held_view(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[ViewProcess]:
    """``view --demo`` held before the first phase (the arm at rest in its ready pose, as the
    snapshot shows it), at ``--quality`` ``request.param``."""
    _need_chromium()
    view = ViewProcess(
        "--demo", "--cycles", "1", "--quality", request.param, "--report", str(tmp_path / "v")
    )
    try:
        view.wait_for("demo: next phase approach", 60)
        yield view
    finally:
        view.stop()


def test_fast_quality_keeps_the_tone_mapping() -> None:
    """Post-processing is Filament's tone mapping and output colour transform: without it the
    page shows linear light values, dark (what ``--quality fast`` did)."""
    assert mujoco.mjtRndFlag.mjRND_POST_PROCESSING not in FAST_OFF
    assert mujoco.mjtRndFlag.mjRND_SHADOW in FAST_OFF


@pytest.mark.slow
@pytest.mark.render
@pytest.mark.parametrize("held_view", ["full", "fast"], indirect=True)
def test_the_page_is_as_bright_as_the_offscreen_render(
    held_view: ViewProcess, offscreen: float
) -> None:
    with Chromium(width=WIDTH, height=HEIGHT, timeout=90, manual_frames=True) as browser:
        browser.open(held_view.url)
        held_view.wait_for("Browser connected", 60, tick=browser.frame)
        deadline = time.monotonic() + 60
        img = _image(browser.screenshot())
        while not connected(img):  # the model downloads, the UI session starts
            assert time.monotonic() < deadline, "the page never showed 'Controlling'"
            for _ in range(3):
                browser.frame()
            img = _image(browser.screenshot())
        for _ in range(5):  # the state arrives; the held pose is drawn
            browser.frame()
        img = _image(browser.screenshot())
    page = luminance(img[ROWS])
    assert img[ROWS].std() > 0.05  # a scene, not a blank page
    assert abs(page - offscreen) <= BRIGHTNESS_TOL * offscreen, (page, offscreen)


@pytest.mark.slow
@pytest.mark.render
@pytest.mark.parametrize("held_view", ["fast"], indirect=True)
def test_a_plain_headless_chromium_shows_the_connected_page_bright(
    held_view: ViewProcess, offscreen: float
) -> None:
    """A Chromium that draws on its own (no begin-frame control, as a user's script drives
    it): ``Page.captureScreenshot`` until the page says "Controlling", then that picture is as
    bright as the offscreen render (before the fix: the dark page a new user took for a page
    dimmed while connecting)."""
    with Chromium(width=WIDTH, height=HEIGHT, timeout=120) as browser:
        browser.open(held_view.url)
        held_view.wait_for("Browser connected", 60)
        deadline = time.monotonic() + 150
        while True:
            img = _image(browser.screenshot())
            if connected(img):
                break
            assert time.monotonic() < deadline, "the page never showed 'Controlling'"
            time.sleep(1.0)
        time.sleep(2.0)  # the render settings reach the page after it connects
        img = _image(browser.screenshot())
    page = luminance(img[ROWS])
    assert abs(page - offscreen) <= BRIGHTNESS_TOL * offscreen, (page, offscreen)


@pytest.mark.slow
@pytest.mark.render
@pytest.mark.parametrize("held_view", ["fast"], indirect=True)
def test_the_screenshot_command_of_the_docs_shows_the_connected_page(
    held_view: ViewProcess, offscreen: float, tmp_path: Path
) -> None:
    """``chromium --headless --screenshot --virtual-time-budget=... --run-all-compositor-stages-
    before-draw URL`` (docs/how-to/viewer.md): the page connected ("Controlling", the panel
    drawn) and as bright as the offscreen render (before the fix: 0.135 against 0.508)."""
    out = tmp_path / "page.png"
    profile = tmp_path / "profile"
    cmd = screenshot_command(held_view.url, out, WIDTH, HEIGHT)
    cmd.insert(-1, f"--user-data-dir={profile}")
    subprocess.run(cmd, check=True, capture_output=True, timeout=120)
    img = _image(out.read_bytes())
    assert img.shape[:2] == (HEIGHT, WIDTH)
    assert connected(img), "the page is still 'Connecting...'"
    page = luminance(img[ROWS])
    assert abs(page - offscreen) <= BRIGHTNESS_TOL * offscreen, (page, offscreen)
