"""Breadth-first order of the sketch's feature patches (paper §4.1, Fig. 6).

Each connected component of a sketch network is traversed from a root (its
highest-degree branch point, or an endpoint when it has none); the samples
along a path come in order from the node nearer the root, then the node at
its far end.  Components with more patches go first: they set the terrain's
frame, and smaller networks fit in around them.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..features.graph import FeatureGraph
from ..features.samples import FeatureSample, NetworkSampler, make_sample


@dataclass(frozen=True, eq=False)
class Component:
    """One connected component of a network, as breadth-first samples.

    Parameters
    ----------
    samples : list of FeatureSample
        In breadth-first order from the root.
    length : float
        Total length of the component's paths, cells.
    """

    samples: list[FeatureSample]
    length: float


def breadth_first_components(graph: FeatureGraph, radius: float, *, spacing: float) -> list[Component]:
    """The samples of every connected component of ``graph``, breadth-first.

    Parameters
    ----------
    graph : FeatureGraph
        A sketch's ridges or valleys.
    radius : float
        Inscribed-circle radius in cells (half the patch).
    spacing : float
        Distance between samples along a path, cells.

    Returns
    -------
    list of Component
        In the order of their roots: highest degree first, then by
        position (row, col) for determinism.
    """
    sampler = NetworkSampler(graph, radius)
    n = len(graph.nodes)
    seen = np.zeros(n, dtype=bool)
    degree = sampler.degrees()
    roots = sorted(range(n), key=lambda i: (-degree[i], graph.nodes[i].row, graph.nodes[i].col))
    components = []
    for root in roots:
        if seen[root]:
            continue
        order: list[FeatureSample] = []
        length = 0.0
        members: list[int] = []  # the component's paths
        seen[root] = True
        queue = deque([root])
        _append(order, sampler.node_sample(root))
        while queue:
            node = queue.popleft()
            for path, direction in sampler.paths_at(node):
                p = graph.paths[path]
                other = p.end if direction > 0 else p.start
                if seen[other]:
                    continue
                seen[other] = True
                length += p.length
                order.extend(sampler.path_samples(path, spacing, reverse=direction < 0))
                _append(order, sampler.node_sample(other))
                queue.append(other)
                members.append(path)
        if not order and members:
            # The whole stroke lies inside one patch's disc, so no node or
            # path sample has a way out of it: one patch along it.
            order.append(_short_stroke_sample(graph, members, radius))
        components.append(Component(order, length))
    return components


def _short_stroke_sample(graph: FeatureGraph, paths: list[int], radius: float) -> FeatureSample:
    """The one sample of a component too short for any other.

    A stroke shorter than the patch's radius used to give no patch at all,
    silently: a sketch of short dashes came out as plain fill.  A branched
    one (a small Y or cross) is centred on its branch node and leaves the
    disc once along each of the node's arms (towards the arm's far end),
    so it keeps its degree; a dash is centred half way along its longest
    path and leaves the disc both ways along its main axis.
    """
    ends = [(graph.paths[i].start, graph.paths[i].end) for i in paths]
    degree = np.bincount(np.ravel(ends))
    if degree.max() >= 3:
        node = int(np.argmax(degree))  # (the first of the highest degree: the same every time)
        nd = graph.nodes[node]
        center = np.array([nd.row, nd.col], dtype=float)
        ways = []
        for i, (a, b) in zip(paths, ends):
            if node in (a, b):
                pts = np.asarray(graph.paths[i].points, dtype=float)
                far = (pts[-1] if a == node else pts[0]) - center
                if np.hypot(*far) > 0:
                    ways.append(center + radius * far / np.hypot(*far))
        if len(ways) >= 3:
            return make_sample(center, graph.kind, ways)
    longest = max(paths, key=lambda i: graph.paths[i].length)
    pts = np.asarray(graph.paths[longest].points, dtype=float)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    center = pts[int(np.searchsorted(arc, arc[-1] / 2))]
    every = np.concatenate([np.asarray(graph.paths[i].points, dtype=float) for i in paths])
    d = every - every.mean(axis=0)
    # The main axis, its angle from east, in closed form (no LAPACK: the
    # same floats on every machine); a dot, with no axis, runs east-west.
    angle = 0.5 * np.arctan2(2.0 * float(d[:, 0] @ d[:, 1]), float(d[:, 1] @ d[:, 1] - d[:, 0] @ d[:, 0]))
    axis = np.array([np.sin(angle), np.cos(angle)])
    return make_sample(center, graph.kind, [center + radius * axis, center - radius * axis])


def feature_order(graphs: Sequence[FeatureGraph], radius: float, *, spacing: float,
                  keep: Callable[[FeatureSample], bool] | None = None, raster: bool = False) -> list[FeatureSample]:
    """Every feature sample of the sketch networks, in placing order.

    Parameters
    ----------
    graphs : sequence of FeatureGraph
        The sketch's networks (ridges, then valleys).
    radius : float
        Inscribed-circle radius in cells (half the patch).
    spacing : float
        Distance between samples along a path, cells.
    keep : callable, optional
        Samples for which it returns False are left out (after ordering).
    raster : bool, default False
        Order by centre row, then column, instead of breadth-first.

    Returns
    -------
    list of FeatureSample

    Notes
    -----
    Components are sorted once, by the key (most samples, network index in
    ``graphs``, longest) over the components listed network by network in
    root order; the sort is stable, so equal keys keep root order.
    """
    listed = [(g, comp) for g, graph in enumerate(graphs)
              for comp in breadth_first_components(graph, radius, spacing=spacing)]
    listed.sort(key=lambda t: (-len(t[1].samples), t[0], -t[1].length))
    samples = [s for _, comp in listed for s in comp.samples if keep is None or keep(s)]
    if raster:
        samples.sort(key=lambda s: (round(s.center[0]), round(s.center[1])))
    return samples


def _append(order: list[FeatureSample], sample: FeatureSample | None) -> None:
    if sample is not None:
        order.append(sample)
