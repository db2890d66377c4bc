"""Helpers shared by the DEM readers and writers.

* atomic output: every file is first written under a temporary name in the
  destination directory and moved into place with :func:`os.replace`, so a
  crash never leaves a half-written DEM behind; the temporary files being
  written are known (:func:`remove_unfinished`), so a process stopped by a
  signal removes them even when the writes run on other threads (the app);
* the JSON sidecar that gives heightmaps without a header (PNG, RAW, NPY)
  their height range, cell size and georeference;
* the 16-bit level encoding of heights used by PNG and ``.r16``;
* turning library exceptions into one :class:`DEMFormatError` line.
"""

from __future__ import annotations

import errno
import glob
import json
import math
import os
import secrets
import shutil
import struct
import threading
import tokenize
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
from PIL import Image
from rasterio.crs import CRS
from rasterio.errors import RasterioError

from ..errors import DEMFormatError, TerraSynthError
from ..heightfield import GeoReference, HeightField, geographic_cell_size

#: Value of the sidecar's ``"format"`` key; a JSON file without it is not ours.
SIDECAR_FORMAT = "terrasynth-heightmap"
#: Extensions of the heightmaps read with a ``<stem>.json`` sidecar.
SIDECAR_EXTENSIONS = (".png", ".npy", ".r16", ".r32")

#: Exceptions that file-format libraries raise on bad input.  They are turned
#: into :class:`DEMFormatError`; anything else is a bug and propagates.
LIBRARY_ERRORS = (
    OSError,
    ValueError,
    EOFError,
    SyntaxError,
    KeyError,
    IndexError,
    TypeError,
    OverflowError,
    MemoryError,
    struct.error,
    zlib.error,
    tokenize.TokenError,  # numpy parses a damaged .npy header with tokenize
    Image.DecompressionBombError,
    RasterioError,  # GDAL's errors come as RasterioIOError (an OSError) or these
)


@contextmanager
def wrap_errors(path: Path, action: str) -> Iterator[None]:
    """Re-raise library exceptions as one :class:`DEMFormatError` line.

    A :class:`DEMFormatError` that does not name ``path`` yet (writers do
    not know it) gets it prefixed.

    Parameters
    ----------
    path : Path
        File named in the message.
    action : str
        What was being done, e.g. ``"read"`` or ``"write"``.
    """
    try:
        yield
    except DEMFormatError as exc:
        if str(path) in str(exc):
            raise
        raise DEMFormatError(f"cannot {action} {path}: {exc}") from exc
    except TerraSynthError:
        raise  # parameter errors are not about the file
    except FileNotFoundError as exc:
        raise DEMFormatError(f"cannot {action} {path}: no such file or directory") from exc
    except LIBRARY_ERRORS as exc:
        detail = " ".join(str(exc).split()) or type(exc).__name__
        cause = exc.__cause__ or exc.__context__
        if "See previous exception" in detail and cause is not None:
            # rasterio's "Read failed. See previous exception for details.":
            # GDAL's own words are in the exception before it.
            detail = detail.replace("See previous exception for details.", "").strip()
            detail += f" ({' '.join(str(cause).split())})"
            if action == "read":
                detail += "; the file may be damaged or cut short"
        raise DEMFormatError(f"cannot {action} {path}: {detail}") from exc


#: Temporary files of atomic writes not finished yet, in every thread.
_UNFINISHED: set[Path] = set()
_UNFINISHED_LOCK = threading.Lock()


