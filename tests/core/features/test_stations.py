"""Stations: where a sample's feature line crosses the circle of half the
patch's inscribed radius, on the route to each of its crossings."""

from __future__ import annotations

import numpy as np

from terrasynth_core.features.graph import FeatureGraph, FeatureNode, FeaturePath
from terrasynth_core.features.samples import example_samples
from terrasynth_core.features.stations import LineStations

RADIUS = 20.0


def _graph(paths: list[np.ndarray], kind: str = "ridge") -> FeatureGraph:
    """A graph of the given polylines; endpoints that coincide are one node."""
    nodes: list[tuple[float, float]] = []

    def node(p):
        for i, q in enumerate(nodes):
            if np.hypot(*(np.asarray(q) - p)) < 1e-9:
                return i
        nodes.append((float(p[0]), float(p[1])))
        return len(nodes) - 1

    links = [(node(pts[0]), node(pts[-1]), pts) for pts in paths]
    degree = np.bincount([a for a, _, _ in links] + [b for _, b, _ in links], minlength=len(nodes))
    made = tuple(FeatureNode(i, r, c, "branch" if degree[i] >= 3 else "end", int(degree[i]))
                 for i, (r, c) in enumerate(nodes))
    return FeatureGraph(kind, (200, 200), made, tuple(FeaturePath(a, b, pts) for a, b, pts in links))


def _line(start, end, n=200) -> np.ndarray:
    return np.linspace(start, end, n)


def test_a_straight_line_has_its_stations_halfway_to_each_crossing():
    graph = _graph([_line((100.0, 20.0), (100.0, 180.0))])
    stations = LineStations(graph, RADIUS)
    for sample in example_samples(graph, RADIUS, RADIUS):
        got = stations.inner(sample.center, sample.crossings)
        want = sample.center + 0.5 * (sample.crossings - sample.center)
        np.testing.assert_allclose(got, want, atol=1e-6)


def test_stations_follow_a_bent_line_not_the_chord():
    # A line along the row 100 that bends up by 45 degrees at column 100:
    # from a sample at the bend the route to the upper crossing leaves the
    # chord, and its station lies on the line.
    flat = _line((100.0, 40.0), (100.0, 100.0), 61)
    up = np.array([[100.0 - t, 100.0 + t] for t in np.linspace(0, 60, 121)])
    graph = _graph([np.vstack([flat, up[1:]])])
    stations = LineStations(graph, RADIUS)
    centre = np.array([100.0, 100.0])
    routes = stations.routes(centre)
    crossings = np.array([e for e, _ in routes])
    got = stations.inner(centre, crossings[::-1])  # any order of crossings
    np.testing.assert_allclose(np.hypot(*(got - centre).T), 0.5 * RADIUS, atol=1e-6)
    along_up = np.abs((got[:, 0] - 100.0) + (got[:, 1] - 100.0)) < 1e-6  # on the 45-degree arm
    assert along_up.sum() == 1 and not along_up[np.argmax(crossings[::-1][:, 0])]


def test_a_station_two_routes_share_is_not_used():
    # A fork beyond the station circle: both crossings are reached through
    # one station, which cannot stand for either alone.
    trunk = _line((100.0, 100.0), (100.0, 115.0), 31)
    left = _line((100.0, 115.0), (80.0, 140.0), 60)
    right = _line((100.0, 115.0), (120.0, 140.0), 60)
    back = _line((100.0, 100.0), (100.0, 60.0), 80)
    graph = _graph([trunk, left, right, back])
    stations = LineStations(graph, RADIUS)
    centre = np.array([100.0, 100.0])
    crossings = np.array([e for e, _ in stations.routes(centre)])
    assert len(crossings) == 3
    got = stations.inner(centre, crossings)
    usable = ~np.isnan(got).any(axis=1)
    assert usable.sum() == 1  # only the route back along the row
    np.testing.assert_allclose(got[usable][0], [100.0, 90.0], atol=1e-6)


def test_a_centre_off_the_network_has_no_stations():
    graph = _graph([_line((100.0, 20.0), (100.0, 180.0))])
    got = LineStations(graph, RADIUS).inner(np.array([50.0, 50.0]), np.array([[30.0, 50.0], [70.0, 50.0]]))
    assert np.isnan(got).all()


def test_stations_on_a_stored_point_index_answer_as_those_made_in_memory():
    """An example's point index is stored and mapped (``keep``): read back
    by a later process, it finds every centre, node or path point, as one
    made in memory does."""
    from terrasynth_core.exemplars import cache

    trunk = _line((100.0, 20.0), (100.0, 180.0), 4001)  # enough points for a file of its own
    branch = _line((100.0, 100.0), (20.0, 100.0), 2000)
    graph = _graph([trunk[:2001], trunk[2000:], branch])

    def keep(name, make, dtype):
        return cache.kept_array(f"test-stations-{name}", make, name=name, dtype=dtype)

    plain, first, again = LineStations(graph, RADIUS), LineStations(graph, RADIUS, keep=keep), \
        LineStations(graph, RADIUS, keep=keep)
    for centre in (np.array([100.0, 100.0]), trunk[500], branch[1200], np.array([50.0, 50.0])):
        routes = [s.routes(centre) for s in (plain, first, again)]
        assert len(routes[0]) == len(routes[1]) == len(routes[2])
        for (c0, s0), (c1, s1), (c2, s2) in zip(*routes):
            np.testing.assert_array_equal(c0, c1), np.testing.assert_array_equal(c0, c2)
            np.testing.assert_array_equal(s0, s2)
    assert len(plain.routes(np.array([100.0, 100.0]))) == 3 and len(plain.routes(trunk[500])) == 2
    assert isinstance(again._at[0], np.memmap)
