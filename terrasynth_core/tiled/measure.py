"""Whether tile borders show: the seam measure of a tiled run's output."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from .plan import TilePlan

__all__ = ["BORDER_BAND", "border_ratio"]

#: Width of the band measured along each inner tile border, cells.
BORDER_BAND = 8

#: The percentile compared: the sharpest creases, where a seam would show.
PERCENTILE = 99.9


def border_ratio(heights: np.ndarray, plan: TilePlan, *, band: int = BORDER_BAND,
                 exclude: np.ndarray | None = None) -> float:
    """|Laplacian| at the :data:`PERCENTILE` in ``band``-cell bands centred
    on the inner tile borders, over the same in the tiles' interiors.

    A step or a crease where two tiles meet raises the curvature along the
    border; about 1 means the borders are as smooth or as rough as the
    terrain elsewhere.

    Parameters
    ----------
    heights : ndarray of float, shape ``plan.shape``
        Metres.
    plan : TilePlan
    band : int, default :data:`BORDER_BAND`
    exclude : ndarray of bool, shape ``plan.shape``, optional
        Cells left out of both sides: a drawn stroke's crest is the
        sharpest ground of a small map, and where it crosses a border it
        decides the band's percentile, seam or none.

    Returns
    -------
    float
        NaN for a single tile (no inner border), or when ``exclude``
        leaves no cell on one side.
    """
    heights = np.asarray(heights, np.float64)
    if heights.shape != tuple(plan.shape):
        raise ValueError(f"heights are {heights.shape}, the plan {plan.shape}")
    if exclude is not None and np.shape(exclude) != heights.shape:
        raise ValueError(f"the mask left out is {np.shape(exclude)}, the heights {heights.shape}")
    lap = np.abs(ndimage.laplace(heights))
    near = np.zeros(heights.shape, bool)
    half = band // 2
    for e in plan.row_edges[1:-1]:
        near[max(e - half, 0):e + band - half, :] = True
    for e in plan.col_edges[1:-1]:
        near[:, max(e - half, 0):e + band - half] = True
    keep = np.ones(heights.shape, bool) if exclude is None else ~np.asarray(exclude, bool)
    if not (near & keep).any() or not (~near & keep).any():
        return float("nan")
    return float(np.percentile(lap[near & keep], PERCENTILE) / np.percentile(lap[~near & keep], PERCENTILE))
