"""Style-region and water-mask PNGs read into a document's layers.

A style-region PNG has one flat colour per style: each pixel takes the
document style whose colour is nearest (within the core's tolerance);
pixels near none, and transparent ones, are left to the plain examples.  A
water mask is dark paint on a light or transparent ground.  Maps of another
size than the sketch are resized to it by nearest cell.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from terrasynth_core.errors import ParamsError
from terrasynth_core.features.labels import read_label_map, read_mask

from .control_specs import StyleSpec
from .sketch_layers import NO_STYLE, resize_nearest


def style_layer_from_png(path, styles: Sequence[StyleSpec], shape: tuple[int, int]) -> np.ndarray:
    """Style ids of a style-region PNG.

    Parameters
    ----------
    path : str or Path
    styles : sequence of StyleSpec
        The document's styles; their colours are the map's legend.
    shape : (rows, cols)
        The sketch's size; the map is resized to it.

    Returns
    -------
    ndarray of int16, shape ``shape``
        Style id per cell, -1 where the map's colour is near no style's.

    Raises
    ------
    ParamsError
        When there are no styles to map colours to.
    SketchError
        When the file is not a readable image (the message names it).
    """
    if not styles:
        raise ParamsError("the document has no styles: add one per colour of the map in the Regions panel first")
    labels = read_label_map(path, [spec.color for spec in styles], default=True)
    # Label i is the i-th style; -1 (no style) looks up the last entry.
    ids = np.array([spec.id for spec in styles] + [NO_STYLE], np.int16)
    return resize_nearest(ids[labels], shape)


def water_layer_from_png(path, shape: tuple[int, int]) -> np.ndarray:
    """Water cells of a water-mask PNG (opaque pixels darker than mid-grey).

    Parameters
    ----------
    path : str or Path
    shape : (rows, cols)
        The sketch's size; the mask is resized to it.

    Returns
    -------
    ndarray of bool, shape ``shape``

    Raises
    ------
    SketchError
        When the file is not a readable image (the message names it).
    """
    return resize_nearest(read_mask(path), shape)
