"""OpenEXR heightmaps: one 32-bit float channel of metres.

What Godot, Blender and Houdini read as a float heightfield: a scanline
image with a single ``Y`` (luminance) channel, ZIP-compressed (lossless), so
tools that expand grey images to RGB see the same metres in every channel.
Rows run north to south.  Nodata is stored as NaN.

The cell size and the georeference, which EXR cannot express, go into
custom header attributes (``terrasynth_cell_size_m``: ``[dy, dx]`` metres,
``terrasynth_units``: ``"metres"``, ``terrasynth_georef``: JSON), so the
file reads back into the same :class:`HeightField`.  Written and read with
the ``OpenEXR`` package (the Academy Software Foundation's own bindings).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import DEMFormatError
from ..heightfield import GeoReference, HeightField
from ._common import _georef_json, read_field

#: The channel holding the heights.
CHANNEL = "Y"
#: Header attribute with ``[dy, dx]`` in metres.
CELL_SIZE_ATTRIBUTE = "terrasynth_cell_size_m"
UNITS_ATTRIBUTE = "terrasynth_units"
GEOREF_ATTRIBUTE = "terrasynth_georef"


def write_exr(field: HeightField, path: Path, *, attributes: dict | None = None) -> None:
    """Write ``field`` as a float32 OpenEXR file at ``path`` (a new file).

    Parameters
    ----------
    field : HeightField
        Heights in metres, NaN nodata, shape (rows, cols).
    path : Path
        Destination (the caller makes it atomic).
    attributes : dict, optional
        Extra string or float header attributes (e.g. the preset's name).
    """
    import OpenEXR

    header = {
        "compression": OpenEXR.ZIP_COMPRESSION,
        "type": OpenEXR.scanlineimage,
        UNITS_ATTRIBUTE: "metres",
    }
    if field.cell_size is not None:
        header[CELL_SIZE_ATTRIBUTE] = np.asarray(field.cell_size, dtype=np.float32)
    if field.georef is not None:
        header[GEOREF_ATTRIBUTE] = json.dumps(_georef_json(field.georef))
    header.update(attributes or {})
    heights = np.ascontiguousarray(field.heights, dtype=np.float32)
    with OpenEXR.File(header, {CHANNEL: heights}) as exr:
        exr.write(str(path))


def read_exr(path: Path) -> HeightField:
    """Read a single-channel (``Y``, ``R`` or the only one) float OpenEXR heightmap.

    Returns
    -------
    HeightField
        Heights as stored (metres when TerraSynth wrote it), NaN nodata;
        cell size and georeference from the TerraSynth attributes if any.

    Raises
    ------
    DEMFormatError
        Not an EXR file, or several channels none of which is ``Y`` or ``R``.
    """
    import OpenEXR

    try:
        exr = OpenEXR.File(str(path))
    except RuntimeError as exc:  # the bindings' one error type: not an EXR, truncated
        raise DEMFormatError(f"{path}: not a readable OpenEXR file ({exc})") from exc
    with exr:
        # Copies: the bindings empty the header and channels when the file closes.
        header = {key: value for key, value in exr.header().items()}
        channels = exr.channels()
        names = list(channels)
        name = next((n for n in (CHANNEL, "R") if n in channels), names[0] if len(names) == 1 else None)
        if name is None:
            raise DEMFormatError(f"{path}: EXR channels {names} have no height channel; expected Y, R or one channel")
        heights = np.array(channels[name].pixels, dtype=np.float32)
    if heights.ndim != 2:
        raise DEMFormatError(f"{path}: EXR channel {name!r} has shape {heights.shape}; expected a 2-D image")
    cell = header.get(CELL_SIZE_ATTRIBUTE)
    cell_size = None if cell is None else tuple(float(v) for v in np.ravel(cell))
    georef = None
    if header.get(GEOREF_ATTRIBUTE):
        try:
            georef = GeoReference(**json.loads(header[GEOREF_ATTRIBUTE]))
        except (TypeError, ValueError) as exc:
            raise DEMFormatError(f"{path}: malformed {GEOREF_ATTRIBUTE} attribute: {exc}") from exc
    heights = np.where(np.isinf(heights), np.nan, heights).astype(np.float32)
    return read_field(path, "exr", heights, cell_size=cell_size, georef=georef,
                      metadata={"channel": name, "units": header.get(UNITS_ATTRIBUTE)})
