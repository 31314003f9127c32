"""Pictures of what the sensors saw (``python -m kr210_sim perceive --out look.png``).

One row of three panels per look, each panel the sensor's own size (W x H px, one image pixel a
PNG pixel), under a header band naming it:

1. the colour image;
2. the depth image, colour-mapped (turbo, from the nearest valid depths to 1 m beyond the
   median; missing pixels black; the range in the header);
3. the clusters the pipeline found: the colour image dimmed, each cluster's points in a colour
   of its own, its fitted pose drawn as a wireframe (a cylinder's two rims and sides, a box's
   edges, a sphere's great circles) and its label and confidence written on the object; the
   detection picked is marked ``[pick]``.

Drawn with matplotlib (Agg, headless) and written atomically.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from kr210_sim.perception.camera import Observation, project
from kr210_sim.perception.kinds import Detection, Pose
from kr210_sim.perception.pipeline import Look, Percept
from kr210_sim.util.outputs import atomic_path

if TYPE_CHECKING:
    from matplotlib.axes import Axes

FloatArray = npt.NDArray[np.float64]

#: Height of the band above each row of panels, naming them [px].
HEADER_PX = 28
#: Panels per look: colour, depth, clusters.
PANELS = ("rgb", "depth", "clusters")
#: The clusters' colours (matplotlib's tab10, as RGB in [0, 1]).
CLUSTER_COLOURS = (
    (0.12, 0.47, 0.71), (1.0, 0.5, 0.05), (0.17, 0.63, 0.17), (0.84, 0.15, 0.16),
    (0.58, 0.4, 0.74), (0.55, 0.34, 0.29), (0.89, 0.47, 0.76), (0.5, 0.5, 0.5),
    (0.74, 0.74, 0.13), (0.09, 0.75, 0.81),
)  # fmt: skip


@dataclass(frozen=True, slots=True)
class Label:
    """A cluster's label as drawn.

    Attributes:
        look: The look's row (0-based).
        detection: The detection's index in the look.
        text: The text written.
        u: The column of its anchor (:func:`label_anchor`: the object's top) in the clusters
            panel [px]; the text is centred on it, just above.
        v: The anchor's row [px].
    """

    look: int
    detection: int
    text: str
    u: float
    v: float


def to_pixels(obs: Observation, points: npt.ArrayLike) -> FloatArray:
    """Base-frame points [m] to (u, v) pixel coordinates [px] of ``obs``'s image (NaN behind
    the camera)."""
    T = np.asarray(obs.T_base_camera, dtype=np.float64)
    p = np.atleast_2d(np.asarray(points, dtype=np.float64))
    return project((p - T[:3, 3]) @ T[:3, :3], obs.intrinsics)


def _ring(centre: FloatArray, axis: FloatArray, radius: float, n: int = 36) -> FloatArray:
    """``n + 1`` points of the circle of ``radius`` [m] about ``axis`` at ``centre`` (closed)."""
    a = axis / max(float(np.linalg.norm(axis)), 1e-12)
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(a, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    t = np.linspace(0.0, 2.0 * math.pi, n + 1)
    return centre + radius * (np.outer(np.cos(t), e1) + np.outer(np.sin(t), e2))


def wireframe(shape: str, pose: Pose) -> list[FloatArray]:
    """The polylines (each (N, 3) [m], base frame) that draw a fitted pose."""
    c = np.asarray(pose.position, dtype=np.float64)
    if shape == "cylinder":
        a = np.asarray(pose.axis, dtype=np.float64)
        r, half = pose.size[0], pose.size[1] / 2.0
        top, bottom = _ring(c + half * a, a, r), _ring(c - half * a, a, r)
        sides = [np.array([bottom[i], top[i]]) for i in range(0, 36, 9)]
        return [top, bottom, *sides, np.array([c - half * a, c + half * a])]
    if shape == "box":
        R = np.asarray(pose.frame, dtype=np.float64)
        h = np.asarray(pose.size[:3], dtype=np.float64) / 2.0
        corners = {
            (i, j, k): c + R @ (h * np.array([i, j, k]))
            for i in (-1, 1)
            for j in (-1, 1)
            for k in (-1, 1)
        }
        edges = []
        for (i, j, k), p in corners.items():
            for n in ((-i, j, k), (i, -j, k), (i, j, -k)):
                if n > (i, j, k):
                    edges.append(np.array([p, corners[n]]))
        return edges
    r = pose.size[0]
    return [_ring(c, np.asarray(e), r) for e in np.eye(3)]


def label_anchor(d: Detection) -> FloatArray:
    """Where a cluster's label stands [m] (base frame): on top of its fitted pose (the label
    sits just above it in the image), or at the cluster's centroid without a pose."""
    if d.pose is None:
        return np.asarray(d.centroid, dtype=np.float64)
    c, a = np.asarray(d.pose.position), np.asarray(d.pose.axis)
    half = {"cylinder": d.pose.size[-1] / 2.0, "box": d.pose.size[-1] / 2.0}
    return np.asarray(c + half.get(d.shape, d.pose.size[0]) * a, dtype=np.float64)


def label_text(d: Detection, picked: bool) -> str:
    """What a cluster's label says: its kind (``?`` when none was recognised), the confidence
    in per cent, and ``[pick]`` on the detection picked."""
    return f"{d.label or '?'} {100 * d.confidence:.0f}%" + (" [pick]" if picked else "")


def _header(fig: Any, x: float, y: float, text: str) -> None:
    fig.text(x, y, text, ha="left", va="center", fontsize=10, color="white", family="monospace")


