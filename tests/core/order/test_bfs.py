"""Breadth-first feature order on small hand-made networks (paper §4.1)."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.features.graph import FeatureGraph, FeatureNode, FeaturePath
from terrasynth_core.order import breadth_first_components, feature_order

RADIUS = 8.0


def _line(a, b) -> np.ndarray:
    """Points one cell apart from a to b (axis-parallel segments)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    n = int(round(np.hypot(*(b - a)))) + 1
    return np.linspace(a, b, n)


def _graph(kind: str, nodes: list, paths: list) -> FeatureGraph:
    """A graph from node positions and (start, end) index pairs."""
    degree = np.bincount(np.ravel(paths), minlength=len(nodes))
    node_objs = tuple(FeatureNode(i, float(r), float(c), "branch" if degree[i] >= 3 else "end", int(degree[i]))
                      for i, (r, c) in enumerate(nodes))
    path_objs = tuple(FeaturePath(s, e, _line(nodes[s], nodes[e])) for s, e in paths)
    return FeatureGraph(kind, (200, 200), node_objs, path_objs)


def _y_and_segment() -> FeatureGraph:
    """A Y (branch at (100, 100), arms of 60 cells east, north and west; the
    east and west paths stored towards the branch) and, apart from it, a
    20-cell segment."""
    nodes = [(100, 100), (100, 160), (40, 100), (100, 40), (20, 170), (20, 190)]
    return _graph("ridge", nodes, [(1, 0), (0, 2), (3, 0), (4, 5)])


def _centres(samples) -> list[tuple[float, float]]:
    return [tuple(float(v) for v in s.center) for s in samples]


def test_root_is_the_highest_degree_node_and_arms_come_out_from_it():
    y, segment = breadth_first_components(_y_and_segment(), RADIUS, spacing=RADIUS)
    assert y.samples[0].degree == 3 and _centres(y.samples[:1]) == [(100.0, 100.0)]
    steps = [8.0 * k for k in range(1, 8)]
    expected = ([(100.0, 100.0)]
                + [(100.0, 100.0 + d) for d in steps] + [(100.0, 160.0)]     # east arm, walked against its storage
                + [(100.0 - d, 100.0) for d in steps] + [(40.0, 100.0)]      # north arm
                + [(100.0, 100.0 - d) for d in steps] + [(100.0, 40.0)])     # west arm, against its storage
    assert _centres(y.samples) == expected
    # Along an arm: paths, until the arm's end lies inside the patch.
    assert [s.patch_type for s in y.samples[1:9]] == ["path"] * 6 + ["end"] * 2
    assert y.length == pytest.approx(180.0)
    # A component without a branch starts at its top-left endpoint.
    assert _centres(segment.samples) == [(20.0, 170.0), (20.0, 178.0), (20.0, 186.0), (20.0, 190.0)]
    assert segment.length == pytest.approx(20.0)


def test_components_go_by_sample_count_then_network_then_length():
    ridges = _graph("ridge", [(100, 100), (100, 160), (40, 100), (100, 40), (20, 170), (20, 190), (10, 10), (10, 33)],
                    [(1, 0), (0, 2), (3, 0), (4, 5), (6, 7)])
    # Valleys: a 100-cell line (14 samples) and a 23-cell segment, longer
    # than the ridges' 20-cell one but with as many samples (4).
    valleys = _graph("valley", [(180, 20), (180, 120), (150, 150), (150, 173)], [(0, 1), (2, 3)])
    order = feature_order([ridges, valleys], RADIUS, spacing=RADIUS)
    firsts = {}
    for i, s in enumerate(order):
        firsts.setdefault((s.kind, tuple(float(v) for v in s.center)), i)
    starts = [firsts[("ridge", (100.0, 100.0))], firsts[("valley", (180.0, 20.0))],
              firsts[("ridge", (10.0, 10.0))], firsts[("ridge", (20.0, 170.0))], firsts[("valley", (150.0, 150.0))]]
    assert starts == [0, 25, 39, 43, 47]
    assert len(order) == 25 + 14 + 4 + 4 + 4


def test_keep_filters_after_ordering_and_raster_sorts_by_position():
    graph = _y_and_segment()
    full = feature_order([graph], RADIUS, spacing=RADIUS)
    kept = feature_order([graph], RADIUS, spacing=RADIUS, keep=lambda s: s.center[1] < 150)
    assert _centres(kept) == [c for c in _centres(full) if c[1] < 150]
    raster = feature_order([graph], RADIUS, spacing=RADIUS, raster=True)
    assert sorted(_centres(raster)) == sorted(_centres(full))
    assert _centres(raster) == sorted(_centres(full))


def test_a_stroke_inside_one_patch_gets_one_patch_along_it():
    """A dash shorter than the patch's radius has no node or path sample
    with a way out of the disc; it gets one, centred on it, along it."""
    dash = _graph("valley", [(50, 40), (53, 44)], [(0, 1)])  # 5 cells, under RADIUS
    (component,) = breadth_first_components(dash, RADIUS, spacing=RADIUS)
    (sample,) = component.samples
    assert sample.patch_type == "path"
    assert np.hypot(*(sample.center - np.array([51.5, 42.0]))) <= 1.0
    way = np.array([3.0, 4.0]) / 5.0
    for crossing in sample.crossings:
        out = crossing - sample.center
        assert np.hypot(*out) == pytest.approx(RADIUS)
        assert abs(out @ way) == pytest.approx(RADIUS)  # along the dash
    # A longer stroke keeps its own samples.
    assert len(breadth_first_components(_graph("valley", [(50, 40), (50, 70)], [(0, 1)]), RADIUS,
                                        spacing=RADIUS)[0].samples) > 1


def test_a_small_branched_stroke_keeps_its_degree():
    """A cross of 3-cell arms, inside one disc: one branch sample on its
    node, one crossing along each arm."""
    cross = _graph("ridge", [(50, 50), (47, 50), (50, 53), (53, 50), (50, 47)], [(0, 1), (0, 2), (0, 3), (0, 4)])
    (component,) = breadth_first_components(cross, RADIUS, spacing=RADIUS)
    (sample,) = component.samples
    assert sample.degree == 4 and tuple(sample.center) == (50.0, 50.0)
    ways = sorted(tuple(np.round((c - sample.center) / RADIUS, 6)) for c in sample.crossings)
    assert ways == [(-1.0, 0.0), (0.0, -1.0), (0.0, 1.0), (1.0, 0.0)]
