"""The live viewer: same physics as ``run``, real-time pace, demo mode, joint mode, and the page
in a real headless Chromium (software WebGL) showing the cell with the arm moving."""

from __future__ import annotations

import io
import json
import math
import multiprocessing
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from chromium import ViewProcess, free_port

from kr210_sim.cell.load import load_model
from kr210_sim.cli import main
from kr210_sim.jobs import run_job, view_job
from kr210_sim.media.video import overlay_lines
from kr210_sim.robot import kinematics
from kr210_sim.robot.description import load_robot
from kr210_sim.robot.kinematics import committed
from kr210_sim.score.report import strip_wall
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.runner import SPAWN_SETTLE, RunConfig, Runner
from kr210_sim.view.live import (
    DemoGate,
    JointPose,
    LiveSettings,
    Pacer,
    joint_readout,
    rpy_deg,
    start_up_box,
)
from kr210_sim.view.studio import FAST_OFF, LiveViewer, ViewerSettings, free_camera_pose

import mujoco  # isort: skip


def isolated(fn: Callable[..., None], *args: Any) -> None:
    """Run ``fn(*args)`` in a fresh interpreter and re-raise its failure here.

    MuJoCo Studio 4.0 runs one web viewer per process: a second one in the same process hangs
    for 5 s when it closes. Every test that opens a viewer therefore gets its own process.
    """
    ctx = multiprocessing.get_context("spawn")
    queue = ctx.Queue()
    child = ctx.Process(target=_child, args=(queue, fn, args))
    child.start()
    try:
        status, detail = queue.get(timeout=180)
    finally:
        child.join(30)
        if child.is_alive():
            child.kill()
            child.join(5)
    if status != "ok":
        pytest.fail(f"in the child process:\n{detail}", pytrace=False)


def _child(queue: Any, fn: Callable[..., None], args: tuple[Any, ...]) -> None:
    try:
        fn(*args)
        queue.put(("ok", ""))
    except BaseException:
        queue.put(("error", traceback.format_exc()))


# -- pieces ------------------------------------------------------------------------------------
def test_free_camera_sees_along_the_overview_camera() -> None:
    model = load_model()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "overview")
    lookat, dist, az, el = free_camera_pose(data.cam_xpos[cid], data.cam_xmat[cid])
    # MuJoCo's free camera looks along (cos el cos az, cos el sin az, sin el) from lookat - d f.
    a, e = math.radians(az), math.radians(el)
    f = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
    np.testing.assert_allclose(lookat - dist * f, data.cam_xpos[cid], atol=1e-9)
    np.testing.assert_allclose(f, -data.cam_xmat[cid].reshape(3, 3)[:, 2], atol=1e-12)
    assert lookat[2] == pytest.approx(1.0)
    assert -60 < el < -20 and dist > 2.0  # above the cell, outside the robot's base


def test_pacer_holds_the_speed_and_publishes_once_a_frame() -> None:
    cell = Cell(load_model())
    frames: list[float] = []
    pacer = Pacer(lambda c: frames.append(c.time), speed=2.0, fps=30.0)
    cell.hooks.append(pacer)
    wall0 = time.perf_counter()
    while cell.time < 0.6:
        mujoco.mj_step(cell.model, cell.data)
        pacer(cell)
    pacer.finish()
    wall = time.perf_counter() - wall0
    assert wall >= 0.6 / 2.0 - 2 * (2.0 / 30.0)  # never ahead of speed x real time
    # One frame every speed/fps = 1/15 s of simulated time, on the first step at or past it.
    assert len(frames) == math.ceil(0.6 * 15) or len(frames) == math.ceil(0.6 * 15) + 1
    assert np.all(np.diff(frames) >= 1 / 15 - 1e-9)
    assert 0.5 < pacer.real_time_factor <= 2.0 + 1e-9


def test_demo_gate_pauses_once_before_every_phase_of_a_cycle() -> None:
    runner = Runner(RunConfig(cycles=1, seed=0))
    waited: list[tuple[str, float]] = []
    shown: list[str] = []  # the panel's phase line while the gate waits

    def wait(phase: str) -> None:
        waited.append((phase, runner.cell.time))
        shown.append(overlay_lines(runner.status, runner.cell.time)[1])

    gate = DemoGate(wait)
    runner.on_phase = gate
    runner.run_cycle(1, runner.slot_for_cycle())
    assert runner.plan is not None  # the phases are the cycle plan's, in its order
    phases = ("approach", "grasp", "lift", "retreat", "carry", "release", "return")
    assert runner.plan.phases == phases
    assert [p for p, _ in waited] == list(runner.plan.phases) == gate.paused
    labels = ["approach", "grasp", "lift", "lift", "carry", "release", "return"]
    assert shown == [f"phase: {label}" for label in labels]
    # Before each phase runs: the first pause comes right after the 0.1 s spawn settle, and
    # every phase takes simulated time after its pause.
    times = [t for _, t in waited]
    assert times[0] == pytest.approx(SPAWN_SETTLE, abs=0.003)
    assert np.all(np.diff(times) > 0.05)
    assert runner.results[0].success


