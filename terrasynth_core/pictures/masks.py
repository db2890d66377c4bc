"""Pictures of masks (splat maps): what the README sheet and the app's 2D
overlay show of :func:`terrasynth_core.export.terrain_masks`' arrays."""

from __future__ import annotations

import numpy as np

from .colours import patch_colours

#: Colours of the low, mid, high and peak height bands.
BAND_COLOURS = np.array([(60, 120, 60), (200, 190, 120), (140, 100, 70), (245, 245, 245)], dtype=np.float64)


def mask_picture(mask: np.ndarray) -> np.ndarray:
    """A mask as an RGB picture.

    Parameters
    ----------
    mask : ndarray, shape (rows, cols) or (rows, cols, 3 or 4)
        Float values in [0, 1] (one channel: grey; three: a normal map,
        shown as its colours; four: height bands, each in its colour of
        :data:`BAND_COLOURS`), or integer ids (style regions: one colour
        per id, 0 black).

    Returns
    -------
    ndarray of uint8, shape (rows, cols, 3)
    """
    values = np.asarray(mask)
    if np.issubdtype(values.dtype, np.integer):
        return patch_colours(values.astype(np.int64) - 1)[..., :3]  # id 0 (none): black
    values = np.clip(np.nan_to_num(values.astype(np.float64)), 0.0, 1.0)
    if values.ndim == 2:
        return np.repeat(np.rint(values * 255).astype(np.uint8)[..., None], 3, axis=2)
    if values.shape[2] == 4:
        return np.clip(np.rint(values @ BAND_COLOURS), 0, 255).astype(np.uint8)
    return np.rint(values[..., :3] * 255).astype(np.uint8)