@contextmanager
def atomic_outputs(*paths: Path) -> Iterator[list[Path]]:
    """Temporary paths beside ``paths``, moved onto them if the block succeeds.

    The temporary files are created by the caller (use :func:`open_new`).  On
    success each one replaces its target with :func:`os.replace` (atomic on
    POSIX and Windows within one file system); on failure (an exception,
    KeyboardInterrupt included) they are removed and the targets are left
    untouched.  Until then they are listed for :func:`remove_unfinished`.
    """
    temps = [Path(p).with_name(f".{Path(p).name}.{secrets.token_hex(6)}.tmp") for p in paths]
    with _UNFINISHED_LOCK:
        _UNFINISHED.update(temps)
    try:
        yield temps
        for temp, target in zip(temps, paths):
            _keep_mode(target, temp)
            os.replace(temp, target)
    except Exception as exc:
        _raise_if_disk_full(exc, temps[0].parent if temps else Path("."))
        raise
    finally:
        for temp in temps:
            temp.unlink(missing_ok=True)
        with _UNFINISHED_LOCK:
            _UNFINISHED.difference_update(temps)


def _keep_mode(target: Path, temp: Path) -> None:
    """Give ``temp`` the permissions of the file it replaces (a replaced
    read-only file stays read-only; a new file keeps the umask's).  Best
    effort: a file system without permissions (some network and FUSE
    mounts) must not fail a write that succeeded."""
    try:
        os.chmod(temp, os.stat(target).st_mode & 0o777)
    except OSError:
        pass


#: A failed write with less than this free beside it failed for want of space.
FULL_DISK_BYTES = 1 << 20


def _raise_if_disk_full(exc: Exception, folder: Path) -> None:
    """Say "No space left on device" when a write failed on a (nearly) full disk.

    Libraries report a full disk in their own words, or none: numpy's
    ``tofile`` says "65536 requested and 14304 written", GDAL "Write failed.
    See previous exception for details".  Measured before the temporary
    files are removed (they hold the space that ran out).
    """
    if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
        return
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return
    if free < FULL_DISK_BYTES:
        raise OSError(errno.ENOSPC, f"No space left on device ({free} bytes free in {folder})") from exc


def remove_unfinished() -> list[Path]:
    """Delete the temporary files of every atomic write still in progress.

    For a process about to end on a signal while writes run on other threads
    (the app's saves, autosaves and exports): their targets stay as they were
    (a write that had not reached :func:`os.replace` never does), and no
    ``.NAME.HEX.tmp`` is left behind.

    Returns
    -------
    list of Path
        The temporary files that existed and were removed.
    """
    with _UNFINISHED_LOCK:
        temps = list(_UNFINISHED)
    removed = []
    for temp in temps:
        try:
            temp.unlink()
            removed.append(temp)
        except OSError:  # not created yet, or already moved into place
            pass
    return removed


def open_new(path: Path):
    """Open a new file for binary writing; fails if it exists.

    Unlike :mod:`tempfile`, the permissions follow the umask, so the final
    file gets the same mode as any file the user creates.
    """
    return open(path, "xb")


def read_field(path: Path, fmt: str, heights: np.ndarray, *, cell_size=None, georef=None,
               metadata: dict | None = None) -> HeightField:
    """The :class:`HeightField` a reader returns.

    Parameters
    ----------
    path : Path
        The file read, kept as the field's ``source``.
    fmt : str
        Format name, e.g. ``"geotiff"``.
    heights : ndarray, shape (rows, cols)
        North-up heights in metres, NaN = nodata.
    cell_size : (dy, dx) metres or None
    georef : GeoReference or None
    metadata : dict or None
        What the format tells beyond heights and placement.

    A georeference with an EPSG code but no WKT gets the code's WKT, so
    every field with a known CRS carries it as WKT too.
    """
    return HeightField(heights, cell_size=cell_size, georef=with_crs_wkt(georef), source=str(path), format=fmt,
                       metadata=metadata or {})


def with_crs_wkt(georef: GeoReference | None) -> GeoReference | None:
    """``georef``, with its EPSG code's WKT when it has a code but no WKT."""
    if georef is not None and georef.epsg is not None and not georef.crs_wkt:
        return replace(georef, crs_wkt=CRS.from_epsg(georef.epsg).to_wkt())
    return georef


# -- sidecar -------------------------------------------------------------


