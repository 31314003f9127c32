"""A simple perception of your own: a colour threshold and the depth image back-projected.

    python -m kr210_sim run --cycles 3 --perceive --cell scenes/cells/cluttered.toml \\
        --perception examples/perception_simple.py:perceive

For each kind on the pick list (the cycle's pick first) it keeps the pixels whose colour is
nearest that kind's (chromaticity: colour divided by brightness, so the shelf's shading does not
matter) and whose depth lands inside the bay, takes the largest connected blob of them less its
rim (where depth jumps to what lies behind), and for an upright cylinder fits a circle of the
kind's radius to the blob's points seen from above: the centre of that circle is the can's axis,
and its centre's height is halfway between the bay's floor and the highest points seen. The
confidence is the share of the blob's expected size that was seen. It uses NumPy and SciPy only;
see ``examples/perception_template.py`` for the contract.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy import ndimage

#: Fewest pixels a blob needs to count as an object.
MIN_PIXELS = 80
#: Largest chromaticity distance from a kind's colour that still matches it.
COLOUR_TOLERANCE = 0.12
#: Pixels dropped at a blob's rim, where depth jumps to what lies behind (flying pixels).
EDGE_PX = 2
#: Darkest pixel (brightness, 0-765) whose colour is trusted: shadows carry no hue.
MIN_BRIGHTNESS = 60


def _chroma(rgb: np.ndarray) -> np.ndarray:
    """Colour divided by brightness: (..., 3) in [0, 1], summing to one."""
    rgb = np.asarray(rgb, dtype=np.float64)
    return rgb / np.maximum(rgb.sum(axis=-1, keepdims=True), 1e-9)


def _points(look: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Every pixel's point in the base frame [m] (H, W, 3) and whether it lies in the bay."""
    depth = np.asarray(look["depth"], dtype=np.float64)
    K = np.asarray(look["K"])
    T = np.asarray(look["T_base_camera"])
    h, w = depth.shape
    u, v = np.meshgrid(np.arange(w), np.arange(h))
    x = (u - K[0, 2]) / K[0, 0] * depth
    y = (v - K[1, 2]) / K[1, 1] * depth
    cam = np.stack((x, y, depth), axis=-1)
    base = cam @ T[:3, :3].T + T[:3, 3]
    bay = look["bay"]
    c, s = np.cos(bay["yaw"]), np.sin(bay["yaw"])
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    local = (base - np.asarray(bay["center"])) @ R
    inside = np.all(np.abs(local) <= np.asarray(bay["half"]), axis=-1) & (depth > 0)
    return base, inside


def _circle(xy: np.ndarray, radius: float, start: np.ndarray) -> np.ndarray:
    """The centre of a circle of ``radius`` [m] through the points ``xy`` (Gauss-Newton)."""
    c = start.copy()
    for _ in range(20):
        d = xy - c
        r = np.maximum(np.linalg.norm(d, axis=1), 1e-9)
        J = -d / r[:, None]
        step, *_ = np.linalg.lstsq(J, -(r - radius), rcond=None)
        c += step
        if np.linalg.norm(step) < 1e-6:
            break
    return c


def _find(look: dict[str, Any], label: str, base: np.ndarray, inside: np.ndarray) -> dict | None:
    """The kind ``label``'s largest blob in the look, as an entry (None: not there)."""
    kind = look["kinds"][label]
    rgb = look["rgb"]
    bright = rgb.astype(np.int32).sum(axis=-1) >= MIN_BRIGHTNESS
    near = np.linalg.norm(_chroma(rgb) - _chroma(kind["rgb"]), axis=-1) < COLOUR_TOLERANCE
    mask = ndimage.binary_erosion(near & bright, iterations=EDGE_PX) & inside  # no edges
    blobs, n = ndimage.label(mask)
    if n == 0:
        return None
    sizes = np.bincount(blobs.ravel())[1:]
    best = int(np.argmax(sizes)) + 1
    if sizes[best - 1] < MIN_PIXELS:
        return None
    pts = base[blobs == best]
    floor = look["bay"]["center"][2] - look["bay"]["half"][2]
    if kind["shape"] == "cylinder":
        radius = kind["size"][0]  # the kind's: a fitted radius is too noisy at 2.5 m
        camera = np.asarray(look["T_base_camera"])[:2, 3]
        mid = pts[:, :2].mean(axis=0)
        away = (mid - camera) / max(float(np.linalg.norm(mid - camera)), 1e-9)
        xy = _circle(pts[:, :2], radius, mid + 0.5 * radius * away)
        # the can's top: its lid seen from above, or its side's upper rim seen from below,
        # less what the blob's erosion took off that rim [m]
        eye = np.asarray(look["T_base_camera"])[:3, 3]
        top = float(np.percentile(pts[:, 2], 99))
        if eye[2] < top:
            top += EDGE_PX * float(np.linalg.norm(pts.mean(axis=0) - eye)) / look["K"][1][1]
        centre = [float(xy[0]), float(xy[1]), (floor + top) / 2.0]
    else:  # a box or a ball: the blob's middle, half its height up
        height = kind["size"][2] if kind["shape"] == "box" else 2.0 * kind["size"][0]
        mid = np.median(pts, axis=0)
        centre = [float(mid[0]), float(mid[1]), floor + height / 2.0]
    # the share of the pixels an object this size would cover at this range
    distance = float(np.linalg.norm(np.asarray(centre) - np.asarray(look["T_base_camera"])[:3, 3]))
    width = 2.0 * kind["size"][0] if kind["shape"] != "box" else kind["size"][1]
    height = kind["size"][1] if kind["shape"] == "cylinder" else width
    expected = look["K"][0][0] ** 2 * width * height / distance**2
    confidence = float(min(1.0, sizes[best - 1] / max(0.5 * expected, 1.0)))
    return {"label": label, "position": centre, "axis": [0.0, 0.0, 1.0], "confidence": confidence}


def perceive(look: dict[str, Any]) -> list[dict[str, Any]]:
    """The contract of ``examples/perception_template.py``: the look in, the objects seen out."""
    base, inside = _points(look)
    labels = [look["pick"], *(k for k in look["pick_list"] if k != look["pick"])]
    found = [_find(look, label, base, inside) for label in labels if label in look["kinds"]]
    return [f for f in found if f is not None]
