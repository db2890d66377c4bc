"""Poisson seam removal around one placed patch.

After the graph cut, heights still jump where the cut runs.  Zhou et al.
(2007, §5.2) turn the window's heights into gradients, set the gradients
across the seam to zero and solve a Poisson equation (Pérez et al. 2003) for
the heights that best fit them, anchored to the terrain around the window.
The paper names C1 continuity as future work; ``mode="c1"`` carries the
slope across the seam instead of flattening it.

References
----------
.. [1] P. Pérez, M. Gangnet, A. Blake, "Poisson image editing", ACM TOG
   22(3):313-318, 2003.
.. [2] H. Zhou, J. Sun, G. Turk, J. M. Rehg, "Terrain synthesis from digital
   elevation models", IEEE TVCG 13(4):834-848, 2007.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Literal

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse.linalg import splu

from ..errors import ParamsError
from .rectangle import open_edges, rectangle_solver

BlendMode = Literal["poisson", "c1"]


def _seam_guidance(d: np.ndarray, crosses: np.ndarray, valid: np.ndarray, mode: BlendMode) -> np.ndarray:
    """Guidance differences along axis 1 (``d[:, j] = h[:, j+1] - h[:, j]``).

    ``crosses`` marks the edges that cross the seam, ``valid`` the edges
    whose two ends both take part in the solve.  Crossing edges get 0
    ("poisson"), or the mean of the valid, non-crossing edges just before
    and just after them along the axis ("c1"; one side alone when the other
    is missing, 0 when both are).
    """
    g = np.where(crosses, 0.0, d)
    if mode == "c1":
        usable = valid & ~crosses
        total = np.zeros_like(d)
        count = np.zeros_like(d)
        total[:, 1:] += np.where(usable[:, :-1], d[:, :-1], 0.0)
        count[:, 1:] += usable[:, :-1]
        total[:, :-1] += np.where(usable[:, 1:], d[:, 1:], 0.0)
        count[:, :-1] += usable[:, 1:]
        mean = np.divide(total, count, out=np.zeros_like(total), where=count > 0)
        g = np.where(crosses, mean, g)
    return g


def remove_seam(
    heights: np.ndarray,
    take_new: np.ndarray,
    region: np.ndarray,
    *,
    fixed: np.ndarray | None = None,
    mode: BlendMode = "poisson",
) -> np.ndarray:
    """Smooth the seam of a composited window by a local Poisson solve.

    Parameters
    ----------
    heights : ndarray of float, shape (h, w)
        The window after the cut: new heights where ``take_new``, existing
        ones elsewhere.  Finite wherever ``region`` or ``fixed`` is set.
    take_new : ndarray of bool, shape (h, w)
        Which side of the seam each pixel is on.
    region : ndarray of bool, shape (h, w)
        Pixels whose heights may change.
    fixed : ndarray of bool, shape (h, w), optional
        Pixels whose heights must not change (Dirichlet), e.g. window border
        pixels that touch terrain outside the window.  Default: the
        complement of ``region``.
    mode : {"poisson", "c1"}, default "poisson"
        Guidance across the seam: zero gradient (the paper), or the mean of
        the two neighbouring gradients along the same axis, which continues
        the slope (first-derivative continuity).

    Returns
    -------
    ndarray of float32, shape (h, w)
        ``heights`` with the solved values in ``region`` minus ``fixed``;
        every other pixel unchanged, bit for bit.

    Raises
    ------
    ParamsError
        Mismatched shapes, an unknown mode, or non-finite heights in ``region`` minus
        ``fixed`` (NaN fixed pixels are allowed and act as a Neumann
        border).

    Notes
    -----
    Minimises ``sum (h(q) - h(p) - g(p, q))^2`` over the 4-neighbour edges
    that touch a free pixel and whose other end is free or fixed;
    edges to pixels neither in ``region`` nor ``fixed`` are dropped (Neumann
    border).  The guidance ``g`` is the composite's own differences except
    on edges crossing the seam (``take_new`` differs at the two ends).  A
    connected group of free pixels with no edge to a fixed pixel
    has nothing to anchor it and is returned unchanged.  The normal
    equations (a sparse graph Laplacian) are solved directly: by sine
    transforms and a small dense system when the free pixels form a solid
    rectangle (:mod:`.rectangle`, nearly every fill window), else by a
    sparse LU whose last few factorizations are cached by mask.
    """
    h0 = np.asarray(heights)
    if h0.ndim != 2 or min(h0.shape) < 1:
        raise ParamsError(f"heights must be a 2-D array, got shape {h0.shape}")
    shape = h0.shape
    for name, arr in (("take_new", take_new), ("region", region)):
        if np.shape(arr) != shape:
            raise ParamsError(f"{name} mask must have the heights' shape {shape}, got {np.shape(arr)}")
    if fixed is not None and np.shape(fixed) != shape:
        raise ParamsError(f"fixed mask must have the heights' shape {shape}, got {np.shape(fixed)}")
    if mode not in ("poisson", "c1"):
        raise ParamsError(f"seam removal mode must be 'poisson' or 'c1', got {mode!r}")
    take_new = np.asarray(take_new, dtype=bool)
    region = np.asarray(region, dtype=bool)
    fixed = ~region if fixed is None else np.asarray(fixed, dtype=bool)

    free = region & ~fixed
    result = h0.astype(np.float32)  # a copy: the caller's array is never touched
    values = h0.astype(np.float64)
    bad = ~np.isfinite(h0) & free
    if bad.any():
        raise ParamsError(f"heights hold {int(bad.sum())} non-finite values among the pixels to solve")
    finite = np.isfinite(values)
    # A fixed pixel without a height (NaN: no terrain there) cannot anchor
    # anything; it borders the solve like a pixel outside the region.
    known = fixed & finite

    # Free groups with no edge to a known pixel cannot be anchored: drop them.
    block = _solid_block(free)
    if block is not None:
        # One solid rectangle (nearly every window): one group, anchored
        # when a known pixel lies just outside one of its sides.
        if not _block_anchored(block, known):
            return result
    else:
        labels, n_groups = ndimage.label(free)
        anchored = np.zeros(n_groups + 1, bool)
        anchored[labels[ndimage.binary_dilation(known) & free]] = True
        anchored[0] = False
        free = anchored[labels]
        if not free.any():
            return result
    take = free | known
    values = np.where(take, values, 0.0)
    composite = np.where(take, h0, 0.0).astype(np.float64)

    # Edges along rows (down) and columns (right), as masks on their first
    # pixel: "valid" when both ends take part, "used" when one is free too.
    down_valid = take[:-1, :] & take[1:, :]
    right_valid = take[:, :-1] & take[:, 1:]
    down_used = down_valid & (free[:-1, :] | free[1:, :])
    right_used = right_valid & (free[:, :-1] | free[:, 1:])

    # Guidance: the composite's differences, rewritten across the seam.
    g_down = _seam_guidance(
        np.diff(composite, axis=0).T, (take_new[:-1, :] != take_new[1:, :]).T, down_valid.T, mode
    ).T
    g_right = _seam_guidance(np.diff(composite, axis=1), take_new[:, :-1] != take_new[:, 1:], right_valid, mode)

    # One least-squares equation x_q - x_p = g per used edge p -> q; the
    # normal equations are the graph Laplacian of the free pixels.  Solving
    # for the change d = x - values (0 at known pixels) keeps the right-hand
    # side small, nonzero only near the seam, and the result
    # exact to float64 round-off whatever the absolute heights.
    index = np.full(shape, -1, dtype=np.int64)
    index[free] = np.arange(int(free.sum()))
    p_idx = np.concatenate([index[:-1, :][down_used], index[:, :-1][right_used]])
    q_idx = np.concatenate([index[1:, :][down_used], index[:, 1:][right_used]])
    r = np.concatenate(
        [(g_down - np.diff(values, axis=0))[down_used], (g_right - np.diff(values, axis=1))[right_used]]
    )
    n = int(free.sum())
    rhs = np.bincount(q_idx[q_idx >= 0], r[q_idx >= 0], minlength=n) - np.bincount(
        p_idx[p_idx >= 0], r[p_idx >= 0], minlength=n
    )
    result[free] = (values[free] + _solve(free, known, p_idx, q_idx, rhs)).astype(np.float32)
    return result


def _solid_block(free: np.ndarray) -> tuple[int, int, int, int] | None:
    """``(r0, r1, c0, c1)`` when the free pixels are exactly that solid
    rectangle, else None (also when there are none)."""
    rows = np.flatnonzero(free.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(free.any(axis=0))
    r0, r1, c0, c1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    if np.count_nonzero(free) != (r1 - r0) * (c1 - c0):
        return None
    return r0, r1, c0, c1


def _block_anchored(block: tuple[int, int, int, int], known: np.ndarray) -> bool:
    """Whether a known pixel is 4-adjacent to the solid block."""
    r0, r1, c0, c1 = block
    rows, cols = known.shape
    return bool((r0 > 0 and known[r0 - 1, c0:c1].any()) or (r1 < rows and known[r1, c0:c1].any())
                or (c0 > 0 and known[r0:r1, c0 - 1].any()) or (c1 < cols and known[r0:r1, c1].any()))


def _solve(free: np.ndarray, known: np.ndarray, p_idx: np.ndarray, q_idx: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """The change at the free pixels (row-major), ``L^-1 rhs``.

    A solid rectangle of free pixels (a fill window, nearly always) goes to
    the fast rectangle solver (up to its rim size,
    :data:`.rectangle.MAX_RIM`); anything else to a sparse factorization.
    """
    rows = np.flatnonzero(free.any(axis=1))
    cols = np.flatnonzero(free.any(axis=0))
    block = (int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1)
    if rhs.size == (block[1] - block[0]) * (block[3] - block[2]):
        solver = rectangle_solver((block[1] - block[0], block[3] - block[2]))
        if solver is not None:
            try:
                return solver.solve(rhs, *solver.capacitance(open_edges(block, known)))
            except np.linalg.LinAlgError:
                pass  # too weakly anchored for the small dense system: factorize
    return _laplacian_solver(free, known, p_idx, q_idx).solve(rhs)


#: Factorizations kept for reuse, keyed by the free and known masks.  The
#: Laplacian depends only on them (not on heights or the seam), and windows
#: placed in a regular fill repeat the same masks over and over.  At most
#: 48 entries and 24 million factor nonzeros (about 300 MB; one 80x80 window
#: takes about 0.25 million, one 160x160 window about 1.1 million).
_SOLVER_CACHE: OrderedDict = OrderedDict()
_SOLVER_CACHE_ENTRIES = 48
_SOLVER_CACHE_NONZEROS = 24_000_000
_SOLVER_LOCK = threading.Lock()


def _laplacian_solver(free: np.ndarray, known: np.ndarray, p_idx: np.ndarray, q_idx: np.ndarray):
    """Sparse LU of the free pixels' Laplacian, from the cache when possible."""
    key = (free.shape, np.packbits(free).tobytes(), np.packbits(known).tobytes())
    with _SOLVER_LOCK:
        solver = _SOLVER_CACHE.get(key)
        if solver is not None:
            _SOLVER_CACHE.move_to_end(key)
            return solver
    n = int(free.sum())
    both = (p_idx >= 0) & (q_idx >= 0)
    degree = np.bincount(p_idx[p_idx >= 0], minlength=n) + np.bincount(q_idx[q_idx >= 0], minlength=n)
    rows = np.concatenate([np.arange(n), p_idx[both], q_idx[both]])
    cols = np.concatenate([np.arange(n), q_idx[both], p_idx[both]])
    data = np.concatenate([degree.astype(np.float64), -np.ones(2 * int(both.sum()))])
    laplacian = sparse.csc_matrix((data, (rows, cols)), shape=(n, n))
    # Symmetric positive definite (every group is anchored): a symmetric
    # fill-reducing order, and diagonal pivots are stable without searching.
    solver = splu(
        laplacian, permc_spec="MMD_AT_PLUS_A", options={"SymmetricMode": True, "DiagPivotThresh": 0.0}
    )
    with _SOLVER_LOCK:
        _SOLVER_CACHE[key] = solver
        while len(_SOLVER_CACHE) > 1 and (
            len(_SOLVER_CACHE) > _SOLVER_CACHE_ENTRIES
            or sum(s.L.nnz + s.U.nnz for s in _SOLVER_CACHE.values()) > _SOLVER_CACHE_NONZEROS
        ):
            _SOLVER_CACHE.popitem(last=False)
    return solver