def sidecar_path(path: Path) -> Path:
    """``<same stem>.json`` beside a heightmap file."""
    return path.with_suffix(".json")


def make_sidecar(field: HeightField, *, nodata_value: float | None) -> dict:
    """The sidecar content describing ``field``.

    Parameters
    ----------
    field : HeightField
    nodata_value : float or None
        Stored value meaning nodata (0 for 16-bit levels), ``None`` when the
        file stores NaN or has no nodata.

    Returns
    -------
    dict
        ``format``, ``version``, ``min`` and ``max`` (metres), ``cell_size``
        (``[dy, dx]`` metres or ``None``), ``nodata_value``, ``georef`` (the
        :class:`GeoReference` fields or ``None``) and ``shape``
        (``[rows, cols]``, which headerless raw files need).
    """
    return {
        "format": SIDECAR_FORMAT,
        "version": 1,
        "min": field.min,
        "max": field.max,
        "cell_size": list(field.cell_size) if field.cell_size is not None else None,
        "nodata_value": nodata_value,
        "georef": _georef_json(field.georef),
        "shape": list(field.shape),
    }


def _georef_json(georef: GeoReference | None) -> dict | None:
    """Plain JSON values of a georeference (numpy scalars are not JSON)."""
    if georef is None:
        return None
    content = {key: float(value) for key, value in asdict(georef).items() if key not in ("epsg", "crs_wkt")}
    content["epsg"] = int(georef.epsg) if georef.epsg is not None else None
    content["crs_wkt"] = georef.crs_wkt
    return content


def _our_sidecar(path: Path) -> dict | None:
    """The content of ``path`` when it is a sidecar TerraSynth wrote (marked
    ``"format": "terrasynth-heightmap"``), else None (unreadable, not JSON,
    or someone else's JSON)."""
    try:
        content = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return content if isinstance(content, dict) and content.get("format") == SIDECAR_FORMAT else None


def check_sidecar_free(path: Path, content: dict) -> None:
    """Refuse to write the heightmap ``path`` when its sidecar would replace a file not ours.

    The rule for ``<stem>.json`` beside a PNG, ``.npy``, ``.r16`` or
    ``.r32``: a sidecar is marked by ``"format": "terrasynth-heightmap"``
    (every sidecar TerraSynth ever wrote carries it); an existing
    ``<stem>.json`` without that marker belongs to the user and is never
    overwritten.  Nor is one that another heightmap of the same stem (another
    of those extensions) is read with, unless the new ``content`` is the same
    (the same field written in two formats).

    Raises
    ------
    DEMFormatError
        Naming the JSON file and what to do.
    """
    side = sidecar_path(path)
    existing = check_sidecar_ours(path)
    if existing is not None and existing == json.loads(json.dumps(content)):
        return
    # One sidecar serves every heightmap of its stem: another one would be read
    # through the new content (a PNG's levels as another range, an .npy's nodata).
    for other in path.parent.glob(glob.escape(path.stem) + ".*"):
        if other.suffix.lower() in SIDECAR_EXTENSIONS and other.name != path.name and other.stem == path.stem:
            raise DEMFormatError(
                f"cannot write {path}: its sidecar {side} is also read with {other}, which it would "
                "change; choose another output name"
            )


def check_sidecar_ours(path: Path) -> dict | None:
    """The existing sidecar of the heightmap ``path`` (None without one),
    refused when that ``<stem>.json`` is not a TerraSynth sidecar: the
    part of :func:`check_sidecar_free` that needs no new content, so a
    command can make it before it works.

    Raises
    ------
    DEMFormatError
        Naming the JSON file and what to do.
    """
    side = sidecar_path(path)
    if not side.exists():
        return None
    existing = _our_sidecar(side)
    if existing is None:
        raise DEMFormatError(
            f"cannot write {path}: its sidecar {side} would replace an existing file that is not a "
            "TerraSynth sidecar; move that file away or choose another output name"
        )
    return existing


