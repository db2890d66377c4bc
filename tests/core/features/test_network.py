"""The fast paths of the mask-to-graph pipeline against plain references.

PPA's output must not change with the speed-ups (issue 11), so each shortcut
of :mod:`terrasynth_core.features.network` is checked here against the
straightforward computation it replaces, on random masks with many ties:
the spanning forest against a plain Kruskal, a branch-reduction step
against a full recompression, the packed-key sort against a stable sort.
"""

import numpy as np
import pytest

from terrasynth_core.features.network import (
    _FORWARD_OFFSETS,
    _drop,
    _spurs_to_remove,
    _strongest_first,
    compress_chains,
    spanning_forest,
)


def _random_masks(count: int, seed: int):
    rng = np.random.default_rng(seed)
    for i in range(count):
        shape = tuple(int(v) for v in rng.integers(2, 24, 2))
        mask = rng.random(shape) < rng.uniform(0.2, 1.0)
        # Whole numbers give many equally strong links (ties); fractions none.
        strength = rng.integers(0, 3, shape).astype(np.float32) if i % 2 else rng.random(shape).astype(np.float32)
        yield mask, strength


def _kruskal(mask: np.ndarray, strength: np.ndarray) -> set[tuple[int, int]]:
    """The maximum spanning forest by the definition spanning_forest documents:
    8-adjacent links, the weaker of two crossing diagonals dropped, links
    taken strongest first, ties in the order of _FORWARD_OFFSETS then
    row-major, one union-find in Python."""
    rows, cols = mask.shape
    index = -np.ones(mask.shape, dtype=int)
    index[mask] = np.arange(mask.sum())
    s = np.where(mask, strength, 0).astype(np.float64)
    links = []
    for direction, (dr, dc) in enumerate(_FORWARD_OFFSETS):
        for r in range(rows - dr):
            for c in range(max(0, -dc), cols - max(0, dc)):
                if not (mask[r, c] and mask[r + dr, c + dc]):
                    continue
                if dr and dc:
                    c0 = min(c, c + dc)  # the 2x2 block's left column
                    if mask[r, c0] and mask[r, c0 + 1] and mask[r + 1, c0] and mask[r + 1, c0 + 1]:
                        down_right = s[r, c0] + s[r + 1, c0 + 1]
                        down_left = s[r, c0 + 1] + s[r + 1, c0]
                        if (dc > 0 and down_right < down_left) or (dc < 0 and down_left <= down_right):
                            continue
                links.append((-(s[r, c] + s[r + dr, c + dc]), direction, r, c, index[r, c], index[r + dr, c + dc]))
    parent = list(range(int(mask.sum())))

    def root(v):
        while parent[v] != v:
            parent[v] = parent[parent[v]]
            v = parent[v]
        return v

    tree = set()
    for *_, a, b in sorted(links):
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[ra] = rb
            tree.add((a, b))
    return tree


def test_spanning_forest_is_kruskals_forest():
    for mask, strength in _random_masks(60, seed=11):
        forest = spanning_forest(mask, strength)
        assert {tuple(e) for e in forest.edges.tolist()} == _kruskal(mask, strength)
        # Listed by first then second pixel, as before the speed-up.
        assert (np.lexsort(forest.edges.T[::-1]) == np.arange(len(forest.edges))).all()


def _same_chains(a, b) -> bool:
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in ("pixels", "offsets", "start", "end", "length"))


def test_dropping_chains_equals_recompressing_what_is_left():
    rng = np.random.default_rng(5)
    for mask, strength in _random_masks(60, seed=12):
        forest = spanning_forest(mask, strength)
        chains = compress_chains(forest.edges, forest.coords)
        for remove in (rng.random(len(chains)) < 0.3, _spurs_to_remove(chains, len(forest.coords), 4.0)):
            expected = compress_chains(chains.edges(~remove), forest.coords)
            assert _same_chains(_drop(chains, remove, forest.coords), expected)


def test_chains_start_at_their_first_listed_end_and_do_not_depend_on_pixel_numbers_otherwise():
    # A path 0-1-2-3 listed from its middle, the second link reversed.
    coords = np.array([[0, 0], [0, 1], [0, 2], [0, 3]])
    chains = compress_chains(np.array([[2, 3], [2, 1], [1, 0]]), coords)
    assert chains.pixels.tolist() == [3, 2, 1, 0]  # from the end listed first
    assert chains.length.tolist() == [3.0]
    # Two one-link chains at a branch come after the chain with inner pixels,
    # in the order they are listed.
    coords = np.array([[1, 1], [0, 1], [2, 1], [1, 2], [1, 3]])
    chains = compress_chains(np.array([[0, 2], [0, 1], [0, 3], [3, 4]]), coords)
    assert [chains.pixels[a:b].tolist() for a, b in zip(chains.offsets[:-1], chains.offsets[1:])] == [
        [0, 3, 4], [0, 2], [0, 1]]


@pytest.mark.parametrize("values", [
    np.array([3.0, 1.0, 3.0, -2.0, 1.0, 0.0]),
    np.array([0.5, 0.25, 0.5, 1e-3]),
    np.array([1e300, 1.0, 1e300]),
    np.array([]),
])
def test_strongest_first_is_a_stable_descending_sort(values):
    assert _strongest_first(values).tolist() == np.argsort(-values, kind="stable").tolist()


