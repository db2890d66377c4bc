"""Graph-cut seams between already synthesized terrain and a new patch.

Where a new patch overlaps terrain that is already in the output, each
overlap pixel keeps either the existing height or the new one.  A minimum cut
(Kwatra et al. 2003) picks the split whose boundary runs where the two
height fields agree best; Zhou et al. (2007, §5.1) use it both to merge a
patch and, through the cut's cost, to choose among candidate patches.

References
----------
.. [1] V. Kwatra, A. Schödl, I. Essa, G. Turk, A. Bobick, "Graphcut
   textures: image and video synthesis using graph cuts", ACM TOG 22(3):
   277-286, 2003.
.. [2] Y. Boykov, V. Kolmogorov, "An experimental comparison of
   min-cut/max-flow algorithms for energy minimization in vision",
   IEEE TPAMI 26(9):1124-1137, 2004.
"""

from __future__ import annotations

from dataclasses import dataclass

import maxflow
import numpy as np

from ..errors import ParamsError

#: Default edge-weight floor relative to the windows' height range: keeps a
#: cut through perfectly matching (e.g. flat) terrain short and clean instead
#: of arbitrary, while staying far below any real height mismatch.
_RELATIVE_EPSILON = 1e-4


@dataclass(frozen=True, eq=False)
class SeamResult:
    """Outcome of :func:`graph_cut_seam`.

    Parameters
    ----------
    take_new : ndarray of bool, shape (h, w)
        ``True`` where the window takes the new patch's height.
    seam : ndarray of bool, shape (h, w)
        New pixels 4-adjacent to a kept existing pixel: where the cut runs.
    cost : float
        Sum of the weights of the cut edges (height units; 0 without overlap).
    overlap_pixels : int
        Number of filled pixels in the window.
    """

    take_new: np.ndarray
    seam: np.ndarray
    cost: float
    overlap_pixels: int


def _bool_grid(mask, shape: tuple[int, int], name: str) -> np.ndarray:
    m = np.asarray(mask)
    if m.shape != shape:
        raise ParamsError(f"{name} must have the window's shape {shape}, got {m.shape}")
    return m.astype(bool, copy=False)


def _edge_weights(mismatch: np.ndarray, filled: np.ndarray, axis: int) -> np.ndarray:
    """Weights ``M(s) + M(t)`` of the edges s -> s + 1 along ``axis``.

    Returned with the window's shape; the last row/column holds the edge
    that wraps round to the first (unused by the cut, but part of the
    hard-constraint weight's sum).  An edge between a filled and an
    unfilled pixel cannot compare heights at the unfilled end; it counts
    the filled end twice, so cutting along the rim of the overlap costs as
    much as cutting through it.  ``mismatch`` is 0 at unfilled pixels, so
    that is the sum of both ends, doubled (exactly, in floating point).
    """
    m = np.moveaxis(mismatch, axis, 0)
    f = np.moveaxis(filled, axis, 0)
    out = np.empty_like(m)
    np.add(m[:-1], m[1:], out=out[:-1])
    np.add(m[-1], m[0], out=out[-1])
    one_sided = np.empty(f.shape, dtype=bool)
    np.not_equal(f[:-1], f[1:], out=one_sided[:-1])
    np.not_equal(f[-1], f[0], out=one_sided[-1])
    out[one_sided] *= 2.0
    return np.moveaxis(out, 0, axis)


def _cut_cost(take_new: np.ndarray, w_down: np.ndarray, w_right: np.ndarray) -> float:
    cut_down = take_new[:-1, :] != take_new[1:, :]
    cut_right = take_new[:, :-1] != take_new[:, 1:]
    return float(w_down[:-1, :][cut_down].sum() + w_right[:, :-1][cut_right].sum())


def seam_pixels(take_new: np.ndarray, filled: np.ndarray) -> np.ndarray:
    """New pixels 4-adjacent to a kept existing pixel.

    Parameters
    ----------
    take_new, filled : ndarray of bool, shape (h, w)

    Returns
    -------
    ndarray of bool, shape (h, w)
    """
    kept = filled & ~take_new
    near = np.zeros_like(kept)
    near[1:, :] |= kept[:-1, :]
    near[:-1, :] |= kept[1:, :]
    near[:, 1:] |= kept[:, :-1]
    near[:, :-1] |= kept[:, 1:]
    return take_new & near


