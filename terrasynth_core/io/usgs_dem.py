"""USGS ASCII DEM (``.dem``), the classic quadrangle format.

The file is a 1024-byte "A" record (header, fixed columns, Fortran ``D``
exponents) followed by one "B" record per profile.  A profile is a column
of the grid running south to north: ``row col m n x y z_datum z_min z_max``
then ``m`` integer elevations.  Profiles of a UTM quadrangle start and end at
different northings (its edges are not grid lines), so each is placed by its
starting ``y``; cells outside every profile are nodata.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import DEMFormatError
from ..heightfield import GeoReference, HeightField
from ._common import geographic_cell, read_field

A_RECORD_BYTES = 1024

#: Elevations at or below this value are voids (-32767 in the standard).
VOID_LIMIT = -32767

# 0-based byte slices of the A record fields used here
_PLANIMETRIC_SYSTEM = slice(156, 162)  # 0 geographic, 1 UTM, 2 state plane
_ZONE = slice(162, 168)
_GROUND_UNITS = slice(528, 534)  # 0 radians, 1 feet, 2 metres, 3 arc-seconds
_ELEVATION_UNITS = slice(534, 540)  # 1 feet, 2 metres
_RESOLUTION = (slice(816, 828), slice(828, 840), slice(840, 852))
_PROFILES = slice(858, 864)
_HORIZONTAL_DATUM = slice(890, 892)  # 1 NAD27, 2 WGS72, 3 WGS84, 4 NAD83

FEET = 0.3048

#: EPSG of UTM zone 1 north / south, and of the geographic CRS, per datum code.
_UTM_NORTH = {1: 26700, 2: 32200, 3: 32600, 4: 26900}
_UTM_SOUTH = {2: 32300, 3: 32700}
_GEOGRAPHIC = {1: 4267, 2: 4322, 3: 4326, 4: 4269}

# A number: a sign starts a new one unless it follows an exponent letter, so
# touching fields such as "-32767-32767" still split in two.
_NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[EeDd][-+]?\d+)?")


def _field(record: bytes, where: slice, path: Path, name: str, default: float | None = None) -> float:
    text = record[where].strip().replace(b"D", b"E").replace(b"d", b"e")
    if not text:
        if default is None:
            raise DEMFormatError(f"{path}: A record has no {name}")
        return default
    try:
        return float(text)
    except ValueError as exc:
        raise DEMFormatError(f"{path}: A record {name} is {text!r}; expected a number") from exc


def read_usgs_dem(path: Path) -> HeightField:
    """Read a USGS ASCII DEM.

    Parameters
    ----------
    path : Path

    Returns
    -------
    HeightField
        North-up heights in metres: ``z_datum + value * z_resolution``, feet
        converted when the elevation unit code says feet; voids and cells
        outside the quadrangle are NaN.  ``cell_size`` is the x/y resolution
        (metres for UTM, from latitude for arc-second grids); ``georef`` puts
        the upper-left cell corner half a cell west and north of the
        north-westernmost node, with an EPSG code when the header names the
        horizontal datum.

    Raises
    ------
    DEMFormatError
        A record too short or malformed, a truncated profile, or a profile
        count that does not match the header.
    """
    content = path.read_bytes()
    if len(content) < A_RECORD_BYTES:
        raise DEMFormatError(
            f"{path}: {len(content)} bytes; a USGS DEM starts with a {A_RECORD_BYTES}-byte A record"
        )
    a_record = content[:A_RECORD_BYTES]
    system = int(_field(a_record, _PLANIMETRIC_SYSTEM, path, "planimetric system"))
    zone = int(_field(a_record, _ZONE, path, "zone", 0))
    ground_units = int(_field(a_record, _GROUND_UNITS, path, "ground unit code"))
    elevation_units = int(_field(a_record, _ELEVATION_UNITS, path, "elevation unit code"))
    x_res, y_res, z_res = (_field(a_record, s, path, "resolution") for s in _RESOLUTION)
    n_profiles = int(_field(a_record, _PROFILES, path, "profile count"))
    datum = int(_field(a_record, _HORIZONTAL_DATUM, path, "horizontal datum", 0))
    if not (x_res > 0 and y_res > 0 and z_res > 0 and n_profiles >= 2):
        raise DEMFormatError(
            f"{path}: A record gives resolution ({x_res}, {y_res}, {z_res}) and "
            f"{n_profiles} profiles; expected positive resolutions and at least 2 profiles"
        )

    body = content[A_RECORD_BYTES:].replace(b"D", b"E").replace(b"d", b"e")
    numbers = np.array(_NUMBER.findall(body), dtype=np.float64)
    profiles = []  # (x, y, z_datum, elevations south to north)
    at = 0
    for index in range(n_profiles):
        if at + 9 > numbers.size:
            raise DEMFormatError(f"{path}: truncated: {n_profiles} profiles expected, {index} found")
        m = int(numbers[at + 2])
        x, y, z_datum = numbers[at + 4 : at + 7]
        values = numbers[at + 9 : at + 9 + m]
        if m < 1 or values.size < m:
            raise DEMFormatError(f"{path}: profile {index + 1} is truncated ({values.size} of {m} elevations)")
        profiles.append((x, y, z_datum, values))
        at += 9 + m

    xs = np.array([p[0] for p in profiles])
    ys = np.array([p[1] for p in profiles])
    x_min, y_min = float(xs.min()), float(ys.min())
    col_of = np.rint((xs - x_min) / x_res).astype(np.int64)
    first_row = np.rint((ys - y_min) / y_res).astype(np.int64)
    rows = int(max(r + p[3].size for r, p in zip(first_row, profiles)))
    cols = int(col_of.max()) + 1
    unit = FEET if elevation_units == 1 else 1.0
    grid = np.full((rows, cols), np.nan, dtype=np.float64)  # row 0 = south here
    for (_, _, z_datum, values), col, row in zip(profiles, col_of, first_row):
        grid[row : row + values.size, col] = np.where(
            values <= VOID_LIMIT, np.nan, (z_datum + values * z_res) * unit
        )
    heights = grid[::-1].astype(np.float32)

    # Nodes are cell centres: the corner is half a cell beyond the outer nodes.
    x_origin = x_min - x_res / 2
    y_origin = y_min + (rows - 1) * y_res + y_res / 2
    if ground_units == 3:  # arc-seconds: a geographic grid
        to_deg = 1 / 3600
        georef = GeoReference(
            x_origin * to_deg, y_origin * to_deg, x_res * to_deg, y_res * to_deg, _GEOGRAPHIC.get(datum)
        )
        lat = (y_min + (rows - 1) * y_res / 2) * to_deg
        cell_size = geographic_cell(lat, y_res * to_deg, x_res * to_deg)
    else:
        epsg = None
        if system == 1 and zone:
            table = _UTM_SOUTH if zone < 0 else _UTM_NORTH
            epsg = table[datum] + abs(zone) if datum in table else None
        metres = FEET if ground_units == 1 else 1.0
        georef = GeoReference(x_origin, y_origin, x_res, y_res, epsg)
        cell_size = (y_res * metres, x_res * metres)
    metadata = {
        "title": a_record[:40].decode("latin-1").strip(),
        "utm_zone": zone if system == 1 else None,
        "horizontal_datum_code": datum or None,
    }
    return read_field(path, "usgs-dem", heights, cell_size=cell_size, georef=georef, metadata=metadata)
