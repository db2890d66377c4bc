"""Writing masks as 8- or 16-bit PNGs or float OpenEXR, with a JSON key.

``<stem>_<mask>.png`` (or ``.exr``) per mask, plus ``<stem>_masks.json``
with what 1.0 means in each and the notes.  One-channel masks are grey,
the normal map RGB, the height bands RGBA (a splat map).  PNG levels are
``round(value * top)``, ``top`` 255 or 65535 (style region ids: the id + 1
itself); EXR keeps the float values
(``Y`` for one channel, ``R``, ``G``, ``B`` (and ``A``) for more).
"""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import numpy as np
from PIL import Image

from ..errors import ParamsError
from ..io._common import atomic_outputs, open_new, wrap_errors
from .engines import check_folder, check_stem, refuse_existing, writing_into
from .masks import TerrainMasks

#: ``--format`` values.
MASK_FORMATS = ("png8", "png16", "exr")


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png16_bytes(levels: np.ndarray) -> bytes:
    """A 16-bit PNG of ``levels`` (uint16, shape (rows, cols) or (rows, cols, 3 or 4)).

    Pillow writes 16-bit grey only, so RGB and RGBA at 16 bits are
    encoded here (PNG 1.2: colour types 0, 2, 6; filter 0 on every row).
    """
    rows, cols = levels.shape[:2]
    channels = 1 if levels.ndim == 2 else levels.shape[2]
    colour_type = {1: 0, 3: 2, 4: 6}[channels]
    raw = np.ascontiguousarray(levels.astype(">u2")).view(np.uint8).reshape(rows, cols * channels * 2)
    scanlines = np.concatenate([np.zeros((rows, 1), np.uint8), raw], axis=1)  # filter type 0
    header = struct.pack(">IIBBBBB", cols, rows, 16, colour_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", header)
            + _png_chunk(b"IDAT", zlib.compress(scanlines.tobytes(), 6)) + _png_chunk(b"IEND", b""))


def _write_png(values: np.ndarray, temp: Path, bits: int) -> None:
    top = 255 if bits == 8 else 65535
    if np.issubdtype(values.dtype, np.integer):
        levels = values  # ids are written as they are
    else:
        levels = np.rint(np.clip(np.nan_to_num(values), 0, 1) * top)
    with open_new(temp) as fh:
        if bits == 8:
            # Pillow makes L, RGB or RGBA from the uint8 array's shape.
            Image.fromarray(levels.astype(np.uint8)).save(fh, format="PNG")
        else:
            fh.write(png16_bytes(levels.astype(np.uint16)))


def _write_exr(values: np.ndarray, temp: Path, attributes: dict) -> None:
    import OpenEXR

    if values.ndim == 2:
        channels = {"Y": np.ascontiguousarray(values, dtype=np.float32)}
    else:
        channels = {name: np.ascontiguousarray(values[..., k], dtype=np.float32)
                    for k, name in enumerate("RGBA"[:values.shape[2]])}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage, **attributes}
    with OpenEXR.File(header, channels) as exr:
        exr.write(str(temp))


def mask_paths(names, out_dir: Path, stem: str, fmt: str) -> dict[str, Path]:
    """Where each mask goes."""
    ext = ".exr" if fmt == "exr" else ".png"
    return {name: out_dir / f"{stem}_{name}{ext}" for name in names}


def write_masks(masks: TerrainMasks, out_dir, *, fmt: str = "png8", stem: str = "terrain") -> list[Path]:
    """Write every mask of ``masks`` and the key ``<stem>_masks.json`` into ``out_dir``.

    Parameters
    ----------
    masks : TerrainMasks
    out_dir : str or path-like
        Created if missing, in a folder that exists; no existing file is replaced (refused first).
    fmt : {"png8", "png16", "exr"}
    stem : str

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    ParamsError
        Unknown format, or a ``stem`` with folders in it.
    DEMFormatError
        A file exists, or writing failed (the files written are removed).
    """
    if fmt not in MASK_FORMATS:
        raise ParamsError(f"unknown mask format {fmt!r}; expected one of {', '.join(MASK_FORMATS)}")
    check_stem(stem)
    out_dir = Path(out_dir)
    check_folder(out_dir)
    paths = mask_paths(masks.masks, out_dir, stem, fmt)
    key_path = out_dir / f"{stem}_masks.json"
    refuse_existing([*paths.values(), key_path])
    with writing_into(out_dir) as written:
        for name, path in paths.items():
            with wrap_errors(path, "write"), atomic_outputs(path) as (temp,):
                values = masks.masks[name]
                if fmt == "exr":
                    _write_exr(values, temp, {"terrasynth_mask": name})
                else:
                    _write_png(values, temp, 8 if fmt == "png8" else 16)
            written.append(path)
        key = {
            "format": "terrasynth-masks",
            "files": {name: path.name for name, path in paths.items()},
            "encoding": "float 0..1" if fmt == "exr" else f"level / {255 if fmt == 'png8' else 65535}",
            "scales": masks.scales,
            "cell_size_m": list(masks.cell_size),
            "normal": "tangent space, (n + 1) / 2, OpenGL: red east, green north, blue up",
            "height_bands": "RGBA = low, mid, high, peak; they sum to 1",
            "notes": masks.notes,
        }
        with wrap_errors(key_path, "write"), atomic_outputs(key_path) as (temp,), open_new(temp) as fh:
            fh.write((json.dumps(key, indent=2) + "\n").encode("utf-8"))
        written.append(key_path)
    return written