def test_rpy_round_trip_and_joint_readout_counts_ik_solutions() -> None:
    rng = np.random.default_rng(4)
    for roll, pitch, yaw in rng.uniform([-3, -1.5, -3], [3, 1.5, 3], size=(200, 3)):
        cr, sr, cp, sp, cy, sy = (
            math.cos(roll),
            math.sin(roll),
            math.cos(pitch),
            math.sin(pitch),
            math.cos(yaw),
            math.sin(yaw),
        )
        Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
        Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
        Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
        np.testing.assert_allclose(rpy_deg(Rz @ Ry @ Rx), np.degrees([roll, pitch, yaw]), atol=1e-9)
    q = np.array([0.8, -0.2, 0.2, 0.0, 0.0, 0.0])
    lines = joint_readout(committed(), q)
    T = kinematics.forward(q)
    assert f"x {T[0, 3]:6.3f}" in lines[1] and f"z {T[2, 3]:6.3f}" in lines[1]
    n = len(kinematics.inverse(T))
    assert 1 <= n <= 8 and lines[3] == f"IK solutions within the limits: {n}"


# -- the viewer with the run's physics -----------------------------------------------------------
class _Presser:
    """Presses Next in the viewer's panel every ``period`` s (as a user clicking would)."""

    def __init__(self, period: float = 0.05) -> None:
        self.period = period
        self.stop = threading.Event()
        self.thread: threading.Thread | None = None

    def start(self, viewer: LiveViewer) -> None:
        def loop() -> None:
            while not self.stop.wait(self.period):
                viewer.panel.press_next()

        self.thread = threading.Thread(target=loop, daemon=True)
        self.thread.start()


def _view_matches_run(tmp: str, demo: bool) -> None:
    tmp_path = Path(tmp)
    config = RunConfig(cycles=2 if not demo else 1, seed=3)
    ran = run_job(config, tmp_path / "run.json", out=io.StringIO())
    presser = _Presser()
    out = io.StringIO()
    settings = ViewerSettings(port=free_port(), demo=demo)
    try:
        viewed = view_job(
            config,
            tmp_path / "view.json",
            settings,
            LiveSettings(speed=20.0, exit_when_done=True),
            out=out,
            on_ready=presser.start if demo else None,
        )
    finally:
        presser.stop.set()
    assert strip_wall(viewed.report) == strip_wall(ran.report)
    assert viewed.frames > 10 * config.cycles and not viewed.interrupted
    phases = ["approach", "grasp", "lift", "retreat", "carry", "release", "return"]
    assert viewed.paused == (phases if demo else [])
    assert out.getvalue().count("demo: next phase") == (7 if demo else 0)


@pytest.mark.slow
@pytest.mark.parametrize("demo", [False, True])
def test_view_writes_the_report_of_run(tmp_path: Path, demo: bool) -> None:
    isolated(_view_matches_run, str(tmp_path), demo)


