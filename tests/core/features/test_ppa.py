"""PPA ridge/valley extraction and the shared graph pipeline."""

import numpy as np
import pytest

from terrasynth_core import HeightField, ParamsError
from terrasynth_core.measures import feature_tpi_score
from terrasynth_core.features import FeatureGraph, PPAParams, extract_features, extract_ridges, extract_valleys
from terrasynth_core.features.network import compress_chains, graph_mask, spanning_forest
from terrasynth_core.features.ppa import profile_targets
from terrasynth_core.io import load_dem

ROWS, COLS = 120, 160
SLOPE = 0.4  # crest line: row = 30 + SLOPE * col


def _distance_to_line() -> np.ndarray:
    rr, cc = np.mgrid[0:ROWS, 0:COLS].astype(np.float32)
    return (rr - (30 + SLOPE * cc)) / np.hypot(1, SLOPE)


def _offset_from_line(points: np.ndarray) -> np.ndarray:
    return np.abs(points[:, 0] - (30 + SLOPE * points[:, 1])) / np.hypot(1, SLOPE)


@pytest.fixture
def gaussian_ridge() -> np.ndarray:
    """A straight Gaussian ridge, 500 m high, with 0.5 m of noise."""
    noise = np.random.default_rng(0).standard_normal((ROWS, COLS))
    return (100 + 500 * np.exp(-((_distance_to_line() / 12) ** 2)) + 0.5 * noise).astype(np.float32)


@pytest.fixture
def v_valley() -> np.ndarray:
    """A straight V-shaped valley, sides at 20 m per cell, tilted along its axis."""
    cols = np.arange(COLS, dtype=np.float32)[None, :]
    return (20 * np.abs(_distance_to_line()) + 5 * cols / COLS).astype(np.float32)


def _real(dems_dir, name: str) -> np.ndarray:
    file, window = REAL_CROPS[name]
    return np.asarray(load_dem(dems_dir / file).heights)[window]


REAL_CROPS = {
    "bigtujunga": ("bigtujunga.tif", np.s_[0:300, 300:700]),
    "N44W072": ("N44W072.hgt", np.s_[700:1000, 300:600]),
    "SainteHelens": ("SainteHelens.dem", np.s_[:, :]),
    "Mandakini": ("Mandakini.bil", np.s_[:, :]),
}


def _check_graph(graph: FeatureGraph) -> None:
    """Acyclic, node types and degrees consistent with the paths."""
    assert graph.is_acyclic()
    ends = np.zeros(len(graph.nodes), dtype=int)
    for path in graph.paths:
        ends[path.start] += 1
        ends[path.end] += 1
        assert path.start != path.end
        assert len(path.points) >= 2
        start, end = graph.nodes[path.start], graph.nodes[path.end]
        np.testing.assert_allclose(path.points[0], (start.row, start.col), atol=1e-9)
        np.testing.assert_allclose(path.points[-1], (end.row, end.col), atol=1e-9)
    for node in graph.nodes:
        assert node.degree == ends[node.id]
        assert node.degree != 2 and node.degree >= 1
        assert node.type == ("end" if node.degree == 1 else "branch")


# -- synthetic terrain --------------------------------------------------------
@pytest.mark.parametrize(("terrain", "kind", "other"),
                         [("gaussian_ridge", "ridges", "valleys"), ("v_valley", "valleys", "ridges")])
def test_straight_feature_gives_one_path_along_its_line(request, terrain, kind, other):
    maps = extract_features(request.getfixturevalue(terrain))
    graph = getattr(maps, kind)
    _check_graph(graph)
    assert len(graph.paths) == 1
    assert graph.count("end") == 2 and graph.count("branch") == 0
    assert _offset_from_line(graph.paths[0].points).max() <= 2.0
    assert graph.paths[0].length >= 0.9 * COLS * np.hypot(1, SLOPE)
    assert not getattr(maps, other).paths


def test_kind_selects_one_graph(gaussian_ridge):
    only = extract_features(gaussian_ridge, kind="ridge")
    assert only.ridges.paths and only.valleys.kind == "valley" and not only.valleys.paths
    assert extract_ridges(gaussian_ridge).kind == "ridge"
    assert extract_valleys(-gaussian_ridge).paths
    assert not extract_features(gaussian_ridge, kind="valley").ridges.paths


