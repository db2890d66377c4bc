"""Feature samples: the vectorised walks give exactly the samples of the
one-at-a-time walks (NetworkSampler), on random forests, on a graph with a
loop, with tied crossing angles and on a real DEM's networks."""

import numpy as np
import pytest

from terrasynth_core.features import extract_features
from terrasynth_core.features.graph import FeatureGraph, FeatureNode, FeaturePath
from terrasynth_core.features.samples import example_samples, walked_example_samples


def assert_same_samples(graph, radius, spacing):
    expected = walked_example_samples(graph, radius, spacing)
    got = example_samples(graph, radius, spacing)
    assert len(got) == len(expected)
    for a, b in zip(got, expected):
        assert a.kind == b.kind
        np.testing.assert_array_equal(a.center, b.center)
        assert a.crossings.shape == b.crossings.shape
        np.testing.assert_array_equal(a.crossings, b.crossings)
    return got


def random_forest(rng, n_nodes, *, loop=False):
    """A random tree of wiggly paths (some shorter than a disc, some longer)."""
    position = rng.uniform(0, 200, size=(n_nodes, 2))
    edges = [(int(rng.integers(0, i)), i) for i in range(1, n_nodes)]
    if loop:
        edges.append((0, n_nodes - 1))
    degree = np.bincount(np.ravel(edges), minlength=n_nodes)
    nodes = tuple(FeatureNode(i, float(r), float(c), "branch" if d >= 3 else "end", int(d))
                  for i, ((r, c), d) in enumerate(zip(position, degree)))
    paths = []
    for a, b in edges:
        n = max(2, int(np.hypot(*(position[b] - position[a]))))
        t = np.linspace(0, 1, n)[:, None]
        points = position[a] + t * (position[b] - position[a])
        points[1:-1] += rng.normal(0, 1.5, size=(n - 2, 2))
        paths.append(FeaturePath(a, b, points))
    return FeatureGraph("ridge", (200, 200), nodes, tuple(paths))


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("radius,spacing", [(40.0, 20.0), (12.0, 5.0), (3.5, 6.0)])
def test_random_forests_same_samples(seed, radius, spacing):
    graph = random_forest(np.random.default_rng(seed), 60)
    assert graph.is_acyclic()
    samples = assert_same_samples(graph, radius, spacing)
    assert len(samples) > 60  # nodes and path points


def test_graph_with_a_loop_is_walked():
    graph = random_forest(np.random.default_rng(7), 30, loop=True)
    assert not graph.is_acyclic()
    assert_same_samples(graph, 25.0, 10.0)


def test_tied_crossing_angles_keep_the_walk_order():
    # Two paths from node 0 over the same points leave the disc at the
    # same point: only the walk order separates their crossings.
    line = np.stack([np.zeros(30), np.arange(30.0)], axis=1)
    nodes = (FeatureNode(0, 0.0, 0.0, "end", 2), FeatureNode(1, 0.0, 29.0, "end", 1),
             FeatureNode(2, 0.0, 29.0, "end", 1))
    graph = FeatureGraph("valley", (10, 40), nodes, (FeaturePath(0, 1, line), FeaturePath(0, 2, line.copy())))
    samples = assert_same_samples(graph, 10.0, 5.0)
    assert samples[0].degree == 2 and np.array_equal(samples[0].crossings[0], samples[0].crossings[1])


def test_empty_graph_has_no_samples():
    assert example_samples(FeatureGraph("ridge", (5, 5), (), ()), 10.0, 5.0) == []


@pytest.mark.parametrize("dem", ["white_mountains", "lowland"])
def test_dem_networks_same_samples(dem, request):
    maps = extract_features(request.getfixturevalue(dem))
    for graph in (maps.ridges, maps.valleys):
        assert len(assert_same_samples(graph, 40.0, 20.0)) > 20
