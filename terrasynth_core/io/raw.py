"""Headerless raw heightmaps: ``.r16`` (little-endian uint16, Unity's RAW)
and ``.r32`` (little-endian float32 metres).

Rows run north to south as everywhere in TerraSynth (Unity's import may
need "Flip Vertically").  The file says nothing about its shape: it comes
from the caller's ``size``, else from the sidecar, else the grid must be
square.  ``.r16`` levels map to metres through the sidecar, as for PNG.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..errors import DEMFormatError, ParamsError
from ..heightfield import HeightField
from ._common import (
    apply_sidecar_nodata,
    decode_levels,
    encode_levels,
    make_sidecar,
    read_field,
    read_sidecar,
    sidecar_placement,
)


def _grid_shape(path: Path, count: int, size, sidecar: dict | None) -> tuple[int, int]:
    """``(rows, cols)`` of a raw file holding ``count`` values."""
    if size is not None:
        try:
            rows, cols = (int(v) for v in size)
        except (TypeError, ValueError) as exc:
            raise ParamsError(f"size must be (rows, cols), got {size!r}") from exc
        if rows < 1 or cols < 1:
            raise ParamsError(f"size must be positive (rows, cols), got {size!r}")
    elif sidecar is not None and sidecar.get("shape") is not None:
        rows, cols = sidecar["shape"]
    else:
        side = math.isqrt(count)
        if side * side != count:
            raise DEMFormatError(
                f"{path}: {count} values do not make a square grid; pass size=(rows, cols)"
            )
        rows = cols = side
    if rows * cols != count:
        raise DEMFormatError(f"{path}: holds {count} values; size {rows} x {cols} needs {rows * cols}")
    return rows, cols


def _read_raw(path: Path, fmt: str, size) -> HeightField:
    """Read an ``r16`` or ``r32`` file (``fmt``) of shape ``size``, else the sidecar's, else square."""
    dtype = np.dtype("<u2" if fmt == "r16" else "<f4")
    nbytes = path.stat().st_size
    if nbytes % dtype.itemsize:
        raise DEMFormatError(f"{path}: {nbytes} bytes is not a whole number of {dtype.itemsize}-byte values")
    sidecar = read_sidecar(path)
    rows, cols = _grid_shape(path, nbytes // dtype.itemsize, size, sidecar)
    values = np.fromfile(path, dtype=dtype).reshape(rows, cols)
    heights = decode_levels(values, 65535, sidecar) if fmt == "r16" else apply_sidecar_nodata(values, sidecar)
    return read_field(path, fmt, heights, **sidecar_placement(sidecar), metadata={"sidecar": sidecar is not None})


def read_r16(path: Path, *, size: tuple[int, int] | None = None) -> HeightField:
    """Read a little-endian uint16 raw heightmap.

    Parameters
    ----------
    path : Path
    size : (rows, cols), optional
        Grid shape; by default the sidecar's, else square.

    Returns
    -------
    HeightField
        Heights in metres through the sidecar (level 0 is nodata when it
        says so), else the raw levels; cell size and georeference from the
        sidecar.
    """
    return _read_raw(path, "r16", size)


def read_r32(path: Path, *, size: tuple[int, int] | None = None) -> HeightField:
    """Read a little-endian float32 raw heightmap in metres; ``size`` as in :func:`read_r16`.

    Returns
    -------
    HeightField
        NaN (and the sidecar's ``nodata_value``, if any) as nodata; cell
        size and georeference from the sidecar.
    """
    return _read_raw(path, "r32", size)


def write_r16(field: HeightField, fh: BinaryIO, *, level_range: tuple[float, float] | None = None) -> dict:
    """Write 16-bit levels spanning min..max (or ``level_range``); returns the sidecar (see PNG)."""
    levels, sidecar = encode_levels(field, level_range=level_range)
    fh.write(levels.astype("<u2").tobytes())
    return sidecar


def write_r32(field: HeightField, fh: BinaryIO) -> dict:
    """Write float32 metres, NaN for nodata; returns the sidecar (shape, placement)."""
    fh.write(field.heights.astype("<f4").tobytes())
    return make_sidecar(field, nodata_value=None)
