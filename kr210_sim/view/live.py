"""The ``view`` command's live side: watch the cycles in MuJoCo Studio, or pose the arm.

Task mode (:func:`kr210_sim.jobs.view_job`) runs the cycles through the loop ``run`` uses
(:func:`kr210_sim.sim.session.run_session`), so the report equals that of ``run`` with the same
options apart from the ``wall_*`` fields. Watching adds two hooks that never touch the physics:

- :class:`Pacer`, a step hook that publishes the state to the viewer about ``fps`` times a wall
  second and sleeps so simulated time runs at ``speed`` times real time;
- :class:`DemoGate`, the runner's ``on_phase`` callback: in demo mode it holds the simulation
  before every phase of the cycle plan (:class:`kr210_sim.plan.cycle.CyclePlan`: approach,
  grasp, lift, retreat, carry, release, return) until Next.

Joint mode (:func:`run_joints`) has no task: the arm takes the pose of the panel's six sliders
and the panel shows the gripper pose from the robot's forward kinematics
(:class:`~kr210_sim.robot.kinematics.Kinematics`) and how many inverse-kinematics solutions that
pose has.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError
from kr210_sim.media.video import overlay_lines
from kr210_sim.robot.kinematics import Kinematics
from kr210_sim.sim.cell import Cell
from kr210_sim.sim.runner import Runner
from kr210_sim.view.studio import LiveViewer, ViewerClosed, ViewerSettings

FloatArray = npt.NDArray[np.float64]

#: Viewer updates per wall second.
DEFAULT_FPS = 60.0
#: Falling further behind real time than this [s] resets the pace instead of racing to catch up.
MAX_LAG = 0.25
#: Refresh period of the viewer while waiting (demo, finished run, joint mode) [s].
IDLE_PERIOD = 1.0 / 30.0


@dataclass(frozen=True, slots=True)
class LiveSettings:
    """Pace of a live run.

    Attributes:
        speed: Simulated seconds per wall second (1 = real time).
        fps: Viewer updates per wall second.
        exit_when_done: Return when the cycles are done instead of showing the final state
            until Ctrl-C.
    """

    speed: float = 1.0
    fps: float = DEFAULT_FPS
    exit_when_done: bool = False

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed) and self.speed > 0):
            raise ConfigError(f"speed must be a positive number, got {self.speed!r}")
        if not (math.isfinite(self.fps) and self.fps > 0):
            raise ConfigError(f"fps must be a positive number, got {self.fps!r}")


class Pacer:
    """Step hook: publish to the viewer ``fps`` times a wall second, hold ``speed`` x real time.

    Called after every physics step; between frames it returns at once (one comparison), so
    the physics runs at full speed in bursts and sleeps the rest of each frame.

    Args:
        publish: Shows the current state (called once a frame).
        speed: Simulated seconds per wall second.
        fps: Frames per wall second.
        clock: Wall clock [s].
        sleep: Sleeps for [s].
    """

    def __init__(
        self,
        publish: Callable[[Cell], None],
        speed: float,
        fps: float = DEFAULT_FPS,
        clock: Callable[[], float] = time.perf_counter,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.publish = publish
        self.speed = float(speed)
        self.frame_sim = self.speed / float(fps)
        self.clock, self.sleep = clock, sleep
        self._next = -math.inf
        self._sim0: float | None = None
        self._wall0 = self._last_sim = self._last_wall = 0.0
        self.sim_paced = 0.0  # simulated time run under the pace [s]
        self.wall_paced = 0.0  # wall time it took [s]
        self.frames = 0

    def restart(self) -> None:
        """Forget the pace (after a pause): the next step starts a new real-time reference."""
        self._close_span()
        self._next = -math.inf

    def _close_span(self) -> None:
        """Add the span from the reference frame to the last frame to the paced totals."""
        if self._sim0 is not None:
            self.sim_paced += self._last_sim - self._sim0
            self.wall_paced += self._last_wall - self._wall0
        self._sim0 = None

    def __call__(self, cell: Cell) -> None:
        t = cell.data.time
        if t < self._next:
            return
        self._next = t + self.frame_sim
        self.publish(cell)
        self.frames += 1
        now = self.clock()
        if self._sim0 is None:
            self._sim0 = self._last_sim = t
            self._wall0 = self._last_wall = now
            return
        delay = self._wall0 + (t - self._sim0) / self.speed - now
        if delay > 0:
            self.sleep(delay)
        self._last_sim, self._last_wall = t, self.clock()
        if delay < -MAX_LAG:  # too slow for this speed: keep going from here, do not race
            self._close_span()
            self._sim0, self._wall0 = t, self._last_wall

    def finish(self) -> None:
        """Close the current span (before a pause or at the end; for :attr:`real_time_factor`)."""
        self._close_span()

    @property
    def real_time_factor(self) -> float:
        """Simulated over wall time while paced (pauses excluded)."""
        return self.sim_paced / self.wall_paced if self.wall_paced > 0 else 0.0


class DemoGate:
    """The runner's ``on_phase`` callback in demo mode: wait for Next before every phase.

    The runner calls it before every step of the cycle plan (not before the spawn and settle
    holds), so the phases are the plan's own. Consecutive segments of one phase (the
    joint-space and straight-line parts of the approach) pause once.

    Args:
        wait: Blocks until Next is pressed; called with the phase about to run.
    """

    def __init__(self, wait: Callable[[str], None]) -> None:
        self.wait = wait
        self.last = ""
        self.paused: list[str] = []

    def __call__(self, phase: str) -> None:
        previous, self.last = self.last, phase
        if phase != previous:
            self.paused.append(phase)
            self.wait(phase)


class ViewerSession:
    """One viewer plus the runner's status: what is shown, and waiting for Next (the demo
    gate's ``wait``)."""

    def __init__(self, viewer: LiveViewer, runner: Runner, out: TextIO) -> None:
        self.viewer, self.runner, self.out = viewer, runner, out
        self.pacer: Pacer | None = None

    def lines(self) -> list[str]:
        return overlay_lines(self.runner.status, self.runner.cell.time)

    def publish(self, cell: Cell, waiting: str = "") -> None:
        self.viewer.publish(cell.data, self.lines(), waiting=waiting)

    def wait_next(self, phase: str) -> None:
        """Hold the simulation (the viewer stays live) until the user presses Next."""
        cell, inbox = self.runner.cell, self.viewer.inbox
        if self.pacer is not None:
            self.pacer.finish()
        self.out.write(f"demo: next phase {phase}; press Next in the viewer (or the N key)\n")
        self.out.flush()
        self.publish(cell, waiting=phase)
        seen = inbox.next_presses
        while inbox.next_presses == seen:
            time.sleep(IDLE_PERIOD)
            self.publish(cell, waiting=phase)
        self.publish(cell)
        if self.pacer is not None:
            self.pacer.restart()


