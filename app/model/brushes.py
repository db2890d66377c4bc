"""The round brush every sketch tool and the selection brush paint with."""

from __future__ import annotations

import numpy as np

from .history import BBox


def capsule_coverage(shape: tuple[int, int], p0: tuple[float, float], p1: tuple[float, float],
                     radius: float, hardness: float) -> tuple[BBox | None, np.ndarray]:
    """Brush intensity of a round brush dragged from ``p0`` to ``p1``.

    Parameters
    ----------
    shape : (rows, cols)
        Grid the brush paints on.
    p0, p1 : (row, col)
        Segment ends in cell units.
    radius : float
        Brush radius in cells.
    hardness : float in [0, 1]
        Width of the linear fall-off is ``(1 - hardness) * radius`` cells
        (at least one); intensity is one half at the radius.

    Returns
    -------
    bbox : (r0, r1, c0, c1) or None
        Window of cells the brush reaches inside the grid (None if none).
    coverage : ndarray of uint8, shape of ``bbox``
        Intensity 0-255 of the brush on each cell of the window.
    """
    rows, cols = shape
    (ra, ca), (rb, cb) = p0, p1
    # Intensity falls linearly over ``falloff`` cells centred on the radius,
    # so the stroked cells (at least half intensity) are those within the
    # radius for any hardness.  At least one cell of fall-off even for a hard
    # brush: an anti-aliased edge.
    falloff = max((1.0 - hardness) * radius, 1.0)
    reach = radius + 0.5 * falloff
    r0 = max(int(np.floor(min(ra, rb) - reach)), 0)
    r1 = min(int(np.ceil(max(ra, rb) + reach)) + 1, rows)
    c0 = max(int(np.floor(min(ca, cb) - reach)), 0)
    c1 = min(int(np.ceil(max(ca, cb) + reach)) + 1, cols)
    if r0 >= r1 or c0 >= c1:
        return None, np.zeros((0, 0), np.uint8)
    rr, cc = np.ogrid[r0:r1, c0:c1]
    dr, dc = rb - ra, cb - ca
    length2 = dr * dr + dc * dc
    if length2 > 0:
        t = np.clip(((rr - ra) * dr + (cc - ca) * dc) / length2, 0.0, 1.0)
    else:
        t = 0.0
    dist = np.hypot(rr - (ra + t * dr), cc - (ca + t * dc))
    coverage = np.clip((radius - dist) / falloff + 0.5, 0.0, 1.0)
    coverage = np.rint(coverage * 255).astype(np.uint8)
    if not coverage.any():
        return None, np.zeros((0, 0), np.uint8)
    return (r0, r1, c0, c1), coverage
