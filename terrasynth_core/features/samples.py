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

from collections.abc import Sequence
from dataclasses import dataclass
from typing import overload

import numpy as np

from .graph import FeatureGraph


@dataclass(frozen=True, eq=False, slots=True)
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


class SampleTable(Sequence):
    """An example's samples of one kind held as arrays (a stored analysis,
    mapped from its file): a :class:`FeatureSample` is made when asked
    for, so a library's hundreds of thousands of samples are not as many
    objects in each process that holds the analyses.

    Parameters
    ----------
    kind : {"ridge", "valley"}
    centers : ndarray of float, shape (n, 2)
        ``(row, col)`` cells.
    degrees : ndarray of int, shape (n,)
        Crossings of each sample.
    crossings : ndarray of float, shape (sum(degrees), 2)
        The samples' crossings one after another, as
        :attr:`FeatureSample.crossings` orders them.
    """

    __slots__ = ("kind", "centers", "degrees", "crossings", "offsets")

    def __init__(self, kind: str, centers: np.ndarray, degrees: np.ndarray, crossings: np.ndarray):
        self.kind, self.centers, self.degrees = kind, centers, degrees
        # A plain view: slices of a memmap would each carry its mapping's attributes.
        self.crossings = np.asarray(crossings)
        self.offsets = np.concatenate([[0], np.cumsum(degrees, dtype=np.int64)])

    @classmethod
    def of(cls, samples: Sequence[FeatureSample], kind: str) -> SampleTable:
        """The table of ``samples`` (itself if it is one)."""
        if isinstance(samples, SampleTable):
            return samples
        centers = np.array([s.center for s in samples], dtype=float).reshape(-1, 2)
        degrees = np.array([s.degree for s in samples], dtype=np.int64)
        crossings = np.concatenate([s.crossings for s in samples]) if samples else np.zeros((0, 2))
        return cls(kind, centers, degrees, crossings)

    def of_degree(self, degree: int) -> tuple[np.ndarray, np.ndarray]:
        """The samples with ``degree`` crossings, in order, as arrays.

        Returns
        -------
        centers : ndarray of float, shape (m, 2)
        crossings : ndarray of float, shape (m, degree, 2)
        """
        which = np.flatnonzero(np.asarray(self.degrees) == degree)
        at = self.offsets[which][:, None] + np.arange(degree)
        return (np.asarray(self.centers)[which].astype(float, copy=False).reshape(-1, 2),
                np.asarray(self.crossings)[at].astype(float, copy=False).reshape(-1, degree, 2))

    def __len__(self) -> int:
        return len(self.degrees)

    @overload
    def __getitem__(self, i: int) -> FeatureSample: ...
    @overload
    def __getitem__(self, i: slice) -> list[FeatureSample]: ...

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        i = range(len(self))[i]  # negative indices, and IndexError past the end
        return FeatureSample(np.array(self.centers[i], dtype=float), self.kind,
                             self.crossings[self.offsets[i]:self.offsets[i + 1]])