def _image_axes(fig: Any, col: int, row: int, rows: int, w: int, h: int) -> Axes:
    """Axes covering exactly panel (``row``, ``col``)'s W x H pixels, image coordinates."""
    fw, fh = len(PANELS) * w, rows * (h + HEADER_PX)
    bottom = fh - (row + 1) * (h + HEADER_PX)
    ax: Axes = fig.add_axes((col * w / fw, bottom / fh, w / fw, h / fh))
    ax.set_axis_off()
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    return ax


def _depth_range(depth: npt.NDArray[np.floating]) -> tuple[float, float]:
    """The colour map's range [m]: the 1st percentile of the valid depths to the 99th, or to
    1 m beyond the median when that is nearer (the walls far behind would flatten the shelf)."""
    valid = depth[np.isfinite(depth) & (depth > 0)]
    if not len(valid):
        return 0.0, 1.0
    lo, mid, hi = (float(v) for v in np.percentile(valid, [1.0, 50.0, 99.0]))
    return lo, max(min(hi, mid + 1.0), lo + 1e-3)


def _draw_clusters(
    ax: Axes, obs: Observation, look: Look, target: Detection | None, row: int
) -> list[Label]:
    """The clusters panel's drawing (on top of the dimmed image); the labels drawn."""
    w, h = obs.intrinsics.width, obs.intrinsics.height
    labels: list[Label] = []
    owners = np.asarray(look.obstacle_owner)
    points = np.asarray(look.obstacle_points, dtype=np.float64).reshape(-1, 3)
    for i, d in enumerate(look.detections):
        colour = CLUSTER_COLOURS[i % len(CLUSTER_COLOURS)]
        mine = points[owners == i]
        if len(mine):
            uv = to_pixels(obs, mine)
            ax.scatter(uv[:, 0], uv[:, 1], s=4.0, c=[colour], marker="s", linewidths=0)
        if d.pose is not None:
            for line in wireframe(d.shape, d.pose):
                uv = to_pixels(obs, line)
                ax.plot(uv[:, 0], uv[:, 1], color="white", linewidth=1.0)
        (u, v) = to_pixels(obs, label_anchor(d))[0]
        if not (np.isfinite(u) and np.isfinite(v)) or not (0 <= u < w and 0 <= v < h):
            continue
        picked = target is d
        text = label_text(d, picked)
        ax.text(
            u, v - 3, text, ha="center", va="bottom", fontsize=9, color="white",
            family="monospace", clip_on=True,
            bbox={"boxstyle": "round,pad=0.2", "facecolor": colour, "alpha": 0.85,
                  "edgecolor": "yellow" if picked else "none", "linewidth": 1.5},
        )  # fmt: skip
        labels.append(Label(row, i, text, float(u), float(v)))
    return labels


def write_look_panels(
    path: Path | str, observations: Sequence[Observation], percept: Percept, title: str = ""
) -> list[Label]:
    """Write the PNG of ``observations`` (one row per look) and what ``percept`` made of them.

    Args:
        path: The PNG to write (atomically).
        observations: The looks, in the order the pipeline took them (one size for all).
        percept: The pipeline's result over them (its ``looks`` in the same order).
        title: Said in the first header band, after the sensor's name.

    Returns:
        The cluster labels drawn, with where (in each row's clusters panel) [px].

    Raises:
        ValueError: No observation, or looks of different sizes.
        ConfigError: When ``path`` cannot be written.
    """
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import colormaps
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if not observations:
        raise ValueError("no look to draw")
    w, h = observations[0].intrinsics.width, observations[0].intrinsics.height
    if any((o.intrinsics.width, o.intrinsics.height) != (w, h) for o in observations):
        raise ValueError("the looks are of different sizes: draw them one by one")
    rows = len(observations)
    dpi = 100.0
    fig = Figure(figsize=(len(PANELS) * w / dpi, rows * (h + HEADER_PX) / dpi), dpi=dpi)
    fig.patch.set_facecolor("#202020")
    FigureCanvasAgg(fig)
    cmap = colormaps["turbo"].with_extremes(bad="black")
    fh = rows * (h + HEADER_PX)
    labels: list[Label] = []
    for row, obs in enumerate(observations):
        look = percept.looks[row] if row < len(percept.looks) else None
        y = 1.0 - (row * (h + HEADER_PX) + HEADER_PX / 2.0) / fh
        lo, hi = _depth_range(obs.depth)
        n = len(look.detections) if look is not None else 0
        heads = (
            f"{obs.sensor}: colour {w}x{h}" + (f"  {title}" if title and row == 0 else ""),
            f"depth {lo:.2f}-{hi:.2f} m (black: missing)",
            f"{n} cluster(s)" + (f"; {'; '.join(look.problems)}" if look and look.problems else ""),
        )
        for col, text in enumerate(heads):
            _header(fig, (col * w + 6) / (len(PANELS) * w), y, text)
        ax = _image_axes(fig, 0, row, rows, w, h)
        ax.imshow(obs.rgb, interpolation="nearest")
        ax = _image_axes(fig, 1, row, rows, w, h)
        depth = np.ma.masked_invalid(np.where(obs.depth > 0, obs.depth, np.nan))
        ax.imshow(depth, cmap=cmap, vmin=lo, vmax=hi, interpolation="nearest")
        ax = _image_axes(fig, 2, row, rows, w, h)
        ax.imshow((obs.rgb.astype(np.float32) * 0.35).astype(np.uint8), interpolation="nearest")
        if look is not None:
            labels += _draw_clusters(ax, obs, look, percept.target, row)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png", facecolor=fig.get_facecolor())
    return labels
