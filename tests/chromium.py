"""Headless Chromium driven over the DevTools protocol: load the viewer page, screenshot it, type.

Used by the browser tests, ``benchmarks/viewer.py`` and the README screenshot. It starts
Debian's ``chromium-headless-shell`` (or another Chromium) with software WebGL (SwiftShader), no
network side traffic and a fresh profile, and talks to one page over the DevTools WebSocket
(``websockets``, installed with MuJoCo Studio).
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Any

from kr210_sim.errors import ConfigError

#: Executables tried in order.
CANDIDATES = ("chromium-headless-shell", "chromium", "chromium-browser", "google-chrome")
#: Flags for a headless, sandbox-free (root in containers), offline, software-WebGL Chromium.
FLAGS = (
    "--headless",
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--no-default-browser-check",
    "--mute-audio",
    "--hide-scrollbars",
)


#: JavaScript that changes one corner pixel, so the next frame has something to draw.
_DAMAGE = """(() => {
  let d = document.getElementById('kr210-damage');
  if (!d) {
    d = document.createElement('div');
    d.id = 'kr210-damage';
    d.style.cssText = 'position:fixed;left:0;top:0;width:1px;height:1px;pointer-events:none';
    document.body.appendChild(d);
  }
  d.style.opacity = d.style.opacity === '0.01' ? '0.02' : '0.01';
  d.style.background = '#000';
})()"""


def find_chromium() -> str | None:
    """Path of a Chromium executable, or None."""
    for name in CANDIDATES:
        path = shutil.which(name)
        if path:
            return path
    return None


class Chromium:
    """One headless Chromium process with one page.

    Args:
        width: Window width [px].
        height: Window height [px].
        executable: Chromium to run (default: :func:`find_chromium`).
        timeout: Seconds to wait for the browser and for each command.
        manual_frames: Draw only when :meth:`frame` asks (DevTools begin-frame control): on a
            slow machine each screenshot then costs one frame, not a wait behind a backlog of
            frames drawn in software. The page's timers and sockets run in real time.

    Raises:
        ConfigError: When no Chromium is installed or it does not start.
    """

    def __init__(
        self,
        width: int = 1200,
        height: int = 800,
        executable: str | None = None,
        timeout: float = 20.0,
        manual_frames: bool = False,
    ) -> None:
        exe = executable or find_chromium()
        if exe is None:
            raise ConfigError(
                "no Chromium found: install chromium-headless-shell (Debian) or chromium"
            )
        from websockets.sync.client import connect

        self.timeout = timeout
        self.profile = Path(tempfile.mkdtemp(prefix="kr210_chromium_"))
        args = [exe, *FLAGS, f"--window-size={width},{height}"]
        if manual_frames:
            args += ["--enable-begin-frame-control", "--run-all-compositor-stages-before-draw"]
        self.manual_frames = manual_frames
        args += [f"--user-data-dir={self.profile}", "--remote-debugging-port=0", "about:blank"]
        if hasattr(os, "geteuid") and os.geteuid() == 0:
            args.insert(1, "--no-sandbox")  # Chromium's sandbox refuses to run as root
        self.process = subprocess.Popen(
            args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
        )
        self._id = 0
        self._stack = contextlib.ExitStack()
        try:
            port = self._devtools_port()
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/json/list", timeout=5) as r:
                targets = json.load(r)
            page = next(t for t in targets if t.get("type") == "page")
            self.ws = self._stack.enter_context(
                connect(page["webSocketDebuggerUrl"], max_size=None, open_timeout=timeout)
            )
            if manual_frames:
                self.send("HeadlessExperimental.enable")
        except BaseException:
            self.close()
            raise

    def _devtools_port(self) -> int:
        marker = self.profile / "DevToolsActivePort"
        deadline = time.monotonic() + self.timeout
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise ConfigError(f"Chromium exited with code {self.process.returncode}")
            try:
                text = marker.read_text().split()
            except OSError:
                text = []
            if text:
                return int(text[0])
            time.sleep(0.05)
        raise ConfigError("Chromium did not open its DevTools port in time")

    def send(self, method: str, **params: Any) -> dict[str, Any]:
        """Run one DevTools command and return its result."""
        self._id += 1
        call = self._id
        self.ws.send(json.dumps({"id": call, "method": method, "params": params}))
        deadline = time.monotonic() + self.timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"DevTools {method} did not answer in {self.timeout} s")
            msg = json.loads(self.ws.recv(timeout=left))
            if msg.get("id") == call:
                if "error" in msg:
                    raise RuntimeError(f"DevTools {method}: {msg['error']}")
                result: dict[str, Any] = msg.get("result", {})
                return result

    def open(self, url: str) -> None:
        """Load ``url`` in the page."""
        self.send("Page.navigate", url=url)

    def evaluate(self, expression: str) -> Any:
        """The value of a JavaScript expression in the page (promises are awaited)."""
        r = self.send("Runtime.evaluate", expression=expression, awaitPromise=True)
        return r.get("result", {}).get("value")

    def screenshot(self) -> bytes:
        """A PNG of the page as it is now (with manual frames: as the next frame draws it)."""
        if self.manual_frames:
            # A frame without damage comes without a picture: touch one corner pixel first.
            self.evaluate(_DAMAGE)
            shot = self.frame(screenshot=True)
            if shot is None:
                raise RuntimeError("Chromium drew no frame to screenshot")
            return shot
        return base64.b64decode(self.send("Page.captureScreenshot", format="png")["data"])

    def frame(self, screenshot: bool = False) -> bytes | None:
        """Draw one frame (manual frames only); return its PNG when ``screenshot``."""
        params: dict[str, Any] = {"interval": 1000.0 / 60.0}
        if screenshot:
            params["screenshot"] = {"format": "png"}
        r = self.send("HeadlessExperimental.beginFrame", **params)
        data = r.get("screenshotData")
        return base64.b64decode(data) if data else None

    def press(self, key: str) -> None:
        """Type one letter key (down and up), as a user at the keyboard would."""
        code = f"Key{key.upper()}"
        vk = ord(key.upper())
        common = {"key": key, "code": code, "windowsVirtualKeyCode": vk, "nativeVirtualKeyCode": vk}
        self.send("Input.dispatchKeyEvent", type="keyDown", text=key, **common)
        self.send("Input.dispatchKeyEvent", type="keyUp", **common)

    def click(self, x: float, y: float) -> None:
        """Click the left mouse button at page coordinates (``x``, ``y``) [px]."""
        for kind in ("mouseMoved", "mousePressed", "mouseReleased"):
            self.send("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1)

    def frame_rate(self, seconds: float = 2.0) -> float:
        """Animation frames per second the page gets, counted over ``seconds``."""
        ms = int(seconds * 1000)
        js = (
            "new Promise(done => { let n = 0; const t0 = performance.now();"
            f" function f(t) {{ n++; if (t - t0 < {ms}) requestAnimationFrame(f);"
            " else done(n * 1000 / (t - t0)); } requestAnimationFrame(f); })"
        )
        return float(self.evaluate(js))

    def close(self) -> None:
        """Stop the browser (its whole process group) and remove its profile."""
        self._stack.close()
        if self.process.poll() is None:
            try:
                os.killpg(self.process.pid, 15)
            except ProcessLookupError:
                pass
            try:
                self.process.wait(5)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, 9)
                self.process.wait(5)
        shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self) -> Chromium:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def screenshot_command(
    url: str, out: Path, width: int = 1200, height: int = 800, budget_ms: int = 10000
) -> list[str]:
    """The one command that screenshots the viewer page without DevTools (``docs/how-to/
    viewer.md``): ``--screenshot`` after ``budget_ms`` of virtual time [ms], with
    ``--run-all-compositor-stages-before-draw`` (without it the PNG holds the page's first frame,
    "Connecting..." in Studio's status bar, however long the budget)."""
    exe = find_chromium()
    if exe is None:
        raise ConfigError("no Chromium found: install chromium-headless-shell (Debian) or chromium")
    args = [exe, *FLAGS, f"--window-size={width},{height}", f"--virtual-time-budget={budget_ms}"]
    args += ["--run-all-compositor-stages-before-draw", f"--screenshot={out}", url]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        args.insert(1, "--no-sandbox")  # Chromium's sandbox refuses to run as root
    return args


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class ViewProcess:
    """``python -m kr210_sim view`` in a subprocess, its output collected line by line
    (the browser tests, the viewer benchmark, the README screenshot).


    Args:
        args: Options after ``view --web --port P``.
    """

    def __init__(self, *args: str) -> None:
        self.port = free_port()
        cmd = [sys.executable, "-u", "-m", "kr210_sim", "view", "--web", "--port", str(self.port)]
        self.proc = subprocess.Popen(
            [*cmd, *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        )
        self.lines: list[str] = []
        threading.Thread(target=self._pump, daemon=True).start()

    def _pump(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip())

    def count(self, text: str) -> int:
        """Output lines holding ``text`` so far."""
        return sum(text in line for line in list(self.lines))

    def wait_for(
        self, text: str, timeout: float = 60.0, tick: Callable[[], object] | None = None
    ) -> None:
        """Wait up to ``timeout`` [s] for a line holding ``text``, calling ``tick`` meanwhile."""
        deadline = time.monotonic() + timeout
        while not self.count(text):
            assert self.proc.poll() is None, "\n".join(self.lines)
            assert time.monotonic() < deadline, f"no {text!r} in:\n" + "\n".join(self.lines)
            if tick is not None:
                tick()
            else:
                time.sleep(0.05)

    @property
    def url(self) -> str:
        """The page's address."""
        return f"http://127.0.0.1:{self.port}/"

    def stop(self) -> None:
        """Terminate the process (kill it after 10 s)."""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
