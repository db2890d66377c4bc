"""NumPy ``.npy`` grids, with the optional JSON sidecar for placement."""

from __future__ import annotations

from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..errors import DEMFormatError
from ..heightfield import HeightField
from ._common import (apply_sidecar_nodata, fill_value_nodata, make_sidecar, read_field, read_sidecar,
                      sidecar_placement)


def read_npy(path: Path) -> HeightField:
    """Read a 2-D numeric ``.npy`` array of heights in metres.

    Parameters
    ----------
    path : Path
        Any real integer or float dtype; pickled objects are refused.

    Returns
    -------
    HeightField
        NaN stays nodata; with a TerraSynth sidecar, its ``nodata_value``
        also becomes NaN and its cell size and georeference are used.
        Without a sidecar's nodata value, conventional fill values are
        nodata (:func:`~._common.fill_value_nodata`: -9999, -32767, the
        integer type's lowest value such as SRTM's -32768, floats below
        -1e30), named in ``metadata["nodata_value"]``.

    Raises
    ------
    DEMFormatError
        Not an ``.npy`` array, not 2-D, or not real numbers.
    """
    array = np.load(path, allow_pickle=False)
    if not isinstance(array, np.ndarray):
        array.close()  # an .npz archive opened as a zip file
        raise DEMFormatError(f"{path}: holds an archive of several arrays; expected a single .npy array")
    if array.ndim != 2:
        raise DEMFormatError(f"{path}: array of shape {array.shape}; expected a 2-D grid")
    if array.dtype.kind not in "iuf":
        raise DEMFormatError(f"{path}: array of type {array.dtype}; expected real integer or float heights")
    sidecar = read_sidecar(path)
    heights = apply_sidecar_nodata(array, sidecar)
    metadata = {"dtype": str(array.dtype), "sidecar": sidecar is not None}
    if sidecar is None or sidecar.get("nodata_value") is None:
        # No file says what nodata is: a conventional fill value is.
        fill = fill_value_nodata(array, heights)
        if fill is not None:
            metadata["nodata_value"] = fill
    return read_field(path, "npy", heights, **sidecar_placement(sidecar), metadata=metadata)


def write_npy(field: HeightField, fh: BinaryIO) -> dict:
    """Write ``field`` as a float32 ``.npy`` array, NaN for nodata.

    Returns
    -------
    dict
        The sidecar carrying cell size and georeference (``.npy`` cannot).
    """
    np.save(fh, field.heights, allow_pickle=False)
    return make_sidecar(field, nodata_value=None)