def _joint_mode() -> None:
    robot = load_robot()
    cell = Cell(load_model())
    limits = (robot.q_lower.tolist(), robot.q_upper.tolist())
    settings = ViewerSettings(port=free_port(), joints=True, quality="fast")
    viewer = LiveViewer(cell.model, settings, limits)
    try:
        pose = JointPose(viewer, cell, committed(), [0.8, -0.2, 0.2, 0.0, 0.0, 0.0])
        q = np.array([0.3, 0.25, -0.4, 1.0, -0.6, 2.0])
        viewer.panel.set_joints(q)  # what moving the sliders sends
        deadline = time.monotonic() + 10.0
        while not np.allclose(cell.q, q) and time.monotonic() < deadline:
            pose.tick()
            time.sleep(0.01)
        np.testing.assert_allclose(cell.q, q)
        T = kinematics.forward(q)
        assert np.linalg.norm(cell.gripper_pose()[:3, 3] - T[:3, 3]) < 1e-3
        assert pose.lines == joint_readout(committed(), q, cell.gripper_pose())
        assert pose.lines[-1] == "MuJoCo's gripper_link is 0.00 mm from it"

        # --quality fast: the viewer draws without shadows, reflections and haze, but keeps the
        # post-processing (the tone mapping: without it the page is 4x darker); the flags are
        # set when Studio posts the model, on its own thread: under load that can come late.
        def fast_flags() -> list[int]:
            flags = viewer.panel.viewer.render_flags.flags
            return [int(flags[int(f)]) for f in FAST_OFF]

        deadline = time.monotonic() + 20.0
        while any(fast_flags()) and time.monotonic() < deadline:
            pose.tick()
            time.sleep(0.05)
        assert fast_flags() == [0] * len(FAST_OFF) == [0, 0, 0]
        post = int(mujoco.mjtRndFlag.mjRND_POST_PROCESSING)
        assert viewer.panel.viewer.render_flags.flags[post] == 1
        assert viewer.panel.camera == "free" and viewer.panel.viewer.camera.distance > 2.0
    finally:
        viewer.close()


def test_joint_mode_poses_the_arm_from_the_sliders() -> None:
    isolated(_joint_mode)


@pytest.mark.slow
def test_ctrl_c_writes_the_cycles_done_and_exits_130(tmp_path: Path) -> None:
    report = tmp_path / "view.json"
    view = ViewProcess("--cycles", "5", "--speed", "4", "--exit-when-done", "--report", str(report))
    try:
        view.wait_for("[1/5]", 60)
        view.proc.send_signal(signal.SIGINT)
        assert view.proc.wait(20) == 130
    finally:
        view.stop()
    data = json.loads(report.read_text())
    assert data["interrupted"] is True and 1 <= len(data["cycles"]) < 5
    assert data["summary"]["cycles"] == len(data["cycles"])