def check_not_sidecar(path: Path, what: str = "JSON") -> None:
    """Refuse to write a report or other JSON ``path`` over a heightmap's sidecar.

    Raises
    ------
    DEMFormatError
        When ``path`` exists and is a TerraSynth sidecar (overwriting it
        would make its heightmap read as raw levels).
    """
    if path.is_file() and _our_sidecar(path) is not None:
        raise DEMFormatError(
            f"cannot write the {what} {path}: it is the sidecar of a heightmap beside it "
            "(its metres and cell size); choose another name"
        )


def write_sidecar(content: dict, path: Path) -> None:
    """Write a sidecar dictionary as JSON to a new file ``path``."""
    with open_new(path) as fh:
        fh.write((json.dumps(content, indent=2) + "\n").encode("utf-8"))


def read_sidecar(path: Path) -> dict | None:
    """The sidecar of the heightmap ``path``, or ``None`` when there is none.

    A JSON file with the same stem that was not written by TerraSynth (no
    ``"format": "terrasynth-heightmap"``) is ignored.  A sidecar of ours that
    is malformed raises :class:`DEMFormatError` naming it.
    """
    side = sidecar_path(path)
    if not side.is_file():
        return None
    try:
        content = json.loads(side.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise DEMFormatError(f"cannot read sidecar {side}: {exc}") from exc
    if not isinstance(content, dict) or content.get("format") != SIDECAR_FORMAT:
        return None
    try:
        lo, hi = float(content["min"]), float(content["max"])
        if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
            raise ValueError(f"min {lo} and max {hi} must be finite with min <= max")
        content["min"], content["max"] = lo, hi
        if content.get("cell_size") is not None:
            dy, dx = (float(v) for v in content["cell_size"])
            content["cell_size"] = (dy, dx)
        if content.get("georef") is not None:
            content["georef"] = GeoReference(**content["georef"])
        if content.get("shape") is not None:
            rows, cols = (int(v) for v in content["shape"])
            content["shape"] = (rows, cols)
    except (KeyError, TypeError, ValueError) as exc:
        raise DEMFormatError(f"sidecar {side} is malformed: {exc}") from exc
    return content


# -- 16-bit levels ----------------------------------------------------------


def encode_levels(field: HeightField, *, level_range: tuple[float, float] | None = None) -> tuple[np.ndarray, dict]:
    """Heights as 16-bit levels and the sidecar that maps them back.

    Without nodata the range ``min..max`` maps linearly to ``0..65535``.  With
    nodata, level 0 is reserved for it and valid cells use ``1..65535``.

    Parameters
    ----------
    field : HeightField
    level_range : (low, high) metres, optional
        The heights the first and last levels stand for instead of the
        field's min and max (the tiles of one terrain share one range, as
        an engine's single height scale needs); must contain them.

    Returns
    -------
    levels : ndarray of uint16, shape (rows, cols)
    sidecar : dict
        See :func:`make_sidecar`.
    """
    heights = field.heights
    nodata = field.nodata
    lo, hi = field.min, field.max
    if level_range is not None:
        low, high = (float(v) for v in level_range)
        if not (math.isfinite(low) and math.isfinite(high) and low <= lo and hi <= high):
            raise DEMFormatError(f"level range {low:g}..{high:g} m does not contain the heights {lo:g}..{hi:g} m")
        lo, hi = low, high
    has_nodata = bool(nodata.any())
    first = 1 if has_nodata else 0
    span = 65535 - first
    if hi > lo:
        # In place: one float64 grid at a time (an 8129-sample tile's is 0.5 GB).
        levels = np.where(nodata, lo, heights).astype(np.float64)
        levels -= lo
        levels *= span / (hi - lo)
        np.rint(levels, out=levels)
        levels += first
    else:
        # A flat field has no range: every valid cell takes the top level.
        levels = np.full(heights.shape, 65535.0)
    if has_nodata:
        levels[nodata] = 0
    levels = levels.astype(np.uint16)
    sidecar = make_sidecar(field, nodata_value=0 if has_nodata else None)
    sidecar["min"], sidecar["max"] = lo, hi
    return levels, sidecar


def decode_levels(levels: np.ndarray, top: int, sidecar: dict | None) -> np.ndarray:
    """Heights in metres from integer levels, the inverse of :func:`encode_levels`.

    Parameters
    ----------
    levels : ndarray of int, shape (rows, cols)
    top : int
        Largest level of the storage (255 for 8-bit, 65535 for 16-bit).
    sidecar : dict or None
        Without one, the levels themselves are the heights.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        ``NaN`` where the level is the sidecar's nodata value.
    """
    if sidecar is None:
        return levels.astype(np.float32)
    nodata_value = sidecar.get("nodata_value")
    first = 0 if nodata_value is None else 1
    lo, hi = sidecar["min"], sidecar["max"]
    heights = lo + (levels.astype(np.float64) - first) * ((hi - lo) / (top - first))
    if nodata_value is not None:
        heights[levels == nodata_value] = np.nan
    return heights.astype(np.float32)


def apply_sidecar_nodata(values: np.ndarray, sidecar: dict | None) -> np.ndarray:
    """Float32 heights with the sidecar's ``nodata_value`` (if any) set to NaN."""
    heights = values.astype(np.float32)
    if sidecar is not None and sidecar.get("nodata_value") is not None:
        heights[values == sidecar["nodata_value"]] = np.nan
    return heights


#: Fill values a grid without nodata metadata is taken to mark nodata with,
#: besides the lowest value of an integer type (SRTM's -32768 in int16):
#: no ground lies this far down (the deepest ocean is about -11,000 m) ...
FILL_VALUES = (-9999.0, -32767.0)
#: ... and floats below this (GDAL's float32 default, -3.4e38).
FILL_BELOW = -1e30


def fill_value_nodata(values: np.ndarray, heights: np.ndarray) -> float | None:
    """Set to NaN in ``heights`` the cells of ``values`` (the grid as read,
    any real dtype) that hold a conventional fill value, for a format that
    cannot say which value is nodata.

    Returns
    -------
    float or None
        The fill value found (the commonest, when several), None when none.
    """
    marks = np.zeros(values.shape, bool)
    found = {}
    candidates = list(FILL_VALUES)
    if values.dtype.kind == "i":
        candidates.append(float(np.iinfo(values.dtype).min))
    for v in candidates:
        hit = values == v
        if hit.any():
            found[v] = int(hit.sum())
            marks |= hit
    if values.dtype.kind == "f":
        low = values < FILL_BELOW
        if low.any():
            found[float(values[low].min())] = int(low.sum())
            marks |= low
    if not found:
        return None
    heights[marks] = np.nan
    return max(found, key=found.get)


def sidecar_placement(sidecar: dict | None) -> dict:
    """``cell_size`` and ``georef`` keyword arguments from a sidecar."""
    if sidecar is None:
        return {"cell_size": None, "georef": None}
    return {"cell_size": sidecar.get("cell_size"), "georef": sidecar.get("georef")}


# -- geometry -------------------------------------------------------------


def geographic_cell(lat_deg: float, y_step_deg: float, x_step_deg: float) -> tuple[float, float]:
    """Ground size ``(dy, dx)`` in metres of a cell of ``y_step x x_step`` degrees."""
    dy = geographic_cell_size(lat_deg, y_step_deg)[0]
    dx = geographic_cell_size(lat_deg, x_step_deg)[1]
    return (dy, dx)


def looks_geographic(x: float, y: float, step: float) -> bool:
    """Whether coordinates without a CRS are likely degrees.

    Longitudes within +-180, latitudes within +-90 and a step under 0.1 are
    implausible for a grid in metres.
    """
    return abs(x) <= 180 and abs(y) <= 90 and step < 0.1

