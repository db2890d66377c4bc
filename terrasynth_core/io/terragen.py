"""Terragen terrain files (``.ter``).

Little-endian: the 16-byte magic ``TERRAGENTERRAIN ``, then tagged chunks:
``SIZE`` (int16 shortest side - 1, 2 bytes padding), ``XPTS``/``YPTS``
(int16 columns/rows, padding), ``SCAL`` (3 float32: metres per terrain unit
along x, y, z), ``CRAD`` (float32 planet radius), ``CRVM`` (uint32 curvature
mode), ``ALTW`` (int16 HeightScale, int16 BaseHeight, then rows x cols int16
elevations) and ``EOF ``.  Grid points are one terrain unit apart, so SCAL is
also the cell size.  The first stored row is the *southern* edge.

Heights in metres are ``(BaseHeight + elevation * HeightScale / 65536) * SCAL_z``.
Terragen itself expects the three SCAL values to be equal; GDAL takes the
vertical scale from SCAL_y, so :func:`write_terragen` writes SCAL_z = SCAL_y.
"""

from __future__ import annotations

import math
import struct
from pathlib import Path
from typing import BinaryIO

import numpy as np

from ..errors import DEMFormatError
from ..heightfield import HeightField
from ._common import read_field

MAGIC = b"TERRAGENTERRAIN "

#: Metres per terrain unit when the file has no SCAL chunk, as in Terragen.
DEFAULT_SCALE = 30.0

INT16_MAX = 32767


def read_terragen(path: Path) -> HeightField:
    """Read the Terragen ``.ter`` terrain at ``path``.

    Returns
    -------
    HeightField
        North-up heights in metres (the file's rows flipped), ``cell_size``
        ``(SCAL_y, SCAL_x)``; no georeference (Terragen has none).

    Raises
    ------
    DEMFormatError
        Wrong magic, unknown chunk, missing size or ALTW chunk, truncated
        elevations.
    """
    content = path.read_bytes()
    if not content.startswith(MAGIC):
        raise DEMFormatError(f"{path}: does not start with {MAGIC.decode()!r}; not a Terragen terrain")
    pos = len(MAGIC)
    size = xpts = ypts = None
    scale = (DEFAULT_SCALE,) * 3
    while True:
        marker = content[pos : pos + 4]
        pos += 4
        if marker == b"ALTW":
            break
        if marker in (b"SIZE", b"XPTS", b"YPTS"):
            (value,) = struct.unpack_from("<h", content, pos)
            pos += 4  # int16 and 2 bytes padding
            if marker == b"SIZE":
                size = value
            elif marker == b"XPTS":
                xpts = value
            else:
                ypts = value
        elif marker == b"SCAL":
            scale = struct.unpack_from("<3f", content, pos)
            pos += 12
        elif marker in (b"CRAD", b"CRVM"):
            pos += 4
        elif marker in (b"EOF ", b""):
            raise DEMFormatError(f"{path}: no ALTW chunk; the file holds no elevations")
        else:
            raise DEMFormatError(f"{path}: unknown chunk {marker!r} at byte {pos - 4}")
    if size is None and (xpts is None or ypts is None):
        raise DEMFormatError(f"{path}: no SIZE chunk (nor XPTS and YPTS); grid size unknown")
    cols = xpts if xpts is not None else size + 1
    rows = ypts if ypts is not None else size + 1
    height_scale, base_height = struct.unpack_from("<hh", content, pos)
    pos += 4
    count = rows * cols
    if rows < 1 or cols < 1 or len(content) < pos + 2 * count:
        raise DEMFormatError(
            f"{path}: truncated: {rows} x {cols} elevations need {pos + 2 * count} bytes, "
            f"file has {len(content)}"
        )
    elevations = np.frombuffer(content, dtype="<i2", count=count, offset=pos).reshape(rows, cols)
    units = base_height + elevations * (height_scale / 65536.0)
    heights = (units * scale[2])[::-1].astype(np.float32)
    return read_field(path, "terragen", heights, cell_size=(scale[1], scale[0]),
                      metadata={"height_scale": height_scale, "base_height": base_height, "scale": tuple(scale)})


def write_terragen(field: HeightField, fh: BinaryIO) -> None:
    """Write ``field`` as a Terragen ``.ter`` terrain.

    SCAL is the cell size (``(dx, dy, dy)``; 30 m when unknown).  BaseHeight
    is the centre of the height range and HeightScale the smallest integer
    that lets int16 elevations cover it, so the quantisation error is at most
    ``(range + 2 * SCAL) / 131072`` metres: below ``range / 30000`` whenever
    the range exceeds about 0.6 SCAL (18 m at 30 m cells).  Nodata cells are
    filled with the minimum height: the format has no nodata.

    Parameters
    ----------
    field : HeightField
    fh : binary file
        Open for writing.

    Raises
    ------
    DEMFormatError
        More than 32767 rows or columns, or heights beyond +-32767 SCAL.
    """
    rows, cols = field.shape
    if max(rows, cols) > INT16_MAX:
        raise DEMFormatError(f"grid of {rows} x {cols} cells; Terragen holds at most {INT16_MAX} per side")
    dy, dx = field.cell_size or (DEFAULT_SCALE, DEFAULT_SCALE)
    units = np.where(field.nodata, field.min, field.heights).astype(np.float64) / dy
    low, high = float(units.min()), float(units.max())
    base_height = round((low + high) / 2)
    half_range = max(high - base_height, base_height - low)
    height_scale = max(1, math.ceil(half_range * 65536 / INT16_MAX))
    if height_scale > INT16_MAX or abs(base_height) > INT16_MAX:
        raise DEMFormatError(
            f"heights {field.min:.1f}..{field.max:.1f} m do not fit Terragen's int16 range "
            f"at {dy} m per unit"
        )
    elevations = np.rint((units - base_height) * (65536 / height_scale))
    elevations = np.clip(elevations, -INT16_MAX - 1, INT16_MAX).astype("<i2")[::-1]

    fh.write(MAGIC)
    fh.write(b"SIZE" + struct.pack("<hh", min(rows, cols) - 1, 0))
    fh.write(b"XPTS" + struct.pack("<hh", cols, 0))
    fh.write(b"YPTS" + struct.pack("<hh", rows, 0))
    fh.write(b"SCAL" + struct.pack("<3f", dx, dy, dy))
    fh.write(b"ALTW" + struct.pack("<hh", height_scale, base_height))
    fh.write(np.ascontiguousarray(elevations).tobytes())
    # The specification aligns chunks to 4 bytes, EOF included.
    if elevations.size % 2:
        fh.write(b"\x00\x00")
    fh.write(b"EOF ")
