"""MuJoCo Studio glue: open the live viewer (browser or window) and stream the cell to it.

The viewer is MuJoCo Studio (``mujoco.studio``, shipped with mujoco 4): a viewer thread in this
process renders (natively) or serves the page, its WebAssembly client and the model on one port
(web). The simulation thread pushes state with ``ViewerHandle.sync``. This module adds:

- :class:`LiveViewer`: opens the viewer and publishes the cell's state. It syncs a *shadow* copy
  of the model and data, so nothing the viewer sends back (a reset, a dragged body, a physics
  option) can reach the simulated cell: watching never changes the physics.
- :class:`Panel`: a viewer-side plugin drawing the panel: the overlay lines of the video (cycle,
  slot, phase, score, simulated time), the Next button of demo mode (key N), the camera choice and,
  in joint mode, six joint sliders.
- :class:`Inbox`: the sim-side plugin receiving the panel's Next presses and joint values.

Studio binds its web port on all interfaces; :class:`_WebViewer` binds the host asked for
(loopback by default), because the viewer has no authentication.
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import math
import os
import sys
import threading
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from kr210_sim.errors import ConfigError, Kr210SimError

import mujoco  # isort: skip

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: Camera choice meaning "orbit freely, starting where the overview camera looks".
FREE_CAMERA = "free"
#: The named camera the free camera starts from.
HOME_CAMERA = "overview"
#: Height of the point the free camera orbits around, on the home camera's line of sight [m].
ORBIT_HEIGHT = 1.0
#: Seconds to wait for the viewer thread to bind its port.
START_TIMEOUT = 20.0
#: Loopback addresses (anything else exposes the viewer to the network).
LOOPBACK = frozenset({"127.0.0.1", "localhost", "::1"})
#: Render effects ``quality="fast"`` turns off (they cost most in software WebGL). Never
#: ``mjRND_POST_PROCESSING``: in Studio's Filament renderer it is the tone mapping and the output
#: colour transform, without which the page shows linear light values (mean luminance 0.13
#: against the offscreen render's 0.51 from the overview camera) at no measurable frame rate gain.
FAST_OFF = (
    mujoco.mjtRndFlag.mjRND_SHADOW,
    mujoco.mjtRndFlag.mjRND_REFLECTION,
    mujoco.mjtRndFlag.mjRND_HAZE,
)
#: State the viewer needs to draw the cell (positions, velocities, controls, time).
_STATE = int(mujoco.mjtState.mjSTATE_INTEGRATION)


class ViewerClosed(Kr210SimError):
    """The viewer window was closed (or its thread died) while the cycles ran."""


def has_display() -> bool:
    """Whether a desktop display is available for a native window."""
    if sys.platform.startswith("linux"):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


def _check_host(host: str) -> None:
    """Refuse a ``--host`` that is no address (``256.1.1.1`` was reported as a busy port).

    Raises:
        ConfigError: When ``host`` is neither an IP address nor a name that resolves.
    """
    import ipaddress
    import re
    import socket

    if re.fullmatch(r"[\d.]+|[\da-fA-F:]*:[\da-fA-F:.]*", host):
        try:
            ipaddress.ip_address(host)
        except ValueError:
            raise ConfigError(f"--host {host}: not an IP address (e.g. 127.0.0.1)") from None
        return
    try:
        socket.getaddrinfo(host, None, type=socket.SOCK_STREAM)
    except (OSError, UnicodeError) as exc:
        raise ConfigError(f"--host {host}: no such host here ({exc})") from None


@dataclasses.dataclass(frozen=True, slots=True)
class ViewerSettings:
    """How to show the cell.

    Attributes:
        mode: ``"web"`` (MuJoCo Studio's web viewer; no display or GPU needed) or ``"window"``
            (Studio's native window; needs a display).
        host: Interface the web viewer listens on (loopback by default).
        port: Web viewer port; 0 takes the first free port from 8080.
        camera: ``"free"`` (orbit, starting on the overview camera's view) or a named camera.
        demo: Show the Next button and pause before every phase.
        joints: Joint mode: six joint sliders instead of a task.
        quality: ``"full"`` (Studio's shadows, reflections and haze) or ``"fast"`` (none of
            them: for browsers without a GPU, which render in software). Both keep Studio's
            post-processing: its tone mapping and output colour transform make the picture as
            bright as the offscreen render (without them it shows linear values, 4x darker).
        width: Window width [px] (native window).
        height: Window height [px] (native window).
    """

    mode: str = "web"
    host: str = "127.0.0.1"
    port: int = 0
    camera: str = FREE_CAMERA
    demo: bool = False
    joints: bool = False
    quality: str = "full"
    width: int = 1280
    height: int = 800

    def __post_init__(self) -> None:
        if self.mode not in ("web", "window"):
            raise ConfigError(f"viewer mode must be 'web' or 'window', got {self.mode!r}")
        if not 0 <= self.port <= 65535:
            raise ConfigError(f"port must be 0-65535, got {self.port}")
        if self.quality not in ("full", "fast"):
            raise ConfigError(f"quality must be 'full' or 'fast', got {self.quality!r}")
        if not self.host:
            raise ConfigError("host must not be empty (127.0.0.1 for this machine only)")
        _check_host(self.host)

    @property
    def exposed(self) -> bool:
        """True when the web viewer is reachable from other machines."""
        return self.mode == "web" and self.host not in LOOPBACK


# -- messages between the simulation and the viewer ----------------------------------------
def _studio() -> Any:
    """Import MuJoCo Studio, or fail with one line saying what to install."""
    try:
        from mujoco.studio import messages  # noqa: F401
    except ImportError as exc:
        raise ConfigError(
            f"the live viewer needs MuJoCo Studio (mujoco >= 4.0): pip install 'mujoco>=4' ({exc})"
        ) from exc
    import mujoco.studio

    return mujoco.studio


_studio()
from mujoco.studio import messages, plugin  # noqa: E402  (after the one-line import check)


@dataclasses.dataclass(frozen=True)
class StatusSnapshot(messages.Snapshot):
    """What the panel shows (sim -> viewer, latest wins).

    Attributes:
        lines: Text lines (cycle n/N, slot, phase, score, simulated time, or the joint readout).
        waiting: The phase demo mode waits to run ("" when not waiting).
        q: The arm's joint positions [rad] (joint mode sets its sliders from them once).
    """

    lines: tuple[str, ...] = ()
    waiting: str = ""
    q: tuple[float, ...] = ()


@dataclasses.dataclass(frozen=True)
class NextEvent(messages.Event):
    """The user pressed Next (viewer -> sim, never dropped)."""


@dataclasses.dataclass(frozen=True)
class JointsSnapshot(messages.Snapshot):
    """Joint slider values [rad] (viewer -> sim, latest wins)."""

    q: tuple[float, ...] = ()


class Inbox(plugin.SimPlugin):
    """Sim-side receiver of the panel's input; read by the simulation thread."""

    def __init__(self) -> None:
        self.next_presses = 0
        self.q: tuple[float, ...] | None = None

    @messages.handler
    def _on_next(self, event: NextEvent) -> bool:
        del event
        self.next_presses += 1
        return True

    @messages.handler
    def _on_joints(self, snapshot: JointsSnapshot) -> bool:
        self.q = snapshot.q
        return True


def free_camera_pose(
    cam_pos: npt.ArrayLike, cam_mat: npt.ArrayLike, orbit_height: float = ORBIT_HEIGHT
) -> tuple[FloatArray, float, float, float]:
    """A free camera that sees what a fixed camera sees.

    Args:
        cam_pos: Camera position in the world [m].
        cam_mat: Camera orientation (3x3 or 9 values; MuJoCo cameras look along their -z).
        orbit_height: Height of the orbit point on the line of sight [m].

    Returns:
        lookat [m], distance [m], azimuth [deg], elevation [deg] for ``MjvCamera``.
    """
    p = np.asarray(cam_pos, dtype=np.float64)
    forward = -np.asarray(cam_mat, dtype=np.float64).reshape(3, 3)[:, 2]
    if forward[2] > -1e-6:
        raise ConfigError("the camera does not look down; cannot orbit around the cell from it")
    distance = float((orbit_height - p[2]) / forward[2])
    lookat = p + distance * forward
    azimuth = math.degrees(math.atan2(forward[1], forward[0]))
    elevation = math.degrees(math.asin(float(np.clip(forward[2], -1.0, 1.0))))
    return lookat, distance, azimuth, elevation


class Panel(plugin.ViewerPlugin):
    """The viewer-side panel (runs on the viewer thread).

    Args:
        camera: The camera to start on (``"free"`` or a named camera).
        demo: Show the Next button (and its key, N).
        joint_limits: (lower, upper) joint limits [rad] for the sliders in joint mode, else None.
        fast: Turn off the costly render effects (:data:`FAST_OFF`).
    """

    def __init__(
        self,
        camera: str = FREE_CAMERA,
        demo: bool = False,
        joint_limits: tuple[Sequence[float], Sequence[float]] | None = None,
        fast: bool = False,
    ) -> None:
        self.fast = fast
        self.camera = camera
        self.demo = demo
        self.joint_limits = joint_limits
        self.status = StatusSnapshot()
        self.q: list[float] | None = None
        self.frames = 0

    # -- input, callable from any thread ------------------------------------------------
    def press_next(self) -> None:
        """What the Next button and the N key do."""
        self.viewer.send_to_sim(NextEvent())

    def set_joints(self, q: Sequence[float]) -> None:
        """What moving a joint slider does."""
        self.q = [float(v) for v in q]
        self.viewer.send_to_sim(JointsSnapshot(q=tuple(self.q)))

    # -- camera -------------------------------------------------------------------------
    def camera_names(self) -> list[str]:
        """The choices: free, then the model's named cameras."""
        m = self.viewer.model
        return [FREE_CAMERA] + [m.camera(i).name for i in range(m.ncam)]

    def aim(self, name: str) -> None:
        """Put the viewer's camera on ``name`` (``"free"``: orbit from the home camera)."""
        from mujoco.studio import ux

        m, d, cam = self.viewer.model, self.viewer.data, self.viewer.camera
        if name == FREE_CAMERA:
            home = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, HOME_CAMERA)
            self.viewer.camera_index = ux.set_camera(m, cam, ux.TUMBLE_CAMERA_IDX)
            if home >= 0:
                lookat, dist, az, el = free_camera_pose(d.cam_xpos[home], d.cam_xmat[home])
                cam.type = int(mujoco.mjtCamera.mjCAMERA_FREE)
                cam.lookat[:] = lookat
                cam.distance, cam.azimuth, cam.elevation = dist, az, el
        else:
            cid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, name)
            if cid >= 0:
                self.viewer.camera_index = ux.set_camera(m, cam, cid)
        self.camera = name

    @messages.handler
    def _on_post_model(self, event: messages.PostModelEvent) -> None:
        del event
        self.aim(self.camera)
        if self.fast:
            flags = self.viewer.render_flags.flags
            for flag in FAST_OFF:
                flags[int(flag)] = 0
            self.viewer.render_flags.flags = flags

    # -- state from the simulation ------------------------------------------------------
    @messages.handler
    def _on_status(self, snapshot: StatusSnapshot) -> None:
        self.status = snapshot
        if self.q is None and snapshot.q:
            self.q = list(snapshot.q)

    # -- the panel ----------------------------------------------------------------------
    @messages.handler
    def _on_build_gui(self, event: messages.BuildGuiEvent) -> None:
        del event
        from mujoco.studio.dear_imgui import dear_imgui as imgui

        self.frames += 1
        imgui.SetNextWindowPos(imgui.Vec2(12, 12), int(imgui.Cond.FirstUseEver))
        flags = int(imgui.WindowFlags.AlwaysAutoResize) | int(imgui.WindowFlags.NoCollapse)
        imgui.Begin("kr210_sim", None, flags)
        for line in self.status.lines:
            imgui.TextUnformatted(line)
        if self.demo:
            imgui.Separator()
            waiting = self.status.waiting
            if waiting:
                imgui.TextUnformatted(f"demo: next phase is {waiting}")
                if imgui.Button("Next (N)") or imgui.IsKeyPressed(imgui.Key.N, False):
                    self.press_next()
            else:
                imgui.TextUnformatted("demo: running the phase")
        if self.joint_limits is not None and self.q is not None:
            imgui.Separator()
            lower, upper = self.joint_limits
            changed = False
            for i in range(6):
                moved, value = imgui.SliderAngle(
                    f"joint {i + 1}", self.q[i], math.degrees(lower[i]), math.degrees(upper[i])
                )
                if moved:
                    self.q[i] = float(value)
                    changed = True
            if changed:
                self.set_joints(self.q)
        imgui.Separator()
        names = self.camera_names()
        current = names.index(self.camera) if self.camera in names else 0
        picked, index = imgui.Combo("camera", current, names)
        if picked and index != current:
            self.aim(names[index])
        imgui.End()


# -- the web viewer, bound where asked -------------------------------------------------------
@dataclasses.dataclass
class _Start:
    """How the web viewer thread's start went: the bound port, or the error."""

    done: threading.Event = dataclasses.field(default_factory=threading.Event)
    port: int = 0
    error: BaseException | None = None


def _no_banner(host: str, port: int) -> None:
    """Studio's start-up banner, not printed."""
    del host, port


def _web_viewer_class(host: str, start: _Start) -> type[Any]:
    """Studio's web viewer, bound on ``host`` (Studio itself binds every interface), reporting
    its start to ``start``."""
    from mujoco.studio import web_viewer

    class _WebViewer(web_viewer.WebViewer):
        @property
        def _host(self) -> str:
            return host

        @_host.setter
        def _host(self, value: str) -> None:
            del value  # Studio assigns '::' (all interfaces); the host we were given wins

        def __init__(self, *args: Any, **kwargs: Any) -> None:
            # Studio prints a boxed banner of its own at start-up: a second URL (localhost,
            # not the host bound here) in terminal hyperlink escapes, even into a log. The
            # view command's box (kr210_sim.view.live.start_up_box) says it once instead.
            banner = getattr(web_viewer, "_print_url_banner", None)
            if banner is not None:
                web_viewer._print_url_banner = _no_banner
            try:
                super().__init__(*args, **kwargs)
                start.port = int(self._http_port)
            except BaseException as exc:
                start.error = exc
                raise
            finally:
                if banner is not None:
                    web_viewer._print_url_banner = banner
                start.done.set()

    return _WebViewer


def _launch(settings: ViewerSettings, plugins: list[Any]) -> tuple[Any, str]:
    """Start the viewer thread; return its handle and the URL (web) or "" (window)."""
    from mujoco.studio import launch_thread, viewer_protocol

    viewer_plugins, sim_plugins = plugin.split_plugins(plugins)
    config = viewer_protocol.ViewerConfig(
        title="kr210_sim",
        width=settings.width,
        height=settings.height,
        gfx="web" if settings.mode == "web" else "",
        http_port=settings.port,
    )
    if settings.mode == "window":
        if not has_display():
            raise ConfigError("--window needs a display (DISPLAY is not set); use --web")
        from mujoco.studio import launch_native

        return launch_native.launch(config, plugins=plugins), ""

    start = _Start()
    cls = _web_viewer_class(settings.host, start)

    def target(endpoint: Any) -> None:
        viewer = cls(config, endpoint, plugins=viewer_plugins)
        viewer_protocol.run_viewer_loop(viewer)

    handle = launch_thread.launch_thread(target, sim_plugins=sim_plugins)
    if not start.done.wait(START_TIMEOUT) or start.error is not None:
        reason = start.error or "it did not start in time"
        try:
            handle.close()
        except BaseException:  # the thread's own error is the one to report
            pass
        port = settings.port or "8080+"
        raise ConfigError(f"cannot serve the viewer on {settings.host}:{port}: {reason}")
    host = settings.host if ":" not in settings.host else f"[{settings.host}]"
    return handle, f"http://{host}:{start.port}/"


class LiveViewer:
    """An open MuJoCo Studio viewer showing one cell model.

    Args:
        model: The simulated model (never handed to the viewer; a copy is).
        settings: How to show it.
        joint_limits: Slider limits [rad] (joint mode).

    Raises:
        ConfigError: When Studio is missing, ``--window`` has no display, the port is busy or
            the camera does not exist.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        settings: ViewerSettings,
        joint_limits: tuple[Sequence[float], Sequence[float]] | None = None,
    ) -> None:
        if settings.camera != FREE_CAMERA:
            from kr210_sim.media.render import check_camera

            check_camera(model, settings.camera)
        self.settings = settings
        self.model = model
        # The viewer's copy: visual settings may differ (a wider free-camera field of view);
        # anything the viewer sends back lands here, not in the simulated cell.
        self.shadow_model = copy.deepcopy(model)
        home = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, HOME_CAMERA)
        if home >= 0:
            self.shadow_model.vis.global_.fovy = float(model.cam_fovy[home])
        self.shadow_data = mujoco.MjData(self.shadow_model)
        self._state = np.empty(mujoco.mj_stateSize(model, _STATE))
        self.inbox = Inbox()
        self.panel = Panel(
            settings.camera, settings.demo, joint_limits, fast=settings.quality == "fast"
        )
        self.handle, self.url = _launch(settings, [self.panel, self.inbox])
        self.syncs = 0
        self.handle.set_model(self.shadow_model, data=self.shadow_data)

    def publish(
        self, data: mujoco.MjData, lines: Sequence[str], waiting: str = "", q: npt.ArrayLike = ()
    ) -> None:
        """Show ``data``'s state and the panel text; deliver the viewer's input to the inbox.

        Raises:
            ViewerClosed: When the viewer has gone (window closed, viewer thread failed).
        """
        try:
            running = self.handle.is_running()  # re-raises the viewer thread's failure
        except Exception as exc:
            raise ViewerClosed(f"the viewer failed: {exc}") from exc
        if not running:
            raise ViewerClosed("the viewer was closed")
        mujoco.mj_getState(self.model, data, self._state, _STATE)
        mujoco.mj_setState(self.shadow_model, self.shadow_data, self._state, _STATE)
        self.handle.send_to_viewer(
            StatusSnapshot(
                lines=tuple(lines), waiting=waiting, q=tuple(float(v) for v in np.ravel(q))
            )
        )
        self.handle.sync(self.shadow_model, self.shadow_data)
        self.syncs += 1

    def close(self) -> None:
        """Stop the viewer thread (and the web server)."""
        try:
            self.handle.close()
        except Exception as exc:  # the viewer thread's failure, already logged by Studio
            log.warning("the viewer stopped with an error: %s", exc)