def start_up_box(url: str, tty: bool) -> str:
    """The box that says where the viewer is: one URL, a terminal hyperlink (OSC 8) around it
    only for a terminal (``tty``): in a log or a pipe the escapes would be noise."""
    plain = [f"viewer: {url}", "open it in a browser; Ctrl+C to quit"]
    link = f"\033]8;;{url}\033\\{url}\033]8;;\033\\" if tty else url
    shown = [f"viewer: {link}", plain[1]]
    width = max(len(line) for line in plain)
    rule = "+" + "-" * (width + 2) + "+"
    rows = [
        f"| {text}{' ' * (width - len(line))} |" for line, text in zip(plain, shown, strict=True)
    ]
    return "\n".join([rule, *rows, rule]) + "\n"


def _is_tty(out: TextIO) -> bool:
    try:
        return bool(out.isatty())
    except (AttributeError, ValueError):  # a closed or minimal stream: not a terminal
        return False


def announce(viewer: LiveViewer, settings: ViewerSettings, out: TextIO) -> None:
    """Say where the viewer is (its URL in :func:`start_up_box`, or a native window), warning
    when it is exposed."""
    if viewer.url:
        out.write(start_up_box(viewer.url, _is_tty(out)))
        if settings.exposed:
            sys.stderr.write(
                f"kr210_sim: warning: the viewer listens on {settings.host}: anyone who can "
                "reach this port can watch and control it (no authentication, no encryption)\n"
            )
    else:
        out.write("viewer: native window\n")
    out.flush()


