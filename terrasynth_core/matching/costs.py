"""The match cost of a candidate patch (paper §4.1-4.2, with a level anchor).

A candidate is scored by its mismatch with the terrain already in its
window (the overlap SSD after the best vertical shift) plus a penalty on
how far that shift moves it from the level field.  Both are in units of the
example's relief squared, so costs of examples with different reliefs
compare, and the graph-cut cost (also relief-normalised) adds to them.
"""

from __future__ import annotations

import numpy as np

#: Weight of the squared height shift (in reliefs) against the overlap SSD.
OFFSET_WEIGHT = 0.2

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


def settle(ssd: float, offset: float, mean: float = 0.0) -> tuple[float, float]:
    """The height shift that minimises the match cost, and the SSD it leaves.

    The cost is the overlap SSD plus ``OFFSET_WEIGHT * (shift + mean)**2``
    (both over the relief squared), where ``mean`` is the candidate's mean
    detail (0 to anchor the shift alone): its minimiser is
    ``(offset - w mean) / (1 + w)`` for the SSD-optimal ``offset``.

    Parameters
    ----------
    ssd : float
        Overlap SSD at the SSD-optimal shift, metres squared.
    offset : float
        That shift, metres.
    mean : float, default 0
        The candidate's mean detail height, metres.

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
    settled = (offset - OFFSET_WEIGHT * mean) / (1.0 + OFFSET_WEIGHT)
    return ssd + (offset - settled) ** 2, settled


def match_cost(ssd: float, offset: float, relief: float) -> float:
    """Overlap mismatch and level shift of a candidate, in reliefs squared.

    Parameters
    ----------
    ssd : float
        Overlap SSD, metres squared.
    offset : float
        The candidate's height shift away from the level field, metres.
    relief : float
        The examples' relief, metres (the cost unit).

    Returns
    -------
    float
        ``ssd / relief**2 + OFFSET_WEIGHT * (offset / relief)**2``.  The
        shift penalty keeps the shifts from random-walking: without it the
        terrain drifts far outside the examples' heights over many patches.
    """
    return ssd / relief**2 + OFFSET_WEIGHT * (offset / relief) ** 2