# -- command-line errors --------------------------------------------------------------------------
def test_window_without_display_names_web(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", "--window", "--cycles", "1"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--web" in err and "display" in err


def test_busy_port_is_one_line(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        code = main(["view", "--web", "--port", str(port), "--report", str(tmp_path / "v.json")])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"kr210_sim: error: cannot serve the viewer on 127.0.0.1:{port}")
    assert len(err.strip().splitlines()) == 1


def test_unknown_camera_lists_the_cameras(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["view", "--web", "--camera", "ceiling", "--cycles", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "kr210_sim: error: no camera 'ceiling'; cameras: overview, shelf, bin, hero, shelf_rgbd, "
        "gripper"
    ), err


def test_start_up_box_has_one_url_and_hyperlink_escapes_only_for_a_terminal() -> None:
    url = "http://127.0.0.1:8080/"
    logged = start_up_box(url, tty=False)
    assert logged == (
        "+--------------------------------------+\n"
        "| viewer: http://127.0.0.1:8080/       |\n"
        "| open it in a browser; Ctrl+C to quit |\n"
        "+--------------------------------------+\n"
    )
    shown = start_up_box(url, tty=True)
    assert "\033" not in logged and shown.count("\033]8;;") == 2  # OSC 8: open and close
    # Without its escapes the terminal's box is the logged one: the borders still line up.
    assert re.sub(r"\033\]8;;[^\033]*\033\\", "", shown) == logged


def test_view_into_a_pipe_writes_one_url_and_no_escapes(tmp_path: Path) -> None:
    """Captured (not a terminal), ``view``'s output holds the viewer's URL once and no terminal
    escape (Studio's own banner gave a second URL in OSC 8 hyperlinks)."""
    port = free_port()
    argv = ["view", "--web", "--port", str(port), "--cycles", "1", "--exit-when-done"]
    proc = subprocess.run(
        [sys.executable, "-m", "kr210_sim", *argv, "--speed", "50", "--report",
         str(tmp_path / "view.json")],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "\033" not in proc.stdout + proc.stderr
    assert re.findall(r"https?://\S+", proc.stdout) == [f"http://127.0.0.1:{port}/"]


def test_only_loopback_is_private() -> None:
    assert not ViewerSettings().exposed
    assert ViewerSettings(host="0.0.0.0").exposed
    assert not ViewerSettings(mode="window", host="0.0.0.0").exposed


# -- in a real browser -----------------------------------------------------------------------------
def orange_mask(img: npt.NDArray[np.int_]) -> npt.NDArray[np.bool_]:
    """KUKA orange (the arm's links): strong red, half green, little blue."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (r > 170) & (g > 50) & (g < 150) & (b < 70) & (r - g > 80)


def shelf_mask(img: npt.NDArray[np.int_]) -> npt.NDArray[np.bool_]:
    """The racking's navy uprights, lit or in shade (the lit targets are a brighter blue)."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (b - r > 50) & (b < 170) & (r < 70) & (g < 110)


def decode(png: bytes) -> npt.NDArray[np.int_]:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    from chromium import Chromium, find_chromium

    if find_chromium() is None:
        why = "no Chromium here (bash .ci/run installs chromium-headless-shell)"
        if os.environ.get("KR210_REQUIRE_CHROMIUM"):
            pytest.fail(why, pytrace=False)
        pytest.skip(why)
    with Chromium(width=640, height=400, timeout=60, manual_frames=True) as c:
        yield c


@pytest.fixture
def view_process(request: pytest.FixtureRequest) -> Iterator[Callable[..., ViewProcess]]:
    started: list[ViewProcess] = []

    def start(*args: str) -> ViewProcess:
        p = ViewProcess(*args)
        started.append(p)
        return p

    yield start
    for p in started:
        p.stop()


@pytest.mark.slow
def test_browser_shows_the_whole_cell_with_the_arm_moving(
    browser: Any, view_process: Callable[..., ViewProcess], tmp_path: Path
) -> None:
    view = view_process("--cycles", "10", "--report", str(tmp_path / "v.json"))
    view.wait_for("viewer: ", 30)
    browser.open(view.url)
    view.wait_for("Browser connected", 30, tick=browser.frame)
    for _ in range(3):  # the model and the first state arrive
        browser.frame()
    first = decode(browser.screenshot())
    time.sleep(2.5)
    second = decode(browser.screenshot())
    for img in (first, second):
        orange, shelf = orange_mask(img).mean(), shelf_mask(img).mean()
        assert img.std() > 20  # not blank
        assert 0.005 < orange < 0.3, orange  # the arm, seen from outside its base
        assert shelf > 0.02, shelf  # 0.054 in a 640 x 480 still from the overview camera
    a, b = orange_mask(first), orange_mask(second)
    assert (a ^ b).sum() > 0.1 * min(a.sum(), b.sum())  # the arm moved


@pytest.mark.slow
def test_browser_demo_waits_for_next_then_goes_on(
    browser: Any, view_process: Callable[..., ViewProcess], tmp_path: Path
) -> None:
    view = view_process("--demo", "--speed", "4", "--cycles", "1", "--report", str(tmp_path / "d"))
    view.wait_for("demo: next phase approach", 30)
    browser.open(view.url)
    view.wait_for("Browser connected", 30, tick=browser.frame)
    t_end = time.monotonic() + 1.5
    while time.monotonic() < t_end:  # it waits: nothing runs without Next
        browser.frame()
    assert view.count("demo: next phase") == 1 and not view.count("[1/1]")
    for _attempt in range(3):  # the first key may arrive before the page's UI is connected
        browser.press("n")
        try:
            view.wait_for("demo: next phase grasp", 6, tick=browser.frame)
            break
        except AssertionError:
            continue
    view.wait_for("demo: next phase grasp", 1)
    assert view.count("demo: next phase") == 2  # one phase per Next


def test_view_replay_plays_a_recording_at_the_asked_speed(tmp_path: Path) -> None:
    from kr210_sim.media.recording import read_recording
    from kr210_sim.view.live import replay_view

    run_job(RunConfig(cycles=1, seed=3), tmp_path / "r.json", record=tmp_path / "r.npz")
    rec = read_recording(tmp_path / "r.npz")
    model = load_model()
    opened: list[LiveViewer] = []
    out = io.StringIO()
    result = replay_view(
        rec,
        model,
        ViewerSettings(port=free_port(), quality="fast"),
        LiveSettings(speed=10.0, exit_when_done=True),
        out=out,
        on_ready=opened.append,
    )
    assert result.interrupted is None and result.frames == rec.frames
    assert opened[0].syncs == rec.frames  # every recorded state went through publish
    assert out.getvalue().splitlines()[1].startswith("| viewer: http://127.0.0.1:")
    assert 5.0 < result.real_time_factor < 10.5  # paced: never faster than asked
    # The viewer's copy holds the last recorded positions.
    assert np.array_equal(opened[0].shadow_data.qpos, rec.arrays["qpos"][-1])
