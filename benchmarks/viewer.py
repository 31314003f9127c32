"""The live viewer's pace: real-time factor held at --speed 1, the fastest --speed sustained, and
the frame rate headless Chromium (software WebGL) sees on the page.

Run: ``python benchmarks/viewer.py [--speeds 1,5,10,20,40] [--screenshot docs/viewer.png]``.
Prints figures only. Each speed runs ``view --web --exit-when-done`` in its own process (MuJoCo
Studio runs one web viewer per process) and reads the pace it prints. ``--screenshot`` writes
the page as the browser test takes it (manual frames, so a screenshot costs one frame).
"""

from __future__ import annotations

import argparse
import io
import re
import subprocess
import sys
import time
from pathlib import Path

# The test helpers (tests/) are not part of the package.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from chromium import ViewProcess, free_port


def pace(speed: float, cycles: int) -> tuple[float, float]:
    """(real-time factor, wall seconds) of ``view`` at ``speed`` for ``cycles`` cycles."""
    cmd = [sys.executable, "-m", "kr210_sim", "view", "--web", "--port", str(free_port())]
    cmd += ["--cycles", str(cycles), "--speed", str(speed), "--exit-when-done"]
    cmd += ["--report", "reports/bench_view.json"]
    t = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    wall = time.perf_counter() - t
    m = re.search(r"live pace: ([0-9.]+)x real time", out)
    if m is None:
        raise SystemExit(f"no pace in the output of {' '.join(cmd)}:\n{out}")
    return float(m.group(1)), wall


def browser_figures(seconds: float, width: int, height: int) -> float:
    """Animation frames per second Chromium gives the page while the cycles run."""
    from chromium import Chromium

    view = ViewProcess("--cycles", "10", "--report", "reports/bench_view.json")
    try:
        view.wait_for("viewer: ")
        with Chromium(width=width, height=height, timeout=120) as c:
            c.open(f"http://127.0.0.1:{view.port}/")
            view.wait_for("Browser connected")
            time.sleep(3.0)  # the model is parsed and the first frames drawn
            return c.frame_rate(seconds)
    finally:
        view.stop()


def screenshot(path: Path, width: int, height: int) -> None:
    """The page in demo mode, held before the first carry, taken as the browser test takes it
    (manual frames), saved as a small PNG. Held, so the picture and the panel agree: at software
    rendering's few frames a second the page draws the streamed states late."""
    from chromium import Chromium
    from PIL import Image

    view = ViewProcess(
        "--demo", "--speed", "2", "--cycles", "10", "--report", "reports/bench_view.json"
    )
    try:
        view.wait_for("demo: next phase approach")
        with Chromium(width=width, height=height, timeout=120, manual_frames=True) as c:
            c.open(f"http://127.0.0.1:{view.port}/")
            view.wait_for("Browser connected", tick=c.frame)
            for phase in ("grasp", "lift", "retreat", "carry"):
                for _ in range(5):  # a key sent before the page's UI is connected is lost
                    c.press("n")
                    try:
                        view.wait_for(f"demo: next phase {phase}", 8.0, tick=c.frame)
                        break
                    except AssertionError:
                        continue
            t_end = time.monotonic() + 8.0  # the page catches up with the held state
            while time.monotonic() < t_end:
                c.frame()
            png = c.screenshot()
    finally:
        view.stop()
    img = Image.open(io.BytesIO(png)).convert("RGB").quantize(colors=128)
    path.parent.mkdir(parents=True, exist_ok=True)
    img.save(path, optimize=True)
    print(f"wrote {path} ({path.stat().st_size // 1024} KiB)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--speeds", default="1,5,10,20,40", help="speeds to try (1,5,10,20,40)")
    ap.add_argument("--cycles", type=int, default=2, help="cycles per speed (2)")
    ap.add_argument("--fps-seconds", type=float, default=5.0, help="frame-rate window [s] (5)")
    ap.add_argument("--screenshot", type=Path, default=None, help="write the README screenshot")
    args = ap.parse_args()
    if args.screenshot is not None:
        screenshot(args.screenshot, 800, 500)
        return
    fastest = 0.0
    for speed in (float(s) for s in args.speeds.split(",")):
        rtf, wall = pace(speed, args.cycles)
        held = rtf >= 0.95 * speed
        fastest = speed if held else fastest
        print(
            f"--speed {speed:5g}: {rtf:6.2f}x real time over {args.cycles} cycles "
            f"({wall:5.1f} s wall, {'held' if held else 'NOT held'})"
        )
    print(f"fastest --speed held (>= 95 %): {fastest:g}")
    from chromium import find_chromium

    if find_chromium() is None:
        print("no Chromium: frame rate not measured")
        return
    for width, height in ((1200, 800), (640, 400)):
        fps = browser_figures(args.fps_seconds, width, height)
        print(
            f"headless Chromium (SwiftShader, {width}x{height}) sees {fps:.1f} frames/s on the page"
        )


if __name__ == "__main__":
    main()
