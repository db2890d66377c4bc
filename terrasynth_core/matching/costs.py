"""The match cost of a candidate patch (paper §4.1-4.2, with a level anchor).

A candidate is scored by its mismatch with the terrain already in its
window (the overlap SSD after the best vertical shift) plus a penalty on
how far that shift moves it from the level field.  Both are in units of the
example's relief squared, so costs of examples with different reliefs
compare, and the graph-cut cost (also relief-normalised) adds to them.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from ..heightfield import whole_windows

#: Weight of the squared height shift (in reliefs) against the overlap SSD
#: when the examples' spread of window levels is not known.
OFFSET_WEIGHT = 0.2

#: Weight of the squared level of a placed window, in units of the spread of
#: the example's window levels (:func:`level_spread`), against the overlap
#: SSD in reliefs.
ANCHOR_WEIGHT = 1.0

#: Share of the best candidate's total cost by which another may be dearer
#: and still be chosen: the seed picks among the candidates within it
#: (image quilting picks among matches within 10 % of the best: Efros and
#: Freeman, "Image Quilting for Texture Synthesis and Transfer", SIGGRAPH
#: 2001).  Taking the cheapest every time, a run's choices depended on the
#: seed only through exact ties: on a small example or a small map every
#: seed gave the same terrain, and ``--variations`` identical files.
NEAR_BEST = 0.1

#: Weight of a fill window's roughness prior (``ln(rho / rho_50)**2``, see
#: :func:`~.fill_search.roughness_prior`) against the match cost: without
#: it the fill prefers an example's smoothest windows.
ROUGHNESS_WEIGHT = 1.0


def overlap_ssd(existing: np.ndarray, patch: np.ndarray, filled: np.ndarray) -> tuple[float, float]:
    """Mismatch of a patch with the terrain under it, after the best shift.

    Parameters
    ----------
    existing : ndarray of float32, shape (h, w)
        Output heights in the window, metres (read only where ``filled``).
    patch : ndarray of float32, shape (h, w)
        The candidate's heights, metres.
    filled : ndarray of bool, shape (h, w)
        Cells that already hold terrain.

    Returns
    -------
    ssd : float
        Mean squared difference over the filled cells after the shift,
        metres squared (0 without overlap).
    offset : float
        The SSD-optimal shift to add to ``patch``, metres (their mean
        difference; 0 without overlap).
    """
    n = int(filled.sum())
    if n == 0:
        return 0.0, 0.0
    diff = existing[filled].astype(np.float64) - patch[filled]
    offset = float(diff.mean())
    return float(((diff - offset) ** 2).mean()), offset


def level_spread(detail: np.ndarray, patch_size: int, valid: np.ndarray | None = None) -> float:
    """How far a window's mean level strays in an example.

    Parameters
    ----------
    detail : ndarray of float32, shape (H, W)
        The example's detail heights, metres.
    patch_size : int
        Window side, cells.
    valid : ndarray of bool, shape (H, W), optional
        Where the example is real (its voids are filled in ``detail``):
        only windows wholly inside count, when there are any.

    Returns
    -------
    float
        Standard deviation of the means of every ``patch_size`` window,
        metres (at least a millimetre).
    """
    h = detail.astype(np.float64)
    p = min(patch_size, *h.shape)
    inside = (slice(p // 2, h.shape[0] - p // 2 or None), slice(p // 2, h.shape[1] - p // 2 or None))
    means = ndimage.uniform_filter(h, p, mode="reflect")[inside]
    if valid is not None:
        whole = whole_windows(valid, p)[inside]
        if whole.any():
            means = means[whole]
    return max(float(means.std()), 1e-3)


def anchor_weight(relief: float, spread: float) -> float:
    """The shift weight of :func:`settle` and :func:`match_cost` for an
    example: :data:`ANCHOR_WEIGHT` times ``(relief / spread)**2``, at least
    :data:`OFFSET_WEIGHT`.

    A placed window's level (its mean relative to the level field) then
    costs as much as it is unusual among the example's own windows: where
    window levels vary a lot (a coarse pass, an example of massifs and
    plains) a massif may be copied, and where they hardly vary (detail above
    a landform) patches stay on the level field and cannot drift.  The
    floor keeps the drift bounded however much window levels vary.
    """
    return max(OFFSET_WEIGHT, ANCHOR_WEIGHT * (relief / spread) ** 2)


def settle(ssd: float, offset: float, mean: float = 0.0,
           weight: float = OFFSET_WEIGHT) -> tuple[float, float]:
    """The height shift that minimises the match cost, and the SSD it leaves.

    The cost is the overlap SSD plus ``weight * (shift + mean)**2`` (both
    over the relief squared), where ``mean`` is the candidate's mean detail
    (0 to anchor the shift alone): its minimiser is
    ``(offset - w mean) / (1 + w)`` for the SSD-optimal ``offset``.

    Parameters
    ----------
    ssd : float
        Overlap SSD at the SSD-optimal shift, metres squared.
    offset : float
        That shift, metres.
    mean : float, default 0
        The candidate's mean detail height, metres.
    weight : float, default OFFSET_WEIGHT
        The shift weight (:func:`anchor_weight`).

    Returns
    -------
    ssd : float
        The SSD at the settled shift: ``ssd + (offset - shift)**2``.
    shift : float
        The settled shift, metres.

    Notes
    -----
    Matching the overlap exactly would carry every patch at its neighbours'
    level, so levels random-walk away from the level field over many
    patches, and fronts that grew apart meet in a step.  Settling a fraction
    ``w / (1 + w)`` of the way back to the level field at every patch keeps
    the drift bounded; the small step it leaves in the overlap is what the
    seam solve removes.
    """
    settled = (offset - weight * mean) / (1.0 + weight)
    return ssd + (offset - settled) ** 2, settled


def match_cost(ssd: float, offset: float, relief: float, weight: float = OFFSET_WEIGHT) -> float:
    """Overlap mismatch and level shift of a candidate, in reliefs squared.

    Parameters
    ----------
    ssd : float
        Overlap SSD, metres squared.
    offset : float
        The candidate's height shift away from the level field, metres.
    relief : float
        The examples' relief, metres (the cost unit).
    weight : float, default OFFSET_WEIGHT
        The shift weight (:func:`anchor_weight`).

    Returns
    -------
    float
        ``ssd / relief**2 + weight * (offset / relief)**2``.  The
        shift penalty keeps the shifts from random-walking: without it the
        terrain drifts far outside the examples' heights over many patches.
    """
    return ssd / relief**2 + weight * (offset / relief) ** 2


def near_best_limit(best: float) -> float:
    """The dearest total cost still chosen beside a best of ``best``
    (:data:`NEAR_BEST`)."""
    return best + NEAR_BEST * abs(best)


def pick_near_best(totals, rng: np.random.Generator) -> int:
    """Index of a candidate drawn evenly among those whose total cost is
    within :data:`NEAR_BEST` of the cheapest.

    Parameters
    ----------
    totals : sequence of float, non-empty
        Each candidate's total cost (match, deformation and seam); a
        non-finite one is never picked (the first when all are).
    rng : numpy.random.Generator
        Seeded by the run: the same seed picks the same candidate.
    """
    totals = np.asarray(totals, dtype=np.float64)
    finite = np.isfinite(totals)
    if not finite.any():
        return 0
    near = np.flatnonzero(finite & (totals <= near_best_limit(float(totals[finite].min()))))
    return int(near[rng.integers(near.size)])


def choose_near_best(scored, seam_cost, rng: np.random.Generator) -> tuple:
    """The fill's and the feature patches' choice: candidates' seams cut
    cheapest first while they can still be near the best, then one picked
    by :func:`pick_near_best`.

    Parameters
    ----------
    scored : iterable of (float, object)
        Each candidate's score before its seam, cheapest first.
    seam_cost : callable
        ``seam_cost(candidate)`` -> ``(cost, made)``: the seam's cost (at
        least 0) and what cutting it made (kept for the one chosen).
    rng : numpy.random.Generator

    Returns
    -------
    (total, candidate, made)
        The chosen one, its total cost (score plus seam).
    """
    tried, best = [], math.inf
    for score, candidate in scored:
        if tried and score > near_best_limit(best):
            break  # cheapest first, and a seam never costs less than 0
        cost, made = seam_cost(candidate)
        tried.append((score + cost, candidate, made))
        best = min(best, score + cost)
    return tried[pick_near_best([t[0] for t in tried], rng)]