def test_heightfield_input_and_no_mutation(gaussian_ridge):
    before = gaussian_ridge.copy()
    from_array = extract_ridges(gaussian_ridge)
    from_field = extract_ridges(HeightField(gaussian_ridge, cell_size=(30.0, 30.0)))
    np.testing.assert_array_equal(gaussian_ridge, before)
    np.testing.assert_allclose(from_array.paths[0].points, from_field.paths[0].points)


def test_mask_limits_where_features_lie(gaussian_ridge):
    mask = np.zeros(gaussian_ridge.shape, dtype=bool)
    mask[:, 80:] = True
    ridges = extract_ridges(gaussian_ridge, mask=mask)
    assert len(ridges.paths) == 1
    assert ridges.paths[0].points[:, 1].min() >= 79.5


def test_integer_heights_are_accepted(gaussian_ridge):
    ridges = extract_ridges(np.rint(gaussian_ridge).astype(np.int16))
    assert len(ridges.paths) == 1


# -- profile recognition -----------------------------------------------------
def test_profile_targets_need_a_lower_cell_on_both_sides():
    z = np.zeros((7, 7), dtype=np.float32)
    z[3, :] = 10.0  # an E-W wall: lower cells north and south of it
    targets = profile_targets(z, profile_length=3, min_drop=0.0)
    assert targets[3].all() and targets.sum() == 7
    assert not profile_targets(z, profile_length=3, min_drop=10.5).any()
    assert profile_targets(z, profile_length=3, min_drop=10.0)[3].all()


def test_nan_is_never_a_target_and_never_lower():
    z = np.full((9, 9), 5.0, dtype=np.float32)
    z[3:6, 3:6] = np.nan
    z[4, 4] = 6.0  # a bump whose only neighbours are nodata
    assert not profile_targets(z, profile_length=3, min_drop=0.0).any()
    w = np.zeros((9, 9), dtype=np.float32)
    w[4, :] = 10.0
    w[4, 2] = np.nan
    targets = profile_targets(w, profile_length=3, min_drop=0.0)
    assert not targets[4, 2] and targets[4, 3]


def test_nodata_heights_are_handled(gaussian_ridge):
    z = gaussian_ridge.copy()
    z[:, :20] = np.nan
    z[50:60, 100:110] = np.nan
    ridges = extract_ridges(z)
    _check_graph(ridges)
    assert ridges.paths
    for path in ridges.paths:
        cells = np.rint(path.points).astype(int)
        assert not np.isnan(z[cells[:, 0], cells[:, 1]]).any()


# -- real DEMs ---------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(REAL_CROPS))
def test_real_dem_graphs_are_clean_forests(dems_dir, name):
    z = _real(dems_dir, name)
    maps = extract_features(z)
    for graph in (maps.ridges, maps.valleys):
        _check_graph(graph)
        assert graph.count("branch") > 0 and graph.count("end") > 5
        assert graph.shape == z.shape


@pytest.mark.parametrize("name", ["bigtujunga", "N44W072", "SainteHelens"])
def test_real_ridges_are_high_and_valleys_low(dems_dir, name):
    z = _real(dems_dir, name)
    maps = extract_features(z)
    # TPI radius 12 is independent of the 7-cell profile length.
    assert feature_tpi_score(z, maps.ridges, radius=12) > 0.7
    assert feature_tpi_score(z, maps.valleys, radius=12) < -0.7


# -- the shared pipeline -----------------------------------------------------
def test_spanning_forest_breaks_loops_at_the_weakest_link():
    mask = np.zeros((9, 9), dtype=bool)
    mask[2, 2:7] = mask[6, 2:7] = mask[2:7, 2] = mask[2:7, 6] = True  # a square loop
    strength = np.full(mask.shape, 10.0)
    strength[6, 4] = 1.0  # the weak spot
    forest = spanning_forest(mask, strength)
    assert len(forest.edges) == mask.sum() - 1
    weak = np.flatnonzero((forest.coords == (6, 4)).all(axis=1))[0]
    assert np.count_nonzero(forest.edges == weak) == 1  # became an end of the line


def test_spanning_forest_drops_the_weaker_crossing_diagonal():
    mask = np.ones((2, 2), dtype=bool)
    strength = np.array([[5.0, 1.0], [1.0, 5.0]])
    forest = spanning_forest(mask, strength)
    diagonal = {tuple(sorted(e)) for e in forest.edges if np.abs(np.diff(forest.coords[e], axis=0)).sum() == 2}
    assert diagonal == {(0, 3)}  # (0,0)-(1,1) kept, the weak (0,1)-(1,0) never used


