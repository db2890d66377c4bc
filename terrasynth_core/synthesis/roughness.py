"""Where the fill puts the example's rougher and smoother windows.

Each fill window asks the search for a roughness quantile of the example's
windows (:meth:`~..matching.fill_search._WindowSearch.prior`).  One quantile
for all, the median, drew every window from the middle of the example's
roughness: the roughest third was never chosen and the output lost the
example's sharpest creases (Himalaya: |Laplacian| p99.9 at 0.63 of the
example's).  These targets spread evenly over :data:`LOWEST`-1 across the
map, a seeded field varying over about a patch, so rough and smooth ground
alternate at the scale real terrain's roughness does.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

#: The smoothest target quantile.  The overlap match itself leans to smooth
#: windows (the bias the prior is there for), so the smooth side needs no
#: targets of its own; targets down to 0 drew the examples' flattest windows
#: (Big Tujunga's basin floor, the Gabon coastal plain) as smooth slabs among
#: the mountains.  From the lower quartile: seam HF ratio 9 -> 11 of 15 runs in
#: range (Big Tujunga 0.79 -> 0.86, Himalaya 0.63 -> 0.76 on average).
LOWEST = 0.25
#: Cells of the coarse grid the targets are made on, per patch side.
CELLS_PER_PATCH = 4


def roughness_targets(shape: tuple[int, int], seed: int, patch_size: int) -> np.ndarray:
    """A roughness target quantile per output cell.

    Parameters
    ----------
    shape : (rows, cols)
    seed : int
        The run's seed.
    patch_size : int
        Cells; the targets vary over about a patch.

    Returns
    -------
    ndarray of float32, shape ``shape``
        Quantiles in [:data:`LOWEST`, 1], spread evenly over the map's cells.
    """
    rows, cols = shape
    step = max(1, patch_size // CELLS_PER_PATCH)
    cr, cc = -(-rows // step) + 1, -(-cols // step) + 1
    rng = np.random.default_rng([int(seed), 7])
    field = ndimage.gaussian_filter(rng.standard_normal((cr, cc)), CELLS_PER_PATCH, mode="reflect")
    # Ranks make the targets even over the map whatever the field's spread.
    ranks = np.empty(field.size)
    ranks[np.argsort(field.ravel(), kind="stable")] = np.linspace(0.0, 1.0, field.size)
    full = ndimage.zoom(ranks.reshape(cr, cc), (rows / (cr - 1), cols / (cc - 1)), order=1)
    return (LOWEST + (1.0 - LOWEST) * np.clip(full[:rows, :cols], 0.0, 1.0)).astype(np.float32)
