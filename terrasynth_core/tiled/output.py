"""The tiled run's output: one tiled, compressed GeoTIFF written band by
band from the finished tiles on disk, never holding the whole terrain.

The file is GDAL's GeoTIFF as :func:`terrasynth_core.io.save_dem` writes
it (float32, 256 x 256 blocks, DEFLATE with the floating-point predictor,
NaN nodata, the run's map placement), readable by GDAL, rasterio and every
GIS; BigTIFF when it needs to be (over 4 GB).  The rows are written in
bands of one block, each block once and in order, so the file's bytes do
not depend on which tile finished first.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rasterio
from affine import Affine
from rasterio.errors import NotGeoreferencedWarning
from rasterio.windows import Window

from ..heightfield import GeoReference
from ..io._common import atomic_outputs, wrap_errors
from ..io.gdal import NO_GEOREF_TAG, field_crs, georef_transform
from .plan import TilePlan
from .store import TileStore, compose

__all__ = ["BLOCK", "Written", "write_geotiff_from_tiles"]

#: GeoTIFF block side, cells (as the project's other GeoTIFFs).
BLOCK = 256


@dataclass(frozen=True)
class Written:
    """What :func:`write_geotiff_from_tiles` wrote: the file and its height
    range (metres)."""

    path: Path
    shape: tuple[int, int]
    lowest: float
    highest: float


def write_geotiff_from_tiles(store: TileStore, plan: TilePlan, out: Path, *, cell_size: float | None,
                             georef: GeoReference | None, adjust=None) -> Written:
    """Write the finished tiles of ``plan`` as one GeoTIFF at ``out``.

    Parameters
    ----------
    store : TileStore
        Holding every tile of ``plan``.
    plan : TilePlan
    out : Path
        A ``.tif``/``.tiff`` path; replaced atomically.
    cell_size : float or None
        Metres (None: unknown, written without placement).
    georef : GeoReference or None
        The output's placement on the map.
    adjust : callable, optional
        ``adjust(box, heights)`` returns the heights to write over ``box``
        (output cells) given the tiles' (the drainage's corrections,
        :meth:`.drainage.TiledSurface.corrected`).

    Returns
    -------
    Written
    """
    rows, cols = plan.shape
    tags = {}
    if georef is not None:
        transform = georef_transform(georef)
    elif cell_size is not None:
        transform = Affine(cell_size, 0.0, 0.0, 0.0, -cell_size, 0.0)
        tags[NO_GEOREF_TAG] = "1"
    else:
        transform = Affine.identity()
    profile = dict(driver="GTiff", width=cols, height=rows, count=1, dtype="float32", nodata=float("nan"),
                   crs=field_crs(georef), transform=transform, tiled=True, blockxsize=BLOCK, blockysize=BLOCK,
                   compress="DEFLATE", predictor=3, zlevel=1, BIGTIFF="IF_SAFER")
    lowest, highest = np.inf, -np.inf
    out = Path(out)
    with wrap_errors(out, "write"), atomic_outputs(out) as (tmp,), \
            rasterio.Env(GDAL_PAM_ENABLED="NO"), warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with rasterio.open(tmp, "w", **profile) as ds:
            for b0 in range(0, rows, BLOCK):
                band = _band(store, plan, b0, min(b0 + BLOCK, rows))
                if adjust is not None:
                    band = adjust((b0, b0 + band.shape[0], 0, cols), band)
                lowest, highest = min(lowest, float(band.min())), max(highest, float(band.max()))
                ds.write(band, 1, window=Window(0, b0, cols, band.shape[0]))
            ds.update_tags(**tags)
    return Written(out, (rows, cols), lowest, highest)


def _band(store: TileStore, plan: TilePlan, b0: int, b1: int) -> np.ndarray:
    """Rows ``b0..b1`` of the output, from the tiles under them (memory-mapped)."""
    return compose(store, plan, (b0, b1, 0, plan.shape[1]))