def test_chains_cover_the_forest_in_order():
    rng = np.random.default_rng(3)
    mask = rng.random((60, 60)) < 0.55
    strength = rng.random((60, 60))
    forest = spanning_forest(mask, strength)
    chains = compress_chains(forest.edges, forest.coords)
    linked = {tuple(sorted(e)) for e in forest.edges.tolist()}
    walked = {tuple(sorted(e)) for e in chains.edges().tolist()}
    assert walked == linked  # every link in exactly the chains' walks
    assert len(chains.edges()) == len(forest.edges)
    degree = np.bincount(forest.edges.ravel(), minlength=len(forest.coords))
    assert (degree[chains.start] != 2).all() and (degree[chains.end] != 2).all()
    for i in range(len(chains)):
        inner = chains.pixels[chains.offsets[i] + 1 : chains.offsets[i + 1] - 1]
        assert (degree[inner] == 2).all()


def test_graph_mask_matches_rasterize(gaussian_ridge):
    graph = extract_ridges(gaussian_ridge)
    mask = graph_mask(graph)
    reference = graph.rasterize()
    assert mask.sum() > 100
    assert (mask ^ reference).sum() <= 0.02 * reference.sum()


# -- parameters --------------------------------------------------------------
@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("profile_length", 6),
        ("profile_length", 1),
        ("profile_length", 17),
        ("profile_length", 7.0),
        ("min_drop", -1.0),
        ("min_drop", float("nan")),
        ("relative_drop", 1.5),
        ("prune_length", -2),
        ("prune_iterations", -1),
        ("prune_iterations", True),
        ("min_component_length", "10"),
        ("smoothing", 2.5),
        ("junction_merge_distance", float("inf")),
    ],
)
def test_params_validation_names_the_field(field, value):
    with pytest.raises(ParamsError, match=f"PPAParams.{field}"):
        PPAParams(**{field: value})


def test_defaults_are_valid_and_documented():
    params = PPAParams()
    assert params.profile_length % 2 == 1 and params.min_drop is None
    assert PPAParams.__doc__ and all(name in PPAParams.__doc__ for name in params.__dataclass_fields__)


def test_bad_arguments_raise_params_error(gaussian_ridge):
    with pytest.raises(ParamsError, match="kind"):
        extract_features(gaussian_ridge, kind="ridges")
    with pytest.raises(ParamsError, match="mask"):
        extract_features(gaussian_ridge, mask=np.ones((3, 3), bool))
    with pytest.raises(ParamsError, match="2-D"):
        extract_features(np.zeros(10))
    with pytest.raises(ParamsError, match="infinite"):
        extract_features(np.full((5, 5), np.inf))
    with pytest.raises(ParamsError, match="PPAParams"):
        extract_features(gaussian_ridge, params={"profile_length": 5})


def _graph_digest(graph):
    nodes = [(n.id, n.row, n.col, n.type, n.degree) for n in graph.nodes]
    return repr((graph.kind, graph.shape, nodes, [(p.start, p.end, p.points.tobytes()) for p in graph.paths]))


def test_two_threads_give_the_graphs_of_one(white_mountains, monkeypatch):
    """Ridges and valleys on two threads (large grids) are exactly those
    extracted one kind at a time."""
    import terrasynth_core.features.ppa as ppa

    monkeypatch.setattr(ppa, "THREADED_CELLS", 0)
    monkeypatch.setattr(ppa, "spare_core", lambda: True)
    both = extract_features(white_mountains)
    ridges = extract_features(white_mountains, kind="ridge").ridges
    valleys = extract_features(white_mountains, kind="valley").valleys
    assert len(both.ridges.paths) > 50 and len(both.valleys.paths) > 50
    assert _graph_digest(both.ridges) == _graph_digest(ridges)
    assert _graph_digest(both.valleys) == _graph_digest(valleys)


def test_spare_core_follows_the_load(monkeypatch):
    import terrasynth_core.features.ppa as ppa

    monkeypatch.setattr(ppa.os, "cpu_count", lambda: 2)
    monkeypatch.setattr(ppa.os, "getloadavg", lambda: (0.7, 0.5, 0.5))
    assert ppa.spare_core()
    monkeypatch.setattr(ppa.os, "getloadavg", lambda: (6.0, 5.0, 4.0))
    assert not ppa.spare_core()
    monkeypatch.setattr(ppa.os, "cpu_count", lambda: 1)
    monkeypatch.setattr(ppa.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    assert not ppa.spare_core()
