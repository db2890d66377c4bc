"""Grayscale PNG heightmaps, with an optional JSON sidecar giving metres.

A PNG holds integer levels only.  What they mean comes from the sidecar
``<same stem>.json`` that :func:`write_png` writes (see
:func:`terrasynth_core.io._common.make_sidecar`): the height range the levels
span, the cell size, the georeference and the level reserved for nodata.
Without a sidecar the levels themselves are taken as heights.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import BinaryIO

import numpy as np
import rasterio
from PIL import Image
from rasterio.errors import NotGeoreferencedWarning

from ..errors import DEMFormatError
from ..heightfield import HeightField
from ._common import decode_levels, encode_levels, read_field, read_sidecar, sidecar_placement

#: Pillow modes whose pixels are gray levels already.
_GRAY_MODES = {"L": 255, "I;16": 65535, "I;16B": 65535, "I;16L": 65535, "I": 65535, "LA": 255}


def _gray_levels(image: Image.Image, path: Path) -> tuple[np.ndarray, int]:
    """The gray levels of ``image`` and the top level of its bit depth.

    Colour images are accepted only when every pixel has equal red, green and
    blue (a grayscale picture saved as RGB); the alpha channel is ignored.
    """
    if image.mode in _GRAY_MODES:
        levels = np.asarray(image)
        if levels.ndim == 3:  # LA: drop alpha
            levels = levels[..., 0]
        return levels, _GRAY_MODES[image.mode]
    if image.mode == "1":
        return np.asarray(image.convert("L")), 255
    rgb = np.asarray(image.convert("RGB"))
    red, green, blue = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    if not (np.array_equal(red, green) and np.array_equal(green, blue)):
        raise DEMFormatError(
            f"{path}: looks like a colour image (a sketch?), its {image.mode} channels differ; "
            "expected a grayscale heightmap"
        )
    return red, 255


#: PNG colour types with several samples per pixel: grey+alpha, RGB, RGBA.
_MULTI_SAMPLE_TYPES = {4: "grey+alpha", 2: "RGB", 6: "RGBA"}


def _png_header(path: Path) -> tuple[int, int] | None:
    """``(bit depth, colour type)`` from the PNG's IHDR, ``None`` if not a PNG."""
    with open(path, "rb") as fh:
        head = fh.read(26)
    if len(head) < 26 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return None
    return head[24], head[25]


def _wide_levels(path: Path, colour_type: int) -> tuple[np.ndarray, np.ndarray | None]:
    """16-bit levels of a grey+alpha, RGB or RGBA PNG, and its transparent cells.

    Pillow reduces such files to 8 bits, so they are read through GDAL, whose
    PNG driver keeps the 16-bit samples.  The colour bands must be equal (a
    grey heightmap saved in colour); alpha 0 marks nodata.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with rasterio.open(path) as ds:
            bands = ds.read()
    kind = _MULTI_SAMPLE_TYPES[colour_type]
    colours = bands[:1] if colour_type == 4 else bands[:3]
    alpha = bands[-1] if colour_type in (4, 6) else None
    if any(not np.array_equal(colours[0], c) for c in colours[1:]):
        raise DEMFormatError(
            f"{path}: a 16-bit {kind} colour image whose red, green and blue differ (a picture?); "
            "expected a grayscale heightmap (equal channels)"
        )
    return colours[0], (alpha == 0) if alpha is not None else None


def read_png(path: Path) -> HeightField:
    """Read an 8- or 16-bit grayscale PNG heightmap.

    Parameters
    ----------
    path : Path
        The PNG; an RGB or RGBA PNG with equal channels counts as grayscale.
        16-bit grey+alpha, RGB and RGBA files keep their 16 bits (read
        through GDAL; alpha 0 is nodata); 8-bit ones ignore alpha.

    Returns
    -------
    HeightField
        With a TerraSynth sidecar: heights in metres mapped from the levels
        (level 0 is nodata when the sidecar says so), cell size and
        georeference from the sidecar.  Without one: heights are the raw
        levels (0..255 or 0..65535), ``cell_size`` is ``None``.

    Raises
    ------
    DEMFormatError
        A colour image, or a file Pillow cannot decode.
    """
    header = _png_header(path)
    transparent = None
    if header is not None and header[0] == 16 and header[1] in _MULTI_SAMPLE_TYPES:
        (levels, transparent), top = _wide_levels(path, header[1]), 65535
    else:
        with Image.open(path) as image:
            if image.format != "PNG":
                raise DEMFormatError(f"{path}: content is {image.format}, not PNG")
            image.load()
            levels, top = _gray_levels(image, path)
    sidecar = read_sidecar(path)
    heights = decode_levels(levels, top, sidecar)
    if transparent is not None:
        heights[transparent] = np.nan
    return read_field(path, "png", heights, **sidecar_placement(sidecar),
                      metadata={"bit_depth": 8 if top == 255 else 16, "sidecar": sidecar is not None})


def write_png(field: HeightField, fh: BinaryIO, *, level_range: tuple[float, float] | None = None) -> dict:
    """Write ``field`` as a 16-bit grayscale PNG.

    Parameters
    ----------
    field : HeightField
    fh : binary file
        Open for writing.
    level_range : (low, high) metres, optional
        Heights of the first and last level (default min and max; see
        :func:`._common.encode_levels`).

    Returns
    -------
    dict
        The sidecar to save beside it: ``min``..``max`` map to levels
        0..65535, or 1..65535 with level 0 for nodata when there is nodata.
    """
    levels, sidecar = encode_levels(field, level_range=level_range)
    # Level 1 deflate: five times faster than Pillow's default for files
    # only about 5 % larger.
    Image.fromarray(levels).save(fh, format="PNG", compress_level=1)
    return sidecar
