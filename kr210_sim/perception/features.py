"""A cluster's feature vector: its colour, its size and the shape of its surface.

As the RoboND perception project did: histograms of hue, saturation and value, and of the
surface normals; to which are added the cluster's extents (a can and a tube of one colour differ
by size) and a histogram of the surface's curvature (a cylinder's side is curved one way, a
box's faces not at all, a sphere both ways). Normals and curvature come from the covariance of
each point's nearest neighbours (SciPy's k-d tree).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from matplotlib.colors import rgb_to_hsv
from scipy.spatial import cKDTree

FloatArray = npt.NDArray[np.float64]

#: Bins of each histogram.
HUE_BINS, SAT_BINS, VAL_BINS, NORMAL_BINS, CURV_BINS = 12, 4, 4, 6, 6
#: Neighbours of each point for its normal.
NEIGHBOURS = 12
#: Length of the feature vector.
N_FEATURES = HUE_BINS + SAT_BINS + VAL_BINS + NORMAL_BINS + CURV_BINS + 3


def normals(points: FloatArray, k: int = NEIGHBOURS) -> tuple[FloatArray, FloatArray]:
    """Each point's unit normal and surface variation (the smallest eigenvalue's share of the
    neighbourhood's covariance: 0 on a plane, up to 1/3).

    Args:
        points: (N, 3) points [m], N >= 4.
        k: Neighbours per point (itself included).
    """
    k = min(k, len(points))
    _, idx = cKDTree(points).query(points, k=k)
    nb = points[idx] - points[idx].mean(axis=1, keepdims=True)
    cov = np.einsum("nki,nkj->nij", nb, nb) / k
    w, v = np.linalg.eigh(cov)
    n = v[:, :, 0]
    var = w[:, 0] / np.maximum(w.sum(axis=1), 1e-18)
    return n, var


def _hist(x: FloatArray, bins: int, lo: float, hi: float) -> FloatArray:
    h, _ = np.histogram(np.clip(x, lo, hi), bins=bins, range=(lo, hi))
    return h / max(len(x), 1)


def extents(points: FloatArray) -> FloatArray:
    """Height (z) and the two horizontal extents along the footprint's principal axes, larger
    first, from the 2nd to the 98th percentile [m]."""
    z = np.percentile(points[:, 2], [2.0, 98.0])
    xy = points[:, :2] - points[:, :2].mean(axis=0)
    _, _, vt = np.linalg.svd(xy, full_matrices=False)
    proj = xy @ vt.T
    lo, hi = np.percentile(proj, [2.0, 98.0], axis=0)
    return np.array([z[1] - z[0], *(hi - lo)])


def features(
    points: FloatArray,
    colours: npt.NDArray[np.uint8],
    normals_and_variation: tuple[FloatArray, FloatArray] | None = None,
) -> FloatArray:
    """The feature vector of one cluster.

    Args:
        points: (N, 3) the cluster's points [m], in a frame whose z is up (N >= 4).
        colours: (N, 3) their colours.
        normals_and_variation: :func:`normals` of the points, when already computed.

    Returns:
        (:data:`N_FEATURES`,) hue, saturation and value histograms, the histogram of the
        normals' angle to the vertical, the curvature histogram, the height and the two
        horizontal extents [m].
    """
    hsv = rgb_to_hsv(colours.astype(np.float64) / 255.0)
    sat = hsv[:, 1]
    hue_w = sat / max(float(sat.sum()), 1e-9)
    hue, _ = np.histogram(hsv[:, 0], bins=HUE_BINS, range=(0.0, 1.0), weights=hue_w)
    n, var = normals(points) if normals_and_variation is None else normals_and_variation
    nz = np.abs(n[:, 2])
    ext = extents(points)
    return np.concatenate(
        (
            hue,
            _hist(sat, SAT_BINS, 0.0, 1.0),
            _hist(hsv[:, 2], VAL_BINS, 0.0, 1.0),
            _hist(nz, NORMAL_BINS, 0.0, 1.0),
            _hist(var, CURV_BINS, 0.0, 0.12),
            ext,
        )
    )