def graph_cut_seam(
    existing: np.ndarray,
    new: np.ndarray,
    filled: np.ndarray,
    *,
    keep_new: np.ndarray | None = None,
    keep_existing: np.ndarray | None = None,
    epsilon: float | None = None,
) -> SeamResult:
    """Minimum-cost seam between existing heights and a new patch.

    Parameters
    ----------
    existing : ndarray of float, shape (h, w)
        Output heights under the window; only read where ``filled`` (may be
        NaN elsewhere).
    new : ndarray of float, shape (h, w)
        The new patch's heights, finite.
    filled : ndarray of bool, shape (h, w)
        ``True`` where the output already has heights.
    keep_new, keep_existing : ndarray of bool, shape (h, w), optional
        Pixels that must take the new / keep the existing height (hard
        constraints, e.g. a branch patch's centre).  They must not overlap,
        and ``keep_existing`` must lie inside ``filled``.
    epsilon : float or None, default None
        Floor added to every edge weight; ``None`` uses 1e-4 times the
        windows' height range.

    Returns
    -------
    SeamResult

    Notes
    -----
    Rules of the cut: unfilled pixels take the new patch; filled pixels on
    the window border keep the existing heights (so the seam cannot leak out
    of the window) unless ``keep_new`` says otherwise.  The weight of the
    edge between 4-neighbours s, t is
    ``M = |a(s) - b(s)| + |a(t) - b(t)| + epsilon`` (a = existing, b = new;
    Kwatra et al. 2003).  Hard constraints are terminal links heavier than
    every edge of the window together.  Without any filled pixel no graph is
    built: everything takes the new patch at cost 0.
    """
    b = np.asarray(new)
    if b.ndim != 2 or min(b.shape) < 2:
        raise ParamsError(f"new patch must be a 2-D array of at least 2x2 cells, got shape {b.shape}")
    shape = b.shape
    a = np.asarray(existing)
    if a.shape != shape:
        raise ParamsError(f"existing heights must have the new patch's shape {shape}, got {a.shape}")
    filled = _bool_grid(filled, shape, "filled mask")
    keep_new = np.zeros(shape, bool) if keep_new is None else _bool_grid(keep_new, shape, "keep_new mask")
    keep_existing = (
        np.zeros(shape, bool) if keep_existing is None else _bool_grid(keep_existing, shape, "keep_existing mask")
    )
    if (keep_new & keep_existing).any():
        raise ParamsError(f"keep_new and keep_existing overlap at {int((keep_new & keep_existing).sum())} pixels")
    if (keep_existing & ~filled).any():
        raise ParamsError(
            f"keep_existing holds {int((keep_existing & ~filled).sum())} unfilled pixels; "
            "only filled pixels can keep existing heights"
        )

    overlap = int(filled.sum())
    if overlap == 0:
        take_new = np.ones(shape, bool)
        return SeamResult(take_new, np.zeros(shape, bool), 0.0, 0)

    a = np.where(filled, a, b).astype(np.float64)
    b = b.astype(np.float64)
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise ParamsError("graph cut needs finite heights in the new patch and in the filled existing pixels")
    if epsilon is None:
        span = max(float(a.max()), float(b.max())) - min(float(a.min()), float(b.min()))
        epsilon = _RELATIVE_EPSILON * span if span > 0 else 1e-6
    elif not epsilon > 0.0:
        raise ParamsError(f"epsilon must be > 0, got {epsilon}")

    mismatch = np.abs(a - b)
    w_down = _edge_weights(mismatch, filled, axis=0) + epsilon
    w_right = _edge_weights(mismatch, filled, axis=1) + epsilon

    border = np.zeros(shape, bool)
    border[[0, -1], :] = True
    border[:, [0, -1]] = True
    # Heavier than cutting every edge of the window: never cut.
    hard = 2.0 * (w_down.sum() + w_right.sum()) + 1.0

    # Nodes only for the overlap; unfilled pixels are new for certain, so an
    # edge from an overlap pixel to one of them becomes a link to the sink
    # (new) terminal.  Source = keep existing, sink = take new.
    index = np.full(shape, -1, dtype=np.int64)
    index[filled] = np.arange(overlap)
    source_caps = np.where((filled & border & ~keep_new) | keep_existing, hard, 0.0)[filled]
    sink_caps = np.where(keep_new, hard, 0.0)[filled]
    graph = maxflow.Graph[float](overlap, 2 * overlap)
    nodes = graph.add_nodes(overlap)
    for s, t, w in (
        (index[:-1, :], index[1:, :], w_down[:-1, :]),
        (index[:, :-1], index[:, 1:], w_right[:, :-1]),
    ):
        both = (s >= 0) & (t >= 0)
        graph.add_edges(s[both], t[both], w[both], w[both])
        for inner, outer in ((s, t), (t, s)):
            rim = (inner >= 0) & (outer < 0)
            sink_caps += np.bincount(inner[rim], w[rim], minlength=overlap)
    graph.add_grid_tedges(nodes, source_caps, sink_caps)
    graph.maxflow()
    take_new = ~filled
    take_new[filled] = graph.get_grid_segments(nodes)

    return SeamResult(
        take_new=take_new,
        seam=seam_pixels(take_new, filled),
        cost=_cut_cost(take_new, w_down, w_right),
        overlap_pixels=overlap,
    )
