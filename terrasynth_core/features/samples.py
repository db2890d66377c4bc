"""Feature samples: where feature patches are centred, and their control points.

A *feature sample* is a patch centre on a ridge or valley network with the
points where the network leaves the circle inscribed in the patch (the
paper's control points, §4.1).  How many times the network crosses the circle
gives the patch type: 1 = endpoint, 2 = path, 3 or more = branch of that
degree.

Only the part of the network *connected to the centre inside the disc*
counts: a stray ridge clipping the corner of a path patch does not turn it
into a branch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .graph import FeatureGraph


@dataclass(frozen=True, eq=False)
class FeatureSample:
    """One feature patch centre.

    Parameters
    ----------
    center : ndarray of float, shape (2,)
        ``(row, col)`` in grid cells.
    kind : {"ridge", "valley"}
    crossings : ndarray of float, shape (n, 2)
        Where the network connected to the centre leaves the inscribed circle,
        ``(row, col)``, sorted counter-clockwise by angle around the centre.
    """

    center: np.ndarray
    kind: str
    crossings: np.ndarray

    @property
    def degree(self) -> int:
        return len(self.crossings)

    @property
    def patch_type(self) -> str:
        """``"end"``, ``"path"`` or ``"branch"`` from the crossing count."""
        return {1: "end", 2: "path"}.get(self.degree, "branch")

    def control_points(self) -> np.ndarray:
        """Control points relative to the centre, shape (n + 1, 2): the centre
        (0, 0) first, then the crossings."""
        return np.vstack([[0.0, 0.0], self.crossings - self.center])


class NetworkSampler:
    """Feature samples of one network, at its nodes and along its paths.

    Walks the graph outwards from a sample centre until it leaves the disc
    of the patch's inscribed circle, which gives the sample's crossings.

    Parameters
    ----------
    graph : FeatureGraph
    radius : float
        Inscribed-circle radius in cells (half the patch).

    Attributes
    ----------
    at_node : list of list of (int, int)
        Per node, the paths that meet there: (path index, direction away
        from the node, +1 from the path's start, -1 from its end).
    """

    def __init__(self, graph: FeatureGraph, radius: float):
        self.graph = graph
        self.radius = float(radius)
        self.points = [np.asarray(p.points, dtype=float) for p in graph.paths]
        self.at_node: list[list[tuple[int, int]]] = [[] for _ in graph.nodes]
        for i, p in enumerate(graph.paths):
            self.at_node[p.start].append((i, +1))
            self.at_node[p.end].append((i, -1))

    def node_sample(self, node: int) -> FeatureSample | None:
        """The sample centred on node ``node`` (None when nothing leaves the disc)."""
        nd = self.graph.nodes[node]
        c = np.array([nd.row, nd.col])
        return _make_sample(c, self.graph.kind, self.crossings_from_node(c, node))

    def path_samples(self, path: int, spacing: float, *, reverse: bool = False) -> list[FeatureSample]:
        """Samples every ``spacing`` cells along path ``path``, half a spacing
        clear of both ends, from its start (or from its end with ``reverse``)."""
        pts = self.points[path][::-1] if reverse else self.points[path]
        out = []
        for j in _arc_positions(pts, spacing, spacing / 2):
            idx = len(pts) - 1 - j if reverse else j
            c = self.points[path][idx]
            s = _make_sample(c, self.graph.kind, self.crossings_from_path(c, path, idx))
            if s is not None:
                out.append(s)
        return out

    def crossings_from_node(self, center: np.ndarray, node: int) -> list[np.ndarray]:
        out: list[np.ndarray] = []
        for path, direction in self.at_node[node]:
            self._walk(center, path, 0 if direction > 0 else len(self.points[path]) - 1, direction, node, out, set())
        return out

    def crossings_from_path(self, center: np.ndarray, path: int, index: int) -> list[np.ndarray]:
        out: list[np.ndarray] = []
        seen = {path}
        self._walk(center, path, index, +1, None, out, seen)
        self._walk(center, path, index, -1, None, out, seen)
        return out

    def _walk(self, center, path, index, direction, from_node, out, seen):
        pts = self.points[path]
        seq = pts[index:] if direction > 0 else pts[index::-1]
        dist = np.hypot(seq[:, 0] - center[0], seq[:, 1] - center[1])
        outside = np.flatnonzero(dist >= self.radius)
        if outside.size:
            j = int(outside[0])
            if j == 0:
                out.append(seq[0].copy())
                return
            out.append(_circle_exit(seq[j - 1], seq[j], center, self.radius))
            return
        # The whole rest of the path lies inside the disc: go on past its node.
        seen.add(path)
        p = self.graph.paths[path]
        node = p.end if direction > 0 else p.start
        if node == from_node:
            return
        for other, d in self.at_node[node]:
            if other in seen:
                continue
            seen.add(other)
            start = 0 if d > 0 else len(self.points[other]) - 1
            self._walk(center, other, start, d, node, out, seen)


def _circle_exit(a: np.ndarray, b: np.ndarray, c: np.ndarray, r: float) -> np.ndarray:
    """Point where segment a->b (a inside, b outside the circle) crosses it."""
    d = b - a
    f = a - c
    qa = float(d @ d)
    qb = 2.0 * float(f @ d)
    qc = float(f @ f) - r * r
    disc = max(qb * qb - 4 * qa * qc, 0.0)
    t = (-qb + np.sqrt(disc)) / (2 * qa) if qa > 0 else 0.0
    return a + np.clip(t, 0.0, 1.0) * d


def _make_sample(center: np.ndarray, kind: str, crossings: list[np.ndarray]) -> FeatureSample | None:
    if not crossings:
        return None
    pts = np.array(crossings, dtype=float)
    ang = np.arctan2(-(pts[:, 0] - center[0]), pts[:, 1] - center[1])  # counter-clockwise, north up
    order = np.argsort(ang, kind="stable")
    return FeatureSample(np.asarray(center, dtype=float), kind, pts[order])


def _arc_positions(points: np.ndarray, spacing: float, margin: float) -> list[int]:
    """Indices of points every ``spacing`` cells along a polyline, keeping
    ``margin`` cells clear of both ends."""
    seg = np.hypot(*np.diff(points, axis=0).T)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    length = arc[-1]
    targets = np.arange(spacing, length - margin + 1e-9, spacing)
    if targets.size == 0:
        return []
    return sorted(set(np.searchsorted(arc, targets).clip(0, len(points) - 1).tolist()))


def example_samples(graph: FeatureGraph, radius: float, spacing: float) -> list[FeatureSample]:
    """The candidate pool of an example: every node, and points along every
    path every ``spacing`` cells.

    Parameters
    ----------
    graph : FeatureGraph
        Ridges or valleys of the example DEM.
    radius : float
        Inscribed-circle radius in cells (half the patch).
    spacing : float
        Distance between path samples in cells.
    """
    sampler = NetworkSampler(graph, radius)
    out = [s for s in (sampler.node_sample(node.id) for node in graph.nodes) if s is not None]
    for i in range(len(graph.paths)):
        out.extend(sampler.path_samples(i, spacing))
    return out