def hold_open(refresh: Callable[[], None]) -> None:
    """Keep the viewer live until Ctrl-C or until it is closed."""
    try:
        while True:
            refresh()
            time.sleep(IDLE_PERIOD)
    except (KeyboardInterrupt, ViewerClosed):
        return


# -- joint mode ------------------------------------------------------------------------------
def rpy_deg(R: npt.ArrayLike) -> tuple[float, float, float]:
    """Roll, pitch, yaw [deg] of rotation ``R`` (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    m = np.asarray(R, dtype=np.float64)
    pitch = math.atan2(-m[2, 0], math.hypot(m[0, 0], m[1, 0]))
    roll = math.atan2(m[2, 1], m[2, 2])
    yaw = math.atan2(m[1, 0], m[0, 0])
    return math.degrees(roll), math.degrees(pitch), math.degrees(yaw)


def joint_readout(
    kin: Kinematics, q: npt.ArrayLike, T_measured: npt.ArrayLike | None = None
) -> list[str]:
    """The joint-mode panel text for joint positions ``q`` [rad].

    Args:
        kin: The kinematics of the arm shown.
        q: The six joint positions [rad].
        T_measured: gripper_link's pose in MuJoCo (4x4), shown as a cross-check, or None.

    Returns:
        The joint values [deg], the gripper position [m] and roll/pitch/yaw [deg] from forward
        kinematics, and the number of inverse-kinematics solutions inside the limits.
    """
    qa = np.asarray(q, dtype=np.float64)
    T = kin.forward(qa)
    n = int(np.sum(~np.isnan(kin.inverse(T)).any(axis=-1)))
    roll, pitch, yaw = rpy_deg(T[:3, :3])
    x, y, z = T[:3, 3]
    lines = [
        "joints [deg]: " + " ".join(f"{v:7.1f}" for v in np.degrees(qa)),
        f"gripper x {x:6.3f}  y {y:6.3f}  z {z:6.3f} m",
        f"roll {roll:7.1f}  pitch {pitch:7.1f}  yaw {yaw:7.1f} deg",
        f"IK solutions within the limits: {n}",
    ]
    if T_measured is not None:
        gap = float(np.linalg.norm(np.asarray(T_measured)[:3, 3] - T[:3, 3])) * 1000.0
        lines.append(f"MuJoCo's gripper_link is {gap:.2f} mm from it")
    return lines


class JointPose:
    """Joint mode's simulation side: pose the arm from the sliders and describe the pose.

    Args:
        viewer: The open viewer (its inbox holds the latest slider values).
        cell: The cell; only the arm's joint positions are set (kinematically, no task).
        kin: The kinematics of the arm (the panel's pose and IK solution count).
        q0: The starting pose [rad].
    """

    def __init__(self, viewer: LiveViewer, cell: Cell, kin: Kinematics, q0: npt.ArrayLike) -> None:
        self.viewer, self.cell, self.kin = viewer, cell, kin
        self.q = np.asarray(q0, dtype=np.float64).copy()
        self.cell.reset(self.q)
        self.lines = joint_readout(kin, self.q, self.cell.gripper_pose())

    def tick(self) -> None:
        """Take the sliders' latest values (if new) and show the pose."""
        q = self.viewer.inbox.q
        if q is not None and not np.array_equal(q, self.q):
            self.q = np.asarray(q, dtype=np.float64)
            self.cell.reset(self.q)
            self.lines = joint_readout(self.kin, self.q, self.cell.gripper_pose())
        self.viewer.publish(self.cell.data, self.lines, q=self.q)


def run_joints(
    settings: ViewerSettings,
    out: TextIO | None = None,
    scene: Path | None = None,
    cell_file: Path | None = None,
) -> None:
    """Joint mode: show the arm posed by the panel's sliders until Ctrl-C or the viewer closes,
    in the cell of ``scene`` or ``cell_file`` (default: the published one), starting from its
    ready pose (:func:`~kr210_sim.cell.layout.ready_pose`)."""
    from kr210_sim.cell.layout import ready_pose
    from kr210_sim.cell.load import model_for
    from kr210_sim.robot.description import load_robot

    out = out or sys.stdout
    robot = load_robot()
    cell = Cell(model_for(scene, cell_file))
    limits = (robot.q_lower.tolist(), robot.q_upper.tolist())
    viewer = LiveViewer(cell.model, settings, joint_limits=limits)
    try:
        pose = JointPose(viewer, cell, Kinematics(robot), ready_pose(cell.model))
        announce(viewer, settings, out)
        hold_open(pose.tick)
    finally:
        viewer.close()


# -- replay ----------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class ReplayViewResult:
    """What ``view --replay`` showed.

    Attributes:
        frames: Recorded frames published.
        real_time_factor: Simulated over wall time of the playback.
        interrupted: The interrupt (Ctrl-C, SIGTERM) or closed viewer that stopped it, or None.
    """

    frames: int
    real_time_factor: float
    interrupted: BaseException | None


def replay_view(
    recording: Any,
    model: Any,
    settings: ViewerSettings,
    live: LiveSettings,
    out: TextIO | None = None,
    on_ready: Callable[[LiveViewer], None] | None = None,
) -> ReplayViewResult:
    """Play a recording (:class:`kr210_sim.media.recording.Recording`, checked against ``model``) in
    the viewer at ``live.speed`` x real time: each recorded state is published as the live view
    publishes the simulated one, with the same panel text.

    Args:
        recording: The recording.
        model: The model it was made with.
        settings: Viewer settings (demo and joint modes do not apply).
        live: Speed, and whether to return at the end instead of holding the last frame.
        out: Where the URL goes (stdout).
        on_ready: Called with the open viewer before the first frame.

    Raises:
        ConfigError: A busy port, no display for ``--window``, an unknown camera.
    """
    import mujoco

    from kr210_sim.media.recording import apply_frame

    out = out or sys.stdout
    data = mujoco.MjData(model)
    viewer = LiveViewer(model, settings)
    geoms = recording.target_geoms
    times = recording.arrays["time"]
    shown = 0
    interrupted: BaseException | None = None
    try:
        announce(viewer, settings, out)
        if on_ready is not None:
            on_ready(viewer)
        wall0 = time.perf_counter()
        try:
            for i in range(recording.frames):
                apply_frame(model, data, recording.arrays["qpos"][i], geoms, recording.shapes_at(i))
                delay = wall0 + (times[i] - times[0]) / live.speed - time.perf_counter()
                if delay > 0:
                    time.sleep(delay)
                viewer.publish(data, recording.status(i).lines())
                shown += 1
        except (KeyboardInterrupt, ViewerClosed) as exc:
            interrupted = exc
        wall = time.perf_counter() - wall0
        rtf = float(times[shown - 1] - times[0]) / wall if shown > 1 and wall > 0 else 0.0
        if interrupted is None and not live.exit_when_done:
            out.write("replay done; the viewer stays open: Ctrl-C to quit\n")
            out.flush()
            last = recording.status(shown - 1).lines()
            hold_open(lambda: viewer.publish(data, last))
        return ReplayViewResult(shown, rtf, interrupted)
    finally:
        viewer.close()