class NetworkSampler:
    """Feature samples of one network, at its nodes and along its paths.

    Walks the graph outwards from a sample centre until it leaves the disc
    of the patch's inscribed circle, which gives the sample's crossings.

    Parameters
    ----------
    graph : FeatureGraph
    radius : float
        Inscribed-circle radius in cells (half the patch).
    station_radius : float, optional
        Also note where each route out crosses this smaller circle first
        (:mod:`.stations`).

    Notes
    -----
    The network is held as arrays (its points one after another, and per
    node the paths that meet there), not a list per path and per node: the
    samplers of a library's examples stay with them between runs.
    """

    def __init__(self, graph: FeatureGraph, radius: float, *, station_radius: float | None = None):
        self.graph = graph
        self.radius = float(radius)
        self.station_radius = station_radius
        self._flat, self._offsets = graph.flat_paths()
        ends = graph.path_ends()
        self._ends = ends
        # Per node, the paths meeting there, in path order: (path, +1) from
        # a path's start, (path, -1) from its end (a path from a node to
        # itself lists both, start first).
        n_paths = len(ends)
        at_node = np.concatenate([ends[:, 0], ends[:, 1]])
        at_path = np.tile(np.arange(n_paths, dtype=np.int64), 2)
        at_step = np.repeat(np.array([1, -1], dtype=np.int64), n_paths)
        order = np.lexsort((-at_step, at_path, at_node))
        self._at_path, self._at_step = at_path[order], at_step[order]
        self._at_offsets = np.concatenate(
            [[0], np.cumsum(np.bincount(at_node, minlength=len(graph.nodes)))]).astype(np.int64)

    def points(self, path: int) -> np.ndarray:
        """Path ``path``'s points, ndarray of float, shape (n, 2), cells (a view)."""
        return self._flat[self._offsets[path]:self._offsets[path + 1]]

    def flat_points(self) -> np.ndarray:
        """Every path's points one after another, ndarray of float, shape (n, 2)."""
        return self._flat

    def locate(self, position: int) -> tuple[int, int]:
        """``(path, index)`` of point ``position`` of :meth:`flat_points`."""
        path = int(np.searchsorted(self._offsets, position, side="right")) - 1
        return path, position - int(self._offsets[path])

    def paths_at(self, node: int) -> list[tuple[int, int]]:
        """The paths that meet at ``node``: (path index, direction away from
        the node, +1 from the path's start, -1 from its end)."""
        a, b = self._at_offsets[node], self._at_offsets[node + 1]
        return list(zip(self._at_path[a:b].tolist(), self._at_step[a:b].tolist()))

    def degrees(self) -> np.ndarray:
        """How many path ends meet at each node, ndarray of int, shape (n_nodes,)."""
        return np.diff(self._at_offsets)

    def node_sample(self, node: int) -> FeatureSample | None:
        """The sample centred on node ``node`` (None when nothing leaves the disc)."""
        nd = self.graph.nodes[node]
        c = np.array([nd.row, nd.col], dtype=float)
        return make_sample(c, self.graph.kind, self.crossings_from_node(c, node))

    def path_samples(self, path: int, spacing: float, *, reverse: bool = False) -> list[FeatureSample]:
        """Samples every ``spacing`` cells along path ``path``, half a spacing
        clear of both ends, from its start (or from its end with ``reverse``)."""
        forward = self.points(path)
        pts = forward[::-1] if reverse else forward
        out = []
        for j in _arc_positions(pts, spacing, spacing / 2):
            idx = len(pts) - 1 - j if reverse else j
            c = forward[idx]
            s = make_sample(c, self.graph.kind, self.crossings_from_path(c, path, idx))
            if s is not None:
                out.append(s)
        return out

    def crossings_from_node(self, center: np.ndarray, node: int) -> list[np.ndarray]:
        return [exit_ for exit_, _ in self.routes_from_node(center, node)]

    def crossings_from_path(self, center: np.ndarray, path: int, index: int) -> list[np.ndarray]:
        return [exit_ for exit_, _ in self.routes_from_path(center, path, index)]

    def routes_from_node(self, center: np.ndarray, node: int) -> list[tuple[np.ndarray, np.ndarray | None]]:
        """Each way out of the disc from node ``node``: ``(crossing, station)``
        (the station None without ``station_radius``)."""
        out: list = []
        for path, direction in self.paths_at(node):
            self._walk(center, path, 0 if direction > 0 else len(self.points(path)) - 1, direction, node, None,
                       out, set())
        return out

    def routes_from_path(self, center: np.ndarray, path: int, index: int) -> list[tuple[np.ndarray, np.ndarray | None]]:
        """As :meth:`routes_from_node`, from point ``index`` of path ``path``."""
        out: list = []
        seen = {path}
        self._walk(center, path, index, +1, None, None, out, seen)
        self._walk(center, path, index, -1, None, None, out, seen)
        return out

    def _walk(self, center, path, index, direction, from_node, station, out, seen):
        pts = self.points(path)
        seq = pts[index:] if direction > 0 else pts[index::-1]
        # Points are about a cell apart: a route leaves the disc within a
        # few radii of points unless it winds, so look there first.
        near = seq[:int(4 * self.radius) + 2]
        dist = np.hypot(near[:, 0] - center[0], near[:, 1] - center[1])
        if len(near) < len(seq) and dist.max() < self.radius:
            near = seq
            dist = np.hypot(seq[:, 0] - center[0], seq[:, 1] - center[1])
        seq = near
        if station is None and self.station_radius is not None:
            past = np.flatnonzero(dist >= self.station_radius)
            if past.size:
                j = int(past[0])
                station = seq[0].copy() if j == 0 else _circle_exit(seq[j - 1], seq[j], center, self.station_radius)
        outside = np.flatnonzero(dist >= self.radius)
        if outside.size:
            j = int(outside[0])
            if j == 0:
                out.append((seq[0].copy(), station))
                return
            out.append((_circle_exit(seq[j - 1], seq[j], center, self.radius), station))
            return
        # The whole rest of the path lies inside the disc: go on past its node.
        seen.add(path)
        node = int(self._ends[path, 1 if direction > 0 else 0])
        if node == from_node:
            return
        for other, d in self.paths_at(node):
            if other in seen:
                continue
            seen.add(other)
            start = 0 if d > 0 else len(self.points(other)) - 1
            self._walk(center, other, start, d, node, station, out, seen)


