"""The objects' points, one cluster each: Euclidean clustering on position and colour.

As PCL's Euclidean cluster extraction (the RoboND project's): two points within ``eps`` are
linked, and a cluster is a connected set of links (SciPy's k-d tree finds the pairs, its sparse
graph routines the components; scikit-learn's DBSCAN gives the same clusters here at four to
five times the CPU time, measured on the bays of :mod:`kr210_sim.perception.synthetic_bay`).
Objects on a cluttered shelf stand touching or a few millimetres apart, closer than a far
sensor's depth noise, so position alone joins them; their colours differ, so each point is
placed by its position [m] and its chromaticity (the colour's share of each channel, which
shading does not change) scaled by :data:`COLOUR_WEIGHT` [m per unit].
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

FloatArray = npt.NDArray[np.float64]

#: How far apart [m] two points of chromaticities one unit apart count as.
COLOUR_WEIGHT = 0.15


#: Colours darker than this (the brightest channel, 0-255) count as grey: their chromaticity is
#: mostly noise.
DARK = 40


def chromaticity(colours: npt.NDArray[np.uint8]) -> FloatArray:
    """(N, 3) shares of red, green and blue in each colour (1/3 each for a dark one)."""
    c = colours.astype(np.float64) + 1.0
    out = c / c.sum(axis=1, keepdims=True)
    out[colours.max(axis=1) < DARK] = 1.0 / 3.0
    return out


def cluster(
    points: FloatArray,
    colours: npt.NDArray[np.uint8],
    eps: float,
    min_points: int = 30,
    colour_weight: float = COLOUR_WEIGHT,
) -> list[npt.NDArray[np.intp]]:
    """The clusters of a cloud, largest first.

    Args:
        points: (N, 3) points [m].
        colours: (N, 3) their colours.
        eps: Longest link [m] (about two voxels, more at a noisy range).
        min_points: Fewest points of a cluster kept (smaller ones are noise).
        colour_weight: Weight of the chromaticity [m per unit].

    Returns:
        Each cluster's indices into ``points``.
    """
    if len(points) < min_points:
        return []
    features = np.hstack((points, colour_weight * chromaticity(colours)))
    pairs = cKDTree(features).query_pairs(eps, output_type="ndarray")
    n = len(points)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    counts = np.bincount(labels)
    keep = np.flatnonzero(counts >= min_points)
    order = keep[np.argsort(-counts[keep], kind="stable")]
    return [np.flatnonzero(labels == k) for k in order]
