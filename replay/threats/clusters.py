"""Hill points grouped into continuous obstacles (seed 000 §5.3), and the terminal points of a group.

Points closer than ``HILL_LINK_M`` (1 km) form one continuous obstacle: :func:`cluster_hill_points`
groups them by single linkage (a chain of < 1 km steps joins its ends).  The boundary ("terminal")
points of a cluster seen from the aircraft are the ones an avoider goes round
(:func:`cluster_terminals`).  Used by the hill threat (:class:`replay.threats.kinds.HillThreat`), the
perception layer and PSO-CA.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from replay.frames import as_points
from terrain.errors import InputError

IntArray = npt.NDArray[np.int64]

HILL_LINK_M = 1000.0  # seed 000 §5.3: points closer than 1 km form one continuous obstacle


def cluster_hill_points(points: npt.ArrayLike, link: float = HILL_LINK_M) -> tuple[IntArray, ...]:
    """Group points (N, 3) into continuous obstacles: single linkage, two points belong together
    when their 3D distance is strictly below ``link`` (seed 000: "less than 1 km"), and a chain of
    such steps joins its ends.  Returns index arrays (ascending), ordered by their first index."""
    p = as_points(points, "points").reshape(-1, 3)
    if not (math.isfinite(link) and link > 0):
        raise InputError(f"link distance must be a positive number of metres; got {link!r}")
    n = len(p)
    if n == 0:
        return ()
    if n == 1:  # one point, one group (a single obstacle: most of PSO-CA's scans)
        return (np.zeros(1, dtype=np.int64),)
    if n <= SMALL_CLUSTERING:
        return _small_clusters(p, link)
    return _tree_clusters(p, link)


def _tree_clusters(p: npt.NDArray[np.float64], link: float) -> tuple[IntArray, ...]:
    """:func:`cluster_hill_points` by scipy: the links from a k-d tree, the groups the connected
    components of their sparse graph."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = len(p)
    pairs = cKDTree(p).query_pairs(np.nextafter(link, 0.0), output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    first: dict[int, int] = {}
    for i, lab in enumerate(labels.tolist()):
        first.setdefault(lab, i)
    order = sorted(first, key=first.__getitem__)
    return tuple(np.flatnonzero(labels == lab).astype(np.int64) for lab in order)


SMALL_CLUSTERING = 256  # points: up to this many, grouped by the dense matrix below (no scipy)


def _small_clusters(p: npt.NDArray[np.float64], link: float) -> tuple[IntArray, ...]:
    """:func:`cluster_hill_points` of a few points (N, 3): the links from the matrix of
    distances, each point labelled with the lowest index it is chained to (labels spread along
    the links and jump to their label's label until they settle).  A PSO-CA decision groups
    a radar picture's few points every scan, where scipy's k-d tree and sparse graph cost a
    quarter of the decision (issue 38)."""
    d = p[:, None, :] - p[None, :, :]
    near = np.sqrt((d * d).sum(axis=2)) < link
    labels = np.arange(len(p))
    while True:
        spread = np.where(near, labels[None, :], len(p)).min(axis=1)
        spread = spread[spread]  # pointer jumping: a long chain settles in log rounds
        if np.array_equal(spread, labels):
            break
        labels = spread
    return tuple((labels == lab).nonzero()[0].astype(np.int64) for lab in np.unique(labels))


def cluster_terminals(points: npt.ArrayLike, observer: npt.ArrayLike) -> tuple[int, int]:
    """The terminal points of one cluster seen from ``observer``: indices of the points with the
    most counter-clockwise (left) and most clockwise (right) horizontal bearing, measured from the
    bearing of the cluster's centroid -- the edges an avoider goes round (seed 000 §5.3)."""
    p = as_points(points, "points").reshape(-1, 3)
    o = as_points(observer, "observer").reshape(3)
    if len(p) == 0:
        raise InputError("a cluster needs at least one point")
    if len(p) == 1:  # its own terminals (a single obstacle: most of PSO-CA's decisions)
        return 0, 0
    d = p[:, :2] - o[:2]
    centre = d.mean(axis=0)
    ref = math.atan2(centre[0], centre[1])  # course of the centroid, clockwise from north
    rel = (np.arctan2(d[:, 0], d[:, 1]) - ref + np.pi) % (2 * np.pi) - np.pi
    return int(np.argmin(rel)), int(np.argmax(rel))