def _circle_exit(a: np.ndarray, b: np.ndarray, c: np.ndarray, r: float) -> np.ndarray:
    """Point where segment a->b (a inside, b outside the circle) crosses it."""
    d = b - a
    f = a - c
    # Products and sums written out, not ``d @ d``: a BLAS dot may fuse
    # them (FMA) or not depending on the CPU and the numpy build, and the
    # vectorised walk (:func:`_circle_exits`) must give the same floats.
    qa = float(d[0] * d[0] + d[1] * d[1])
    qb = 2.0 * float(f[0] * d[0] + f[1] * d[1])
    qc = float(f[0] * f[0] + f[1] * f[1]) - r * r
    disc = max(qb * qb - 4 * qa * qc, 0.0)
    t = (-qb + np.sqrt(disc)) / (2 * qa) if qa > 0 else 0.0
    return a + np.clip(t, 0.0, 1.0) * d


def make_sample(center: np.ndarray, kind: str, crossings: list[np.ndarray]) -> FeatureSample | None:
    """The sample at ``center`` whose feature leaves its disc at
    ``crossings`` (put counter-clockwise from east, north up, as matching
    pairs them); None without crossings."""
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

    Returns
    -------
    list of FeatureSample
        The node samples in node order (nodes with nothing leaving the disc
        left out), then each path's samples from its start, path by path:
        exactly what :class:`NetworkSampler`'s ``node_sample`` and
        ``path_samples`` give, which :func:`walked_example_samples` calls.

    Notes
    -----
    The walks of all samples advance together (:func:`_crossings`), a
    few array passes per step of the walks instead of a Python call per
    path per sample: an example's samples walk hundreds of thousands of
    paths (a plateau's dense networks put many short paths in a disc).
    A graph with a loop (never PPA's, which are forests) and samples whose
    crossings lie at nearly the same angle (their order would hang on the
    last bit) are walked by :class:`NetworkSampler`.
    """
    if not graph.paths:
        return []
    if not graph.is_acyclic():
        return walked_example_samples(graph, radius, spacing)
    radius = float(radius)
    points = [np.asarray(p.points, dtype=float) for p in graph.paths]
    sizes = np.array([len(p) for p in points], dtype=np.int64)
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    flat = np.concatenate(points)
    start_node = np.array([p.start for p in graph.paths], dtype=np.int64)
    end_node = np.array([p.end for p in graph.paths], dtype=np.int64)

    # Samples: every node, then the positions along each path.
    node_centers = np.array([[n.row, n.col] for n in graph.nodes], dtype=float).reshape(-1, 2)
    sample_path, sample_index = _path_sample_positions(points, flat, offsets, spacing)
    centers = np.concatenate([node_centers, flat[offsets[sample_path] + sample_index]])

    # The paths at each node, as NetworkSampler.at_node lists them (by path
    # index): entry e walks path at_path[e] in direction at_step[e].
    n_paths = len(points)
    at_nodes = np.concatenate([start_node, end_node])
    at_path = np.tile(np.arange(n_paths, dtype=np.int64), 2)
    at_step = np.repeat(np.array([1, -1], dtype=np.int64), n_paths)
    order = np.lexsort((at_path, at_nodes))
    at_path, at_step = at_path[order], at_step[order]
    at_offsets = np.concatenate([[0], np.cumsum(np.bincount(at_nodes, minlength=len(graph.nodes)))])

    # First walks: a node sample along every path at its node, a path
    # sample both ways from its point.
    node_ids = np.arange(len(graph.nodes), dtype=np.int64)
    walk_sample = np.concatenate([np.repeat(node_ids, np.diff(at_offsets)),
                                  np.repeat(len(graph.nodes) + np.arange(len(sample_path)), 2)])
    walk_path = np.concatenate([at_path, np.repeat(sample_path, 2)])
    walk_step = np.concatenate([at_step, np.tile(np.array([1, -1], dtype=np.int64), len(sample_path))])
    from_node = offsets[at_path] + np.where(at_step > 0, 0, sizes[at_path] - 1)
    walk_from = np.concatenate([from_node, np.repeat(offsets[sample_path] + sample_index, 2)])

    crossing_sample, crossing_point = _crossings(
        flat, offsets, start_node, end_node, at_offsets, at_path, at_step, centers, radius,
        walk_sample, walk_path, walk_step, walk_from)

    # Crossings counter-clockwise (north up) around their centre.
    rel = crossing_point - centers[crossing_sample]
    angle = np.arctan2(-rel[:, 0], rel[:, 1])
    order = np.lexsort((angle, crossing_sample))
    crossing_sample, crossing_point, angle = crossing_sample[order], crossing_point[order], angle[order]
    # Angles this close could be ordered otherwise by the walk's order (a
    # stable sort): those samples are walked one by one.
    near = (crossing_sample[1:] == crossing_sample[:-1]) & (np.abs(np.diff(angle)) <= _ANGLE_TIE)
    walked = set(crossing_sample[1:][near].tolist())

    count = np.bincount(crossing_sample, minlength=len(centers))
    first = np.concatenate([[0], np.cumsum(count)]).tolist()
    sampler = NetworkSampler(graph, radius) if walked else None
    kind = graph.kind
    n_nodes = len(graph.nodes)
    out: list[FeatureSample] = []
    for s in np.flatnonzero(count).tolist():
        if s in walked:
            if s < n_nodes:
                sample = sampler.node_sample(s)
            else:
                path, index = int(sample_path[s - n_nodes]), int(sample_index[s - n_nodes])
                sample = make_sample(points[path][index], kind, sampler.crossings_from_path(
                    points[path][index], path, index))
            out.append(sample)
        else:
            out.append(FeatureSample(centers[s], kind, crossing_point[first[s] : first[s + 1]]))
    return out


#: Crossing angles (radians) closer than this are ordered by a walk.
_ANGLE_TIE = 1e-9

#: Points each walk looks at per step of :func:`_crossings`.
_STEP_POINTS = 32


def _path_sample_positions(points: list[np.ndarray], flat: np.ndarray, offsets: np.ndarray,
                           spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The path samples' ``(path, point index)``, each shape (n,), in order.

    Only the paths that may be long enough for a sample go through
    :func:`_arc_positions` (whose cumulative sums decide); a path shorter
    than ``1.5 * spacing`` by a margin far beyond rounding has none.
    """
    step = np.hypot(*np.diff(flat, axis=0).T)
    step[offsets[1:-1] - 1] = 0.0
    cumulative = np.concatenate([[0.0], np.cumsum(step)])
    length = cumulative[offsets[1:] - 1] - cumulative[offsets[:-1]]
    paths, indices = [], []
    for i in np.flatnonzero(length >= 1.5 * spacing - 1e-6).tolist():
        positions = _arc_positions(points[i], spacing, spacing / 2)
        paths.extend([i] * len(positions))
        indices.extend(positions)
    return np.array(paths, dtype=np.int64), np.array(indices, dtype=np.int64)


def _crossings(flat, offsets, start_node, end_node, at_offsets, at_path, at_step, centers, radius,
               sample, path, step, position):
    """Where the walks of all samples leave their discs.

    Parameters
    ----------
    flat : ndarray of float64, shape (n_points, 2)
        The paths' points, concatenated; path ``i`` is
        ``flat[offsets[i]:offsets[i + 1]]``.
    start_node, end_node : ndarray of int64, shape (n_paths,)
    at_offsets, at_path, at_step : ndarray of int64
        The paths at node ``k``: ``at_path[at_offsets[k]:at_offsets[k + 1]]``,
        walked away from ``k`` in direction ``at_step`` (+1: from the start).
    centers : ndarray of float64, shape (n_samples, 2)
    radius : float
    sample, path, step, position : ndarray of int64, shape (n_walks,)
        The first walks: their sample, path, direction and first point
        (an index of ``flat``).

    Returns
    -------
    crossing_sample : ndarray of int64, shape (n,)
    crossing_point : ndarray of float64, shape (n, 2)
        The crossings, as :meth:`NetworkSampler._walk` finds them (the
        first point of a walk at or beyond ``radius``, or where the segment
        to it leaves the circle), in no particular order.

    Notes
    -----
    A walk whose path ends inside the disc goes on along the other paths
    at the node it reached; in a forest no path is walked twice by one
    sample, so "the other paths" are all but the one it came along.
    """
    begin = position.copy()
    last = np.where(step > 0, offsets[path + 1] - 1, offsets[path])
    found_sample, found_point = [], []
    while len(sample):
        left = (last - position) * step + 1  # points still to look at
        # This step's points of every walk, concatenated: at most _STEP_POINTS each.
        count = np.minimum(left, _STEP_POINTS)
        first = np.cumsum(count) - count
        walk = np.repeat(np.arange(len(sample)), count)
        k = np.arange(len(walk)) - first[walk]
        index = position[walk] + step[walk] * k
        center = centers[sample]
        dist = np.hypot(flat[index, 0] - center[walk, 0], flat[index, 1] - center[walk, 1])
        # The first point of each walk at or beyond the radius (count: none).
        out_k = np.minimum.reduceat(np.where(dist >= radius, k, _STEP_POINTS), first)
        found = out_k < count
        # Leaving the disc: at the first point if the walk starts outside,
        # else where the segment into the first outside point crosses it.
        f = np.flatnonzero(found)
        at = position[f] + step[f] * out_k[f]
        at_first = at == begin[f]
        b = flat[at]
        a = flat[np.where(at_first, at, at - step[f])]
        exit_point = _circle_exits(a, b, center[f], radius)
        exit_point[at_first] = b[at_first]
        found_sample.append(sample[f])
        found_point.append(exit_point)
        # Walks whose path ends inside the disc go on at its far node.
        ended = np.flatnonzero(~found & (left <= _STEP_POINTS))
        node = np.where(step[ended] > 0, end_node[path[ended]], start_node[path[ended]])
        n_next = at_offsets[node + 1] - at_offsets[node]
        parent = np.repeat(ended, n_next)
        entry = np.arange(n_next.sum()) + np.repeat(at_offsets[node] - np.cumsum(n_next) + n_next, n_next)
        other = at_path[entry] != path[parent]
        parent, entry = parent[other], entry[other]
        next_path, next_step = at_path[entry], at_step[entry]
        next_first = np.where(next_step > 0, offsets[next_path], offsets[next_path + 1] - 1)
        going = np.flatnonzero(~found & (left > _STEP_POINTS))
        next_last = np.where(next_step > 0, offsets[next_path + 1] - 1, offsets[next_path])
        sample, path, step, position, begin, last = (
            np.concatenate([sample[going], sample[parent]]),
            np.concatenate([path[going], next_path]),
            np.concatenate([step[going], next_step]),
            np.concatenate([position[going] + _STEP_POINTS * step[going], next_first]),
            np.concatenate([begin[going], next_first]),
            np.concatenate([last[going], next_last]),
        )
    if not found_sample:
        return np.empty(0, dtype=np.int64), np.empty((0, 2))
    return np.concatenate(found_sample), np.concatenate(found_point)


def _circle_exits(a: np.ndarray, b: np.ndarray, c: np.ndarray, r: float) -> np.ndarray:
    """:func:`_circle_exit` of many segments, shape (n, 2) each; the same
    operations in the same order, so the same floats."""
    d = b - a
    f = a - c
    qa = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]
    qb = 2.0 * (f[:, 0] * d[:, 0] + f[:, 1] * d[:, 1])
    qc = (f[:, 0] * f[:, 0] + f[:, 1] * f[:, 1]) - r * r
    disc = np.maximum(qb * qb - 4 * qa * qc, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(qa > 0, (-qb + np.sqrt(disc)) / (2 * qa), 0.0)
    return a + np.clip(t, 0.0, 1.0)[:, None] * d


def walked_example_samples(graph: FeatureGraph, radius: float, spacing: float) -> list[FeatureSample]:
    """:func:`example_samples` by :class:`NetworkSampler`, one walk at a time
    (any graph, loops included; the reference the vectorised walks match)."""
    sampler = NetworkSampler(graph, radius)
    out = [s for s in (sampler.node_sample(node.id) for node in graph.nodes) if s is not None]
    for i in range(len(graph.paths)):
        out.extend(sampler.path_samples(i, spacing))
    return out
