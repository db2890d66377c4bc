"""From a mask of feature pixels to a :class:`FeatureGraph`.

The pipeline shared by PPA (:mod:`terrasynth_core.features.ppa`, where the
pixels are the profile *targets* weighted by height) and sketch analysis
(:mod:`terrasynth_core.features.sketch`, where they are skeleton pixels
weighted by stroke thickness):

1. :func:`spanning_forest` links 8-adjacent pixels, drops the weaker of two
   crossing diagonals and keeps a maximum spanning forest (Kruskal), which
   breaks every closed loop at its weakest segment (PPA's "polygon breaking",
   done in one pass as Bangay et al. 2010 suggest).
2. :func:`compress_chains` turns the pixel forest into *chains*: maximal runs
   of degree-2 pixels between two node pixels (degree 1 or >= 3).
3. Branch reduction alternates with compression: short end branches (spurs)
   are removed and small isolated components dropped, a few times over.
4. :func:`chains_to_graph` merges branch points joined by very short chains
   into one node, smooths the polylines with their ends fixed and builds the
   :class:`~terrasynth_core.features.graph.FeatureGraph`.

Everything is vectorized over pixels; Python only loops over iterations and,
at the very end, over the surviving paths to build the graph objects.

References
----------
Chang, Y.-C., Song, G.-S., Hsu, S.-K. (1998). Automatic extraction of ridge
and valley axes using the profile recognition and polygon-breaking algorithm.
Computers & Geosciences 24(1):83-93.

Bangay, S., de Bruyn, D., Glass, K. (2010). Minimum spanning trees for valley
and ridge characterization in digital elevation maps. AFRIGRAPH 2010.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

from .graph import FeatureGraph, FeatureKind, FeatureNode, FeaturePath

#: Neighbour offsets ``(drow, dcol)`` that enumerate each 8-adjacent pair once.
_FORWARD_OFFSETS = ((0, 1), (1, 0), (1, 1), (1, -1))


@dataclass(frozen=True, eq=False)
class PixelForest:
    """An acyclic graph on pixels.

    Parameters
    ----------
    coords : ndarray of int64, shape (n_pixels, 2)
        ``(row, col)`` of every pixel; pixel ids index this array.
    edges : ndarray of int64, shape (n_edges, 2)
        Pairs of pixel ids that are linked.
    """

    coords: np.ndarray
    edges: np.ndarray


@dataclass(frozen=True, eq=False)
class Chains:
    """Maximal pixel runs between node pixels of a :class:`PixelForest`.

    Parameters
    ----------
    pixels : ndarray of int64, shape (n,)
        Pixel ids of all chains, concatenated; each chain is ordered from its
        ``start`` node to its ``end`` node, both included.
    offsets : ndarray of int64, shape (n_chains + 1,)
        Chain ``i`` is ``pixels[offsets[i]:offsets[i + 1]]``.
    start, end : ndarray of int64, shape (n_chains,)
        Node pixel ids at either end (degree 1 or >= 3 in the forest).
    length : ndarray of float64, shape (n_chains,)
        Polyline length in cells (steps of 1 or sqrt(2)).
    """

    pixels: np.ndarray
    offsets: np.ndarray
    start: np.ndarray
    end: np.ndarray
    length: np.ndarray

    def __len__(self) -> int:
        return len(self.start)

    def node_degree(self, n_pixels: int) -> np.ndarray:
        """Number of chains at each pixel, shape (n_pixels,)."""
        return np.bincount(np.concatenate([self.start, self.end]), minlength=n_pixels)

    def chain_index(self) -> np.ndarray:
        """Chain id of every entry of :attr:`pixels`, shape (n,)."""
        return np.repeat(np.arange(len(self)), np.diff(self.offsets))

    def edges(self, keep: np.ndarray | None = None) -> np.ndarray:
        """Pixel links of the chains (or of the chains where ``keep``), shape (m, 2)."""
        chain = self.chain_index()
        same = chain[1:] == chain[:-1]
        if keep is not None:
            same &= keep[chain[1:]]
        return np.stack([self.pixels[:-1][same], self.pixels[1:][same]], axis=1)


def spanning_forest(mask: np.ndarray, strength: np.ndarray) -> PixelForest:
    """Maximum spanning forest of the 8-adjacency graph of ``mask``.

    Parameters
    ----------
    mask : ndarray of bool, shape (rows, cols)
        Pixels to link.
    strength : ndarray of float, shape (rows, cols)
        Per-pixel strength; a link is as strong as the sum of its two ends
        (PPA: the heights of the segment's ends).  Read only under ``mask``.

    Returns
    -------
    PixelForest
        The strongest acyclic subset of links; isolated pixels are kept in
        ``coords`` but have no edge.

    Notes
    -----
    Where both diagonals of a 2x2 block are present the weaker is dropped
    first, so no two links cross.  Among equally strong links orthogonal ones
    win: on a staircase of pixels that keeps the middle pixel on the line
    instead of hanging it off as a one-pixel spur.
    """
    rows, cols = mask.shape
    coords = np.argwhere(mask)
    n = len(coords)
    # Flat (row-major) cell numbers throughout: a neighbour is a fixed
    # offset away, and 1-D gathers are the quickest numpy has.
    index = np.full(mask.size, -1, dtype=np.int64)
    index[mask.ravel()] = np.arange(n)
    s = np.where(mask, strength, 0).astype(np.float64).ravel()

    # Links by direction (_FORWARD_OFFSETS), on the grid of their first pixel.
    present = []
    for dr, dc in _FORWARD_OFFSETS:
        src = (slice(0, rows - dr), slice(max(0, -dc), cols - max(0, dc)))
        dst = (slice(dr, rows), slice(max(0, dc), cols - max(0, -dc)))
        linked = np.zeros(mask.shape, dtype=bool)
        linked[src] = mask[src] & mask[dst]
        present.append(linked)
    # Both diagonals of a full 2x2 block: keep only the stronger one.
    block = np.zeros(mask.shape, dtype=bool)  # by the block's top-left pixel
    block[:-1, :-1] = present[2][:-1, :-1] & present[3][:-1, 1:]
    at = np.flatnonzero(block)
    se = s[at] + s[at + cols + 1]
    sw = s[at + 1] + s[at + cols]
    present[2].ravel()[at[se < sw]] = False
    present[3].ravel()[at[sw <= se] + 1] = False
    _drop_weakest_in_triangles(present, s, block)

    a_parts, b_parts, strength_parts = [], [], []
    for (dr, dc), linked in zip(_FORWARD_OFFSETS, present):
        at = np.flatnonzero(linked)
        to = at + (dr * cols + dc)
        a_parts.append(index[at])
        b_parts.append(index[to])
        strength_parts.append(s[at] + s[to])
    a = np.concatenate(a_parts)
    b = np.concatenate(b_parts)
    if len(a) == 0:
        return PixelForest(coords, np.empty((0, 2), dtype=np.int64))
    # Kruskal only needs the order of the links, so the cost is a rank:
    # strongest first, then in the order listed (orthogonal before diagonal:
    # _FORWARD_OFFSETS lists them first); ranks start at 1 because csgraph
    # treats a zero entry as "no link".
    cost = np.empty(len(a), dtype=np.float64)
    cost[_strongest_first(np.concatenate(strength_parts))] = np.arange(1, len(a) + 1)
    tree = minimum_spanning_tree(sparse.csr_matrix((cost, (a, b)), shape=(n, n))).tocoo()
    edges = np.stack([tree.row, tree.col], axis=1).astype(np.int64)
    return PixelForest(coords, edges)


def _strongest_first(strength: np.ndarray) -> np.ndarray:
    """Indices that sort ``strength`` (shape (n,), float64) from the largest
    down, equal values in their order; ``np.argsort(-strength, kind="stable")``.

    Whole-number strengths (integer DEMs such as SRTM tiles) take a quicker
    path: the value and the index packed into one distinct int64 key, which
    the default (unstable) sort orders the same way in half the time.  Other
    strengths (resampled examples) are sorted by the default sort too, a
    third of the stable sort's time, and only the runs of equal values are
    put back in index order.
    """
    n = len(strength)
    if n and np.abs(strength).max() * n < 2.0**52 and np.array_equal(strength, np.floor(strength)):
        return np.argsort((-strength).astype(np.int64) * n + np.arange(n))
    if np.isnan(strength).any():  # NaN is never equal to itself: no runs to repair
        return np.argsort(-strength, kind="stable")
    order = np.argsort(-strength)
    ordered = strength[order]
    tie = ordered[1:] == ordered[:-1]
    if tie.any():
        in_run = np.zeros(n, dtype=bool)
        in_run[1:] |= tie
        in_run[:-1] |= tie
        at = np.flatnonzero(in_run)
        run = np.cumsum(np.concatenate([[True], ~tie]))[at]
        # Runs are contiguous and numbered in order: sorting (run, index)
        # keys keeps every run in its place, its indices ascending.
        order[at] = np.sort(run * n + order[at]) % n
    return order


def _drop_weakest_in_triangles(present: list[np.ndarray], s: np.ndarray, block: np.ndarray) -> None:
    """Remove, in place, the weakest link of every triangle of links.

    The weakest link of a cycle is in no maximum spanning forest (when all
    links are ordered, as :func:`spanning_forest` orders them), so dropping
    it changes nothing but halves the links Kruskal has to sort on dense
    target areas (plateaus).

    Parameters
    ----------
    present : list of 4 ndarrays of bool, shape (rows, cols), C-contiguous
        Whether each link of :data:`_FORWARD_OFFSETS` leaves each pixel;
        updated.
    s : ndarray of float64, shape (rows * cols,)
        Pixel strengths, flat (row-major); a link's is the sum of its pixels'.
    block : ndarray of bool, shape (rows, cols)
        Scratch space, overwritten.

    Notes
    -----
    Ties between equally strong links go as in :func:`spanning_forest`:
    E-W links before N-S links before diagonals, and within a direction the
    upper, then the left one first; so in a 2x2 block every comparison is a
    fixed ``<`` or ``<=``.  Only the blocks holding a whole triangle are
    compared.
    """
    cols = present[0].shape[1]
    east, south, down_right, down_left = present
    # The 2x2 block with top-left pixel (r, c): its links, where present.
    top, bottom = east[:-1, :-1], east[1:, :-1]
    left, right = south[:-1, :-1], south[:-1, 1:]
    diagonal_se, diagonal_sw = down_right[:-1, :-1], down_left[:-1, 1:]
    drops = []
    # Each triangle: its links as (direction, row offset, col offset) of their
    # first pixel in the block, listed so that on a tie a later one is weaker.
    for whole, links in (
        (top & right & diagonal_se, ((0, 0, 0), (1, 0, 1), (2, 0, 0))),
        (bottom & left & diagonal_se, ((0, 1, 0), (1, 0, 0), (2, 0, 0))),
        (top & left & diagonal_sw, ((0, 0, 0), (1, 0, 0), (3, 0, 1))),
        (bottom & right & diagonal_sw, ((0, 1, 0), (1, 0, 1), (3, 0, 1))),
    ):
        block[:-1, :-1] = whole
        at = np.flatnonzero(block)  # flat number of the block's top-left pixel
        first = [at + (i * cols + j) for _, i, j in links]
        power = [s[f] + s[f + (_FORWARD_OFFSETS[k][0] * cols + _FORWARD_OFFSETS[k][1])]
                 for f, (k, _, _) in zip(first, links)]
        x, y, z = power
        weakest = ((x < y) & (x < z), (y <= x) & (y < z), (z <= x) & (z <= y))
        for (k, _, _), f, gone in zip(links, first, weakest):
            drops.append((k, f[gone]))
    for k, at in drops:
        present[k].ravel()[at] = False


def compress_chains(edges: np.ndarray, coords: np.ndarray) -> Chains:
    """Split a pixel forest into chains between its node pixels.

    Parameters
    ----------
    edges : ndarray of int64, shape (n_edges, 2)
        Links of an acyclic pixel graph.
    coords : ndarray of int, shape (n_pixels, 2)
        ``(row, col)`` of each pixel id.

    Returns
    -------
    Chains
        Each chain runs from the end whose link comes first in ``edges`` (on
        a one-link chain: ``edges[i, 0]``) to the other.  Chains with inner
        pixels come first, ordered by their smallest inner pixel id, then
        the one-link chains in the order of ``edges``.

    Notes
    -----
    Linear, no per-pixel Python.  Each link has two *ends* (slot ``2 i + j``
    is ``edges[i, j]``).  Walking a chain enters a link at one end, leaves it
    at the other and, unless that pixel is a node (degree 1 or >= 3), enters
    the next link at the pixel's other end.  Pointer jumping over these
    successor pointers (Wyllie's list ranking, only over the ends still
    walking) gives every end its distance to the end of its walk and the
    end it stops at, which places every pixel of every chain directly.
    """
    if len(edges) == 0:
        empty = np.empty(0, dtype=np.int64)
        return Chains(empty, np.zeros(1, dtype=np.int64), empty, empty, np.empty(0))
    is_node = np.bincount(edges.ravel(), minlength=len(coords)) != 2
    laid, chain_offsets, n_links, first = _walk_chains(edges, is_node)
    # Order: chains with inner pixels by their smallest one, then the
    # one-link chains by their first end.
    key = _inner_min(laid, chain_offsets)
    key = np.where(n_links > 1, key, len(coords) + first)
    return _chains_in_order(laid, chain_offsets[:-1], n_links + 1, key, coords)


def _walk_chains(edges: np.ndarray, is_node: np.ndarray, *, with_links: bool = False) -> tuple:
    """The chains of some links of a forest, split at the pixels where
    ``is_node`` (shape (n_pixels,): degree 1 or >= 3 in the whole forest),
    each laid out from its first end, in no particular order.

    Returns
    -------
    laid : ndarray of int64, shape (n,)
        Pixel ids of the chains, concatenated.
    chain_offsets : ndarray of int64, shape (n_chains + 1,)
        Chain ``i`` is ``laid[chain_offsets[i]:chain_offsets[i + 1]]``.
    n_links : ndarray of int64, shape (n_chains,)
    first : ndarray of int64, shape (n_chains,)
        The end (``2 * link + side`` in ``edges``) each chain starts at.
    arrived : ndarray of int64, shape (n,)
        Only ``with_links``: the link (row of ``edges``) by which the walk
        reached each pixel of ``laid``; -1 at each chain's first pixel.
    """
    n_edges = len(edges)
    pixel = np.asarray(edges, dtype=np.int64).ravel()  # pixel at each end (slot)
    slot = np.arange(2 * n_edges, dtype=np.int64)
    at_node = is_node[pixel]
    # An inner pixel's two ends: each is the other's partner (their sum less itself).
    inner = slot[~at_node]
    pair_sum = np.bincount(pixel[inner], weights=inner, minlength=len(is_node)).astype(np.int64)
    partner = pair_sum[pixel] - slot

    # Walk: enter at end s, leave at s ^ 1, go on at its partner unless it is a node.
    leave = slot ^ 1
    following = np.where(at_node[leave], -1, partner[leave])
    links_to_stop = np.ones(2 * n_edges, dtype=np.int64)  # links from entering at s to the stop
    stop = leave.copy()  # the node end a walk entered at s stops at
    walking = np.flatnonzero(following >= 0)
    while len(walking):
        ahead = following[walking]
        links_to_stop[walking] += links_to_stop[ahead]
        stop[walking] = stop[ahead]
        following[walking] = following[ahead]
        walking = walking[following[walking] >= 0]

    # A chain starts at the first of its two node ends (as the copies of
    # node pixels were numbered before: in the order of ``edges``).
    first = np.flatnonzero(at_node & (slot < stop))
    n_links = links_to_stop[first]
    size = n_links + 1
    chain_offsets = np.concatenate([[0], np.cumsum(size)])
    laid = np.empty(chain_offsets[-1], dtype=np.int64)
    laid[chain_offsets[:-1]] = pixel[first]
    chain_of_stop = np.empty(2 * n_edges, dtype=np.int64)
    chain_of_stop[stop[first]] = np.arange(len(first))
    forward = stop > stop[stop]  # walks towards the later node end
    chain = chain_of_stop[stop[forward]]
    at = chain_offsets[chain] + n_links[chain] - links_to_stop[forward] + 1
    laid[at] = pixel[leave[forward]]
    if with_links:
        arrived = np.full(len(laid), -1, dtype=np.int64)
        arrived[at] = leave[forward] >> 1
        return laid, chain_offsets, n_links, first, arrived
    return laid, chain_offsets, n_links, first


def _inner_min(pixels: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Smallest inner pixel id of each chain laid out as in :class:`Chains`
    (the largest int64 for a chain without one), shape (n_chains,)."""
    if len(offsets) < 2:
        return np.empty(0, dtype=np.int64)
    masked = pixels.copy()
    masked[offsets[:-1]] = _NO_INNER
    masked[offsets[1:] - 1] = _NO_INNER
    return np.minimum.reduceat(masked, offsets[:-1])


#: :func:`_inner_min` of a chain without inner pixels.
_NO_INNER = np.iinfo(np.int64).max


def _chains_in_order(
    source: np.ndarray, first: np.ndarray, size: np.ndarray, key: np.ndarray, coords: np.ndarray
) -> Chains:
    """:class:`Chains` from pixel runs ``source[first[i]:first[i] + size[i]]``
    in the order of their distinct integer ``key`` (all below
    ``len(key) + len(coords) + len(source)``)."""
    # The keys are distinct and small: a counting sort.
    chain_at_key = np.full(int(key.max(initial=-1)) + 1, -1, dtype=np.int64)
    chain_at_key[key] = np.arange(len(key))
    order = chain_at_key[chain_at_key >= 0]
    sizes = size[order]
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    take = np.arange(offsets[-1]) + np.repeat(first[order] - offsets[:-1], sizes)
    pixels = source[take]
    # The lengths are differences of one running sum over all chains, so
    # equal chains can differ in the last bits; keeping this exact sum keeps
    # every threshold and tie of the branch reduction as it was.
    # Steps within a chain join 8-neighbours: 1 or sqrt(2) cells, which
    # np.sqrt of the squared integer step gives exactly as np.hypot does,
    # several times faster (the steps between chains are zeroed below).
    d_row, d_col = np.diff(coords[:, 0][pixels]), np.diff(coords[:, 1][pixels])
    step = np.sqrt((d_row * d_row + d_col * d_col).astype(np.float64))
    step[offsets[1:-1] - 1] = 0.0
    cumulative = np.concatenate([[0.0], np.cumsum(step)])
    length = cumulative[offsets[1:] - 1] - cumulative[offsets[:-1]]
    return Chains(pixels, offsets, pixels[offsets[:-1]], pixels[offsets[1:] - 1], length)


def _spurs_to_remove(chains: Chains, n_pixels: int, prune_length: float) -> np.ndarray:
    """Boolean mask of the short end chains to remove, shape (n_chains,).

    A spur is a chain from an endpoint to a branch point.  At a branch point
    of degree d at most d - 2 spurs go, the shortest first, so the two
    longest lines through it always survive (a short "Y" becomes a line, it
    does not vanish).
    """
    degree = chains.node_degree(n_pixels)
    leaf_start = degree[chains.start] == 1
    leaf_end = degree[chains.end] == 1
    candidate = np.flatnonzero((leaf_start ^ leaf_end) & (chains.length < prune_length))
    remove = np.zeros(len(chains), dtype=bool)
    if len(candidate) == 0:
        return remove
    hub = np.where(leaf_start[candidate], chains.end[candidate], chains.start[candidate])
    order = np.lexsort((chains.length[candidate], hub))
    hub_sorted = hub[order]
    group_start = np.flatnonzero(np.concatenate([[True], hub_sorted[1:] != hub_sorted[:-1]]))
    rank = np.arange(len(order)) - np.repeat(group_start, np.diff(np.append(group_start, len(order))))
    remove[candidate[order]] = rank < degree[hub_sorted] - 2
    return remove


def _small_components(chains: Chains, n_pixels: int, min_length: float) -> np.ndarray:
    """Boolean mask of the chains whose connected component is shorter than
    ``min_length`` cells in total, shape (n_chains,)."""
    if len(chains) == 0:
        return np.zeros(0, dtype=bool)
    # On the node pixels alone, numbered compactly: a graph of thousands of
    # vertices instead of every pixel's.  (The sums below add each
    # component's chains in list order whatever the labels.)
    is_node = np.zeros(n_pixels, dtype=bool)
    is_node[chains.start] = True
    is_node[chains.end] = True
    compact = np.cumsum(is_node) - 1
    start, end = compact[chains.start], compact[chains.end]
    n_nodes = int(compact[-1]) + 1
    graph = sparse.csr_matrix((np.ones(len(chains)), (start, end)), shape=(n_nodes, n_nodes))
    _, label = connected_components(graph, directed=False)
    component_length = np.bincount(label[start], weights=chains.length)
    return component_length[label[start]] < min_length


def _small_forest_components(forest: PixelForest, min_length: float,
                             component: np.ndarray | None) -> np.ndarray | None:
    """Links of the forest's components shorter than ``min_length`` cells,
    shape (n_edges,) bool; None when a component's length is too close to
    ``min_length`` to tell.

    Notes
    -----
    Dropping these links before compressing the forest gives exactly the
    chains that compressing it all and dropping the small components'
    chains gives (:func:`_drop` of whole components joins nothing and
    keeps every chain's direction and order), without laying out every
    chain twice.  Which components are small must agree too: a component
    of ``a`` straight and ``b`` diagonal links is ``a + b * sqrt(2)``
    cells long, which the chains' lengths (differences of one running sum,
    :func:`_chains_in_order`) give to within far less than 1e-6; nearer
    than that to ``min_length`` (``b = 0`` and ``a = min_length``, say),
    only the chains' sums decide, and the caller goes that way.
    """
    edges, coords = forest.edges, forest.coords
    if len(edges) == 0:
        return np.zeros(0, dtype=bool)
    if component is None:
        n = len(coords)
        graph = sparse.csr_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
        _, component = connected_components(graph, directed=False)
    a, b = edges[:, 0], edges[:, 1]
    diagonal = (coords[a, 0] != coords[b, 0]) & (coords[a, 1] != coords[b, 1])
    label = np.asarray(component)[a]
    straight = np.bincount(label[~diagonal], minlength=label.max() + 1)
    slanted = np.bincount(label[diagonal], minlength=label.max() + 1)
    length = straight + slanted * np.sqrt(2.0)
    if np.any((np.abs(length - min_length) <= 1e-6) & (straight + slanted > 0)):
        return None
    return (length < min_length)[label]


def reduce_branches(
    forest: PixelForest,
    *,
    prune_length: float,
    prune_iterations: int,
    min_component_length: float,
    component: np.ndarray | None = None,
) -> Chains:
    """PPA's branch reduction on a pixel forest.

    Parameters
    ----------
    forest : PixelForest
    prune_length : float
        End branches shorter than this many cells are removed.
    prune_iterations : int
        How many rounds of spur removal; each round can expose new spurs
        (a spur on a spur).  Stops early when a round removes nothing.
    min_component_length : float
        Connected components shorter than this many cells in total are
        dropped (before and after pruning).
    component : ndarray of int, shape (n_pixels,), optional
        The connected component of each pixel (any numbering), when the
        caller has it; otherwise it is found here.

    Returns
    -------
    Chains
        The chains of the reduced forest; no node pixel has degree 2.
    """
    n = len(forest.coords)
    # Small components go first (PPA leaves many fragments, no need to prune
    # them) and again last, as pruning can shrink a component below the limit.
    small = _small_forest_components(forest, min_component_length, component)
    if small is None:
        chains = compress_chains(forest.edges, forest.coords)
        chains = _drop(chains, _small_components(chains, n, min_component_length), forest.coords)
    else:
        chains = compress_chains(forest.edges[~small], forest.coords)
    for _ in range(prune_iterations):
        remove = _spurs_to_remove(chains, n, prune_length)
        if not remove.any():
            break
        chains = _drop(chains, remove, forest.coords)
    return _drop(chains, _small_components(chains, n, min_component_length), forest.coords)


def _drop(chains: Chains, remove: np.ndarray, coords: np.ndarray) -> Chains:
    """Chains without those marked in ``remove``, recompressed: exactly
    ``compress_chains(chains.edges(~remove), coords)``.

    Only the kept chains meeting at a node left with two chains are joined
    (walked again); the others keep their pixels, and all are laid out
    again in :func:`compress_chains`' order.
    """
    if not remove.any():
        return chains
    n = len(coords)
    keep = ~remove
    degree = np.bincount(np.concatenate([chains.start[keep], chains.end[keep]]), minlength=n)
    joined = keep & ((degree[chains.start] == 2) | (degree[chains.end] == 2))
    staying = np.flatnonzero(keep & ~joined)
    sizes = np.diff(chains.offsets)
    # A chain that stays keeps its direction, and its order key: its
    # smallest inner pixel, or, without one, its place in the list.
    key = _inner_min(chains.pixels, chains.offsets)[staying]
    key = np.where(key == _NO_INNER, n + staying, key)
    if not joined.any():
        return _chains_in_order(chains.pixels, chains.offsets[staying], sizes[staying], key, coords)
    # The joined chains, laid out as compress_chains would lay out their
    # links. (Each has an inner pixel: the node it was joined at.)
    laid, chain_offsets = _join_chains(chains, np.flatnonzero(joined), (degree != 2) & (degree > 0))
    source = np.concatenate([chains.pixels, laid])
    first = np.concatenate([chains.offsets[staying], len(chains.pixels) + chain_offsets[:-1]])
    size = np.concatenate([sizes[staying], np.diff(chain_offsets)])
    key = np.concatenate([key, _inner_min(laid, chain_offsets)])
    return _chains_in_order(source, first, size, key, coords)


def _join_chains(chains: Chains, joined: np.ndarray, is_node: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Join chains end to end at the pixels that are no longer nodes:
    exactly ``_walk_chains(chains.edges(mask), is_node)[:2]`` for the chains
    ``joined`` (ids ascending; ``mask`` is True at them), without walking
    their pixels again.

    Parameters
    ----------
    chains : Chains
    joined : ndarray of int64, shape (m,)
        Chains to join, ascending; each meets another at a pixel that is
        not in ``is_node``.
    is_node : ndarray of bool, shape (n_pixels,)
        Where the joined chains stop (degree 1 or >= 3 after the removal).

    Returns
    -------
    laid, chain_offsets
        As :func:`_walk_chains`.

    Notes
    -----
    Each joined chain is one link between its end pixels, and
    :func:`_walk_chains` walks these links: the same runs, from the same
    first end, since a chain's ends come in the same order among the
    chain links as its end links among the pixel links (chain by chain,
    start before end).  Each run's chains are then laid out pixel by
    pixel, turned where the run enters one at its end.
    """
    ends = np.stack([chains.start[joined], chains.end[joined]], axis=1)
    nodes, run_offsets, n_steps, _, arrived = _walk_chains(ends, is_node, with_links=True)
    # The steps of all runs, in order: each is the joined chain by which the
    # walk reached its second pixel, entered from the first.
    step_to = np.flatnonzero(arrived >= 0)
    chain = joined[arrived[step_to]]
    forward = chains.start[chain] == nodes[step_to - 1]
    # Every chain's pixels, but the first of each after a run's first chain
    # (the pixel where it meets the chain before).
    first_step = np.zeros(len(chain), dtype=bool)
    first_step[run_offsets[:-1] - np.arange(len(n_steps))] = True
    skip = (~first_step).astype(np.int64)
    size = np.diff(chains.offsets)[chain] - skip
    out = np.cumsum(size) - size
    step = np.repeat(np.arange(len(chain)), size)
    k = np.arange(len(step)) - out[step] + skip[step]  # position along the chain's own pixels
    at = np.where(forward[step], chains.offsets[chain][step] + k, chains.offsets[chain + 1][step] - 1 - k)
    laid = chains.pixels[at]
    run_size = np.add.reduceat(size, run_offsets[:-1] - np.arange(len(n_steps))) if len(size) else size
    return laid, np.concatenate([[0], np.cumsum(run_size)]).astype(np.int64)


def smooth_polylines(points: np.ndarray, offsets: np.ndarray, window: int) -> np.ndarray:
    """Moving average along concatenated polylines, ends fixed.

    Parameters
    ----------
    points : ndarray of float, shape (n, 2)
        All polylines, concatenated.
    offsets : ndarray of int, shape (n_lines + 1,)
        Polyline ``i`` is ``points[offsets[i]:offsets[i + 1]]``.
    window : int
        Averaging window in points; 0 or 1 leave the points unchanged.

    Returns
    -------
    ndarray of float64, shape (n, 2)

    Notes
    -----
    The window is centred and shrinks symmetrically near the ends (to one
    point at an end), so endpoints stay put and lines do not drift towards
    their middle.
    """
    half = window // 2
    if half < 1 or len(points) == 0:
        return points.astype(np.float64)
    line = np.repeat(np.arange(len(offsets) - 1), np.diff(offsets))
    position = np.arange(len(points)) - offsets[line]
    remaining = offsets[line + 1] - 1 - np.arange(len(points))
    h = np.minimum(half, np.minimum(position, remaining))
    cumulative = np.concatenate([np.zeros((1, 2)), np.cumsum(points, axis=0, dtype=np.float64)])
    i = np.arange(len(points))
    total = cumulative[i + h + 1] - cumulative[i - h]
    return total / (2 * h + 1)[:, None]


def chains_to_graph(
    chains: Chains,
    coords: np.ndarray,
    *,
    kind: FeatureKind,
    shape: tuple[int, int],
    junction_merge_distance: float,
    smoothing: int,
) -> FeatureGraph:
    """Build the feature graph: merge close branch points, smooth, type nodes.

    Parameters
    ----------
    chains : Chains
        Reduced chains (no degree-2 node pixels).
    coords : ndarray of int, shape (n_pixels, 2)
        ``(row, col)`` of each pixel id.
    kind : {"ridge", "valley"}
    shape : (rows, cols)
        Shape of the grid the graph describes.
    junction_merge_distance : float
        Branch points joined by a chain no longer than this many cells become
        one node at their mean position (so a drawn "+" gives one degree-4
        branch, not two degree-3 branches a pixel apart).
    smoothing : int
        Moving-average window along the paths, in points (0 = none).

    Returns
    -------
    FeatureGraph
    """
    n = len(coords)
    if len(chains) == 0:
        return FeatureGraph(kind, tuple(shape), (), ())
    degree = chains.node_degree(n)
    branch = degree >= 3
    link = branch[chains.start] & branch[chains.end] & (chains.length <= junction_merge_distance)
    # Groups of merged branch points, found on the node pixels alone
    # (numbered compactly in pixel order, so the groups are numbered as on
    # all pixels: in the order of their first pixel).
    is_node = degree > 0
    node_pixels = np.flatnonzero(is_node)
    compact = np.cumsum(is_node) - 1
    merged = sparse.csr_matrix(
        (np.ones(int(link.sum())), (compact[chains.start[link]], compact[chains.end[link]])),
        shape=(len(node_pixels), len(node_pixels)),
    )
    group = np.full(n, -1, dtype=np.int64)
    n_groups, group[node_pixels] = connected_components(merged, directed=False)
    count = np.bincount(group[node_pixels], minlength=n_groups)
    position = np.stack(
        [np.bincount(group[node_pixels], weights=coords[node_pixels, k], minlength=n_groups) for k in (0, 1)],
        axis=1,
    ) / np.maximum(count, 1)[:, None]

    kept = np.flatnonzero(~link)
    start_group = group[chains.start[kept]]
    end_group = group[chains.end[kept]]
    used, node_id = np.unique(np.concatenate([start_group, end_group]), return_inverse=True)
    start_id, end_id = node_id[: len(kept)], node_id[len(kept) :]
    node_degree = np.bincount(node_id, minlength=len(used))

    sizes = np.diff(chains.offsets)[kept]
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    take = np.arange(offsets[-1]) + np.repeat(chains.offsets[kept] - offsets[:-1], sizes)
    points = coords[chains.pixels[take]].astype(np.float64)
    points[offsets[:-1]] = position[start_group]
    points[offsets[1:] - 1] = position[end_group]
    points = smooth_polylines(points, offsets, smoothing)

    # Python numbers (tolist) before the loops: iterating numpy arrays makes
    # a numpy scalar per item, the slower part of building thousands of nodes.
    node_position = position[used]
    nodes = tuple(
        FeatureNode(i, r, c, "branch" if d >= 3 else "end", d)
        for i, (r, c, d) in enumerate(zip(node_position[:, 0].tolist(), node_position[:, 1].tolist(),
                                          node_degree.tolist()))
    )
    bounds = offsets.tolist()
    paths = tuple(
        FeaturePath(s, e, points[bounds[i] : bounds[i + 1]])
        for i, (s, e) in enumerate(zip(start_id.tolist(), end_id.tolist()))
    )
    return FeatureGraph(kind, tuple(int(v) for v in shape), nodes, paths)


def graph_cells(graph: FeatureGraph) -> np.ndarray:
    """Cells passed by the paths of a graph, inside its shape: each
    segment sampled at one point per cell of its longer axis.

    Returns
    -------
    ndarray of int64, shape (n, 2)
        (row, col), some more than once.
    """
    if not graph.paths:
        return np.zeros((0, 2), np.int64)
    points = np.rint(np.concatenate([p.points for p in graph.paths])).astype(np.int64)
    sizes = np.array([len(p.points) for p in graph.paths])
    last = np.cumsum(sizes) - 1
    segment = np.ones(len(points) - 1, dtype=bool)
    segment[last[:-1]] = False  # no segment from one path's end to the next's start
    start = points[:-1][segment]
    delta = points[1:][segment] - start
    steps = np.abs(delta).max(axis=1)
    seg = np.repeat(np.arange(len(start)), steps + 1)
    k = np.arange(len(seg)) - np.repeat(np.cumsum(steps + 1) - (steps + 1), steps + 1)
    frac = k / np.maximum(steps[seg], 1)
    cells = start[seg] + np.rint(delta[seg] * frac[:, None]).astype(np.int64)
    rows, cols = graph.shape
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < rows) & (cells[:, 1] >= 0) & (cells[:, 1] < cols)
    return cells[inside]


def graph_mask(graph: FeatureGraph, *, width: int = 1) -> np.ndarray:
    """Cells passed by the paths of a graph (:func:`graph_cells`); a
    vectorized :meth:`FeatureGraph.rasterize`.

    Parameters
    ----------
    graph : FeatureGraph
    width : int, default 1
        Line width in cells (1 = the bare polylines; wider ones grown by
        ``width // 2`` steps to the four neighbours).

    Returns
    -------
    ndarray of bool, shape ``graph.shape``
    """
    mask = np.zeros(graph.shape, dtype=bool)
    cells = graph_cells(graph)
    mask[cells[:, 0], cells[:, 1]] = True
    if width > 1:
        mask = ndimage.binary_dilation(mask, iterations=width // 2)
    return mask


def feature_graph_from_mask(
    mask: np.ndarray,
    strength: np.ndarray,
    *,
    kind: FeatureKind,
    prune_length: float,
    prune_iterations: int,
    min_component_length: float,
    junction_merge_distance: float,
    smoothing: int,
) -> FeatureGraph:
    """Run the whole pipeline: spanning forest, branch reduction, graph.

    Parameters
    ----------
    mask : ndarray of bool, shape (rows, cols)
        Feature pixels (PPA targets, skeleton pixels).
    strength : ndarray of float, shape (rows, cols)
        Per-pixel strength; loops break at their weakest link.
    kind : {"ridge", "valley"}
    prune_length, prune_iterations, min_component_length
        See :func:`reduce_branches`.
    junction_merge_distance, smoothing
        See :func:`chains_to_graph`.

    Returns
    -------
    FeatureGraph
        Acyclic by construction.
    """
    shape = mask.shape
    # Only the mask's bounding box and a ring of background around it (a
    # sketch's strokes cover a few percent of it): pixels are numbered row
    # by row there as over the whole grid, every neighbour of a mask pixel
    # is inside, and the coordinates are moved back before anything reads
    # them, so the graph is the same to the bit.
    box = _crop_box(mask)
    if box is not None:
        mask, strength = mask[box], strength[box]
    # A component of n pixels spans at most sqrt(2) * (n - 1) cells, so the
    # ones below min_component_length can go before the costlier steps.
    labels, n_labels = ndimage.label(mask, structure=np.ones((3, 3), dtype=bool))
    if n_labels:
        size = np.bincount(labels.ravel())
        too_small = np.sqrt(2.0) * (size - 1) < min_component_length
        too_small[0] = True
        mask = ~too_small[labels]
    forest = spanning_forest(mask, strength)
    if box is not None:
        forest = PixelForest(forest.coords + np.array([box[0].start, box[1].start], dtype=np.int64), forest.edges)
    chains = reduce_branches(
        forest,
        prune_length=prune_length,
        prune_iterations=prune_iterations,
        min_component_length=min_component_length,
        component=labels[mask] if n_labels else None,
    )
    return chains_to_graph(
        chains,
        forest.coords,
        kind=kind,
        shape=shape,
        junction_merge_distance=junction_merge_distance,
        smoothing=smoothing,
    )


def mask_box(mask: np.ndarray, margin: int = 1) -> tuple[slice, slice] | None:
    """The bounding box of ``mask``'s pixels widened by ``margin`` pixels
    (within the grid), as slices; None when the mask is empty."""
    rows = np.flatnonzero(mask.any(axis=1))
    if len(rows) == 0:
        return None
    cols = np.flatnonzero(mask.any(axis=0))
    return (slice(max(int(rows[0]) - margin, 0), min(int(rows[-1]) + 1 + margin, mask.shape[0])),
            slice(max(int(cols[0]) - margin, 0), min(int(cols[-1]) + 1 + margin, mask.shape[1])))


def _crop_box(mask: np.ndarray) -> tuple[slice, slice] | None:
    """Where :func:`feature_graph_from_mask` works: the mask's box and a
    ring of background; None for the whole grid (or an empty mask)."""
    box = mask_box(mask, 1)
    if box is None or (box[0].stop - box[0].start, box[1].stop - box[1].start) == mask.shape:
        return None
    return box