def test_strongest_first_is_a_stable_sort_from_the_largest():
    """The quick paths (packed integer keys; the default sort with its runs
    of equal values put back in index order) give the stable sort's order."""
    from terrasynth_core.features.network import _strongest_first

    rng = np.random.default_rng(1)
    for trial in range(60):
        n = int(rng.integers(0, 2000))
        whole = rng.integers(-20, 20, n).astype(float)
        with_nan = rng.random(n)
        with_nan[rng.random(n) < 0.1] = np.nan
        cases = (whole, whole * 0.37 + (rng.random(n) < 0.5) * rng.random(n), rng.random(n), with_nan)
        for strength in cases:
            if trial % 3 == 0:
                strength[rng.random(n) < 0.3] = 0.0
                strength[rng.random(n) < 0.2] = -0.0
            np.testing.assert_array_equal(_strongest_first(strength), np.argsort(-strength, kind="stable"))


def test_joined_chains_are_the_walked_links(lowland, monkeypatch):
    """Branch reduction joins chains at the chain level: the same runs, from
    the same end, as walking their pixel links again."""
    from terrasynth_core.features import network
    from terrasynth_core.features.ppa import extract_features

    join = network._join_chains
    checked = []

    def join_and_check(chains, joined, is_node):
        mask = np.zeros(len(chains), dtype=bool)
        mask[joined] = True
        walked = network._walk_chains(chains.edges(mask), is_node)[:2]
        got = join(chains, joined, is_node)

        def runs(laid, offsets):
            return sorted(tuple(laid[offsets[i] : offsets[i + 1]].tolist()) for i in range(len(offsets) - 1))

        assert runs(*got) == runs(*walked)
        checked.append(len(joined))
        return got

    monkeypatch.setattr(network, "_join_chains", join_and_check)
    extract_features(lowland)
    assert len(checked) >= 2 and sum(checked) > 20


def test_small_components_dropped_before_compressing_give_the_same_chains(lowland, monkeypatch):
    """Dropping the small components' links before compressing the forest
    gives the chains (pixels, order, lengths to the bit) of compressing it
    all and dropping their chains after."""
    from terrasynth_core.features import network
    from terrasynth_core.features.ppa import auto_min_drop, profile_targets

    heights = np.asarray(lowland.heights, dtype=np.float32)
    targets = profile_targets(heights, profile_length=7, min_drop=auto_min_drop(heights, 7, 0.15))
    forest = spanning_forest(targets, heights)
    options = dict(prune_length=12.0, prune_iterations=3, min_component_length=30.0)
    assert network._small_forest_components(forest, 30.0, None).any()
    early = network.reduce_branches(forest, **options)
    monkeypatch.setattr(network, "_small_forest_components", lambda *args: None)
    late = network.reduce_branches(forest, **options)
    assert len(early) == len(late) > 20
    for name in ("pixels", "offsets", "start", "end", "length"):
        np.testing.assert_array_equal(getattr(early, name), getattr(late, name))


def test_a_component_as_long_as_the_limit_is_left_to_the_chains():
    from terrasynth_core.features import network

    mask = np.zeros((5, 40), dtype=bool)
    mask[2, 3:34] = True  # 31 pixels, 30 straight links: exactly 30 cells
    forest = spanning_forest(mask, np.ones(mask.shape))
    assert network._small_forest_components(forest, 30.0, None) is None
    assert not network._small_forest_components(forest, 29.0, None).any()
    assert network._small_forest_components(forest, 31.0, None).all()


def _graph_record(graph) -> tuple:
    """Everything a FeatureGraph holds, positions to the bit."""
    return (graph.kind, graph.shape, graph.nodes,
            [(p.start, p.end, np.ascontiguousarray(p.points).tobytes()) for p in graph.paths])


def test_a_graph_made_on_the_masks_box_is_the_graph_of_the_whole_grid(monkeypatch):
    """feature_graph_from_mask works on the mask's bounding box (a sketch's
    strokes cover a few percent of it); moved back, the graph is the one
    the whole grid gives, to the bit, wherever the strokes lie (touching
    the grid's border or not)."""
    from scipy import ndimage

    from terrasynth_core.features import network

    rng = np.random.default_rng(11)
    options = dict(kind="ridge", prune_length=6.0, prune_iterations=3, min_component_length=8.0,
                   junction_merge_distance=4.0, smoothing=5)
    cases = []
    for i in range(12):
        shape = tuple(int(v) for v in rng.integers(30, 120, 2))
        field = ndimage.gaussian_filter(rng.random(shape), 2.0)
        mask = ndimage.binary_opening(field > np.quantile(field, 0.85)) if i % 3 else field > np.quantile(field, 0.9)
        if i % 4 == 0:  # away from the border
            mask[:5], mask[-5:], mask[:, :5], mask[:, -5:] = False, False, False, False
        from skimage.morphology import skeletonize

        cases.append((skeletonize(mask), rng.random(shape)))
    boxed = [_graph_record(network.feature_graph_from_mask(m, s, **options)) for m, s in cases]
    monkeypatch.setattr(network, "_crop_box", lambda mask: None)
    whole = [_graph_record(network.feature_graph_from_mask(m, s, **options)) for m, s in cases]
    assert boxed == whole
    assert sum(len(r[3]) for r in whole) > 30  # real graphs, not empty ones
