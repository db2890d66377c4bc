"""Pictures to PNG files: atomic, optionally scaled down or quantized."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image

from ..errors import ParamsError
from ..io._common import atomic_outputs, open_new


def _quantized(image: Image.Image, colours: int) -> Image.Image:
    return image.quantize(colors=colours, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)


def _png_bytes(image: Image.Image) -> bytes:
    buffer = io.BytesIO()
    image.save(buffer, format="PNG", optimize=True)
    return buffer.getvalue()


def save_png(picture, path, *, max_width: int | None = None, colours: int | None = None,
             max_bytes: int | None = None) -> Path:
    """Write a picture as PNG.

    Parameters
    ----------
    picture : ndarray of uint8, shape (rows, cols, 3) or (rows, cols, 4), or PIL Image
        RGB or RGBA.
    path : str or Path
        Destination; written to a temporary file beside it and renamed, so
        a failed write never leaves a truncated PNG.
    max_width : int or None
        When the picture is wider, it is resized (Lanczos) to this width,
        keeping its aspect ratio.
    colours : int or None
        Quantize to a palette of this many colours (2 to 256): a hillshade
        with a few line colours loses nothing visible and the file shrinks
        several times.  None keeps full colour.
    max_bytes : int or None
        Size budget of the file: a larger full-colour PNG is quantized to 256
        colours, and a still larger one is not written.

    Returns
    -------
    Path
        ``path``, once the PNG is in place.

    Raises
    ------
    ParamsError
        On a malformed picture or option, or a file above ``max_bytes``.
    """
    if isinstance(picture, Image.Image):
        image = picture
    else:
        rgb = np.asarray(picture)
        if rgb.ndim != 3 or rgb.shape[2] not in (3, 4) or rgb.dtype != np.uint8:
            raise ParamsError(f"picture must be a uint8 array of shape (rows, cols, 3 or 4), "
                              f"got {rgb.dtype} {rgb.shape}")
        image = Image.fromarray(rgb)
    if colours is not None and not (isinstance(colours, (int, np.integer)) and 2 <= colours <= 256):
        raise ParamsError(f"colours must be an integer from 2 to 256 or None, got {colours!r}")
    if max_width is not None and image.width > max_width:
        height = max(1, round(image.height * max_width / image.width))
        image = image.resize((max_width, height), Image.Resampling.LANCZOS)
    data = _png_bytes(_quantized(image, int(colours)) if colours is not None else image)
    if max_bytes is not None and len(data) > max_bytes and colours is None:
        data = _png_bytes(_quantized(image, 256))
    if max_bytes is not None and len(data) > max_bytes:
        raise ParamsError(f"{path} would be {len(data)} bytes, above the {max_bytes}-byte budget")
    path = Path(path)
    with atomic_outputs(path) as (tmp,), open_new(tmp) as f:
        f.write(data)
    return path
