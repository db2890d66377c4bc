"""SRTM ``.hgt`` tiles: square grids of big-endian int16 heights in metres.

A tile covers one degree by one degree; its name (``N44W072.hgt``) gives the
latitude and longitude of its south-west corner.  Samples sit *on* the
degree lines, so a 3 arc-second tile has 1201 x 1201 samples and adjacent
tiles share their edge rows and columns.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import DEMFormatError
from ..heightfield import GeoReference, HeightField, geographic_cell_size
from ._common import read_field

#: Samples per side by file size in bytes: 3 arc-second and 1 arc-second tiles.
TILE_SIDES = {1201 * 1201 * 2: 1201, 3601 * 3601 * 2: 3601}

#: Value of SRTM voids.
VOID = -32768

_NAME = re.compile(r"([NS])(\d{1,2})([EW])(\d{1,3})", re.IGNORECASE)


def parse_tile_name(name: str) -> tuple[int, int] | None:
    """Latitude and longitude of the south-west corner from a tile name.

    Parameters
    ----------
    name : str
        File name such as ``"N44W072.hgt"`` or ``"s01e010.hgt"``.

    Returns
    -------
    (lat, lon) : tuple of int, or None
        Degrees, south and west negative; ``None`` when the name does not
        start with a tile code.
    """
    match = _NAME.match(name)
    if match is None:
        return None
    ns, lat, ew, lon = match.groups()
    lat_deg = int(lat) * (-1 if ns.upper() == "S" else 1)
    lon_deg = int(lon) * (-1 if ew.upper() == "W" else 1)
    if not (-90 <= lat_deg < 90 and -180 <= lon_deg < 180):
        return None
    return lat_deg, lon_deg


def read_hgt(path: Path) -> HeightField:
    """Read an SRTM ``.hgt`` tile.

    Parameters
    ----------
    path : Path
        A 1201 x 1201 (3") or 3601 x 3601 (1") tile.

    Returns
    -------
    HeightField
        Heights in metres, voids (-32768) as NaN.  When the file name parses,
        ``georef`` is in EPSG:4326 with the origin at the upper-left corner of
        the upper-left cell (half a cell west and north of the tile's
        north-west sample) and ``cell_size`` is the ground size at the tile's
        centre latitude (cells are narrower east-west than north-south away
        from the equator).  Otherwise both are ``None``.

    Raises
    ------
    DEMFormatError
        If the file size is not that of a 1201 or 3601 square tile.
    """
    size = path.stat().st_size
    side = TILE_SIDES.get(size)
    if side is None:
        expected = " or ".join(f"{n} bytes ({s}x{s})" for n, s in TILE_SIDES.items())
        raise DEMFormatError(f"{path}: SRTM tile of {size} bytes; expected {expected}")
    raw = np.fromfile(path, dtype=">i2").reshape(side, side)
    heights = raw.astype(np.float32)
    heights[raw == VOID] = np.nan

    corner = parse_tile_name(path.name)
    georef = cell_size = None
    if corner is not None:
        lat, lon = corner
        step = 1.0 / (side - 1)
        georef = GeoReference(
            x_origin=lon - step / 2,
            y_origin=lat + 1 + step / 2,
            x_step=step,
            y_step=step,
            epsg=4326,
        )
        cell_size = geographic_cell_size(lat + 0.5, step)
    return read_field(path, "hgt", heights, cell_size=cell_size, georef=georef,
                      metadata={"arc_seconds": 3 if side == 1201 else 1})
