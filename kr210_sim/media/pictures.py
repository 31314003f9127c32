"""The README's pictures: a hero still of a grasp and a short GIF around it.

Both come from one simulated cycle (the published cell, slot 5, seed 0), filmed from the
``hero`` camera: :func:`grasp_states` records the states, :func:`hero_still` renders the moment
the fingers have closed, :func:`grasp_gif` the seconds around it. ``make pictures`` (or
``python -m kr210_sim.media.pictures``) writes ``docs/hero.png`` and ``docs/grasp.gif``.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from kr210_sim.media.render import make_renderer, render_frame
from kr210_sim.util.outputs import check_writable, write_bytes_atomic

import mujoco  # isort: skip  (after kr210_sim so MUJOCO_GL is chosen first)

log = logging.getLogger(__name__)


def grasp_states(
    slot: int = 5, fps: float = 15.0, before: float = 2.0, after: float = 1.6
) -> tuple[mujoco.MjModel, list[mujoco.MjData], int]:
    """States of one cycle at ``fps`` [1/s], from ``before`` [s] ahead of the grasp (the
    fingers starting to close) to ``after`` [s] past it.

    Returns:
        The model, the states, and the index of the first state of the grasp.
    """
    from kr210_sim.sim.session import episode_runner

    runner = episode_runner(0, slot=slot)
    snaps: list[mujoco.MjData] = []
    grasp_at: list[float] = []

    def grab(cell: object) -> None:
        d = runner.cell.data
        if not grasp_at and runner.status["phase"] == "grasp":
            grasp_at.append(d.time)
        if d.time >= len(snaps) / fps:
            copy = mujoco.MjData(runner.model)
            mujoco.mj_copyData(copy, runner.model, d)
            snaps.append(copy)

    runner.cell.hooks.append(grab)
    runner.run_cycle(1, slot)
    runner.cell.hooks.remove(grab)
    start = int(np.ceil(grasp_at[0] * fps - 1e-9))
    lo, hi = max(0, start - round(before * fps)), start + round(after * fps)
    return runner.model, snaps[lo:hi], start - lo


def _frames(
    model: mujoco.MjModel, states: list[mujoco.MjData], camera: str, width: int, height: int
) -> list[np.ndarray]:
    renderer = make_renderer(model, width, height)
    try:
        return [render_frame(renderer, d, camera).copy() for d in states]
    finally:
        renderer.close()


def hero_still(out: Path | str, width: int = 1280, height: int = 720) -> Path:
    """Render the grasp (fingers closed on the cylinder) from the hero camera to a PNG."""
    import imageio.v3 as iio

    path = check_writable(out)
    model, states, _ = grasp_states(fps=15.0, before=0.0, after=1.0)
    model.vis.quality.offsamples = 4
    frame = _frames(model, [states[min(len(states) - 1, 5)]], "hero", width, height)[0]
    return write_bytes_atomic(path, iio.imwrite("<bytes>", frame, extension=".png"))


def grasp_gif(out: Path | str, width: int = 480, height: int = 360, fps: float = 12.0) -> Path:
    """A looping GIF of the approach, grasp and lift from the hero camera."""
    import imageio.v3 as iio

    path = check_writable(out)
    model, states, _ = grasp_states(fps=fps)
    frames = _frames(model, states, "hero", width, height)
    data = iio.imwrite("<bytes>", np.stack(frames), extension=".gif", duration=1000.0 / fps, loop=0)
    return write_bytes_atomic(path, data)


def main() -> None:
    """Write ``docs/hero.png`` and ``docs/grasp.gif``."""
    from kr210_sim.util.paths import ROOT

    logging.basicConfig(level=logging.INFO, format="%(message)s")
    for p in (hero_still(ROOT / "docs" / "hero.png"), grasp_gif(ROOT / "docs" / "grasp.gif")):
        log.info("wrote %s (%d kB)", p, p.stat().st_size // 1000)


if __name__ == "__main__":
    main()
