"""Reading and writing DEM files and terrain meshes.

:func:`load_dem` and :func:`save_dem` pick the format from the file
extension (any case) and always deal in :class:`HeightField` objects: heights
in metres, NaN for nodata, north-up, with the cell size and georeference the
file holds.

Formats
-------
GDAL (through rasterio) reads every raster format it knows; the project's
own readers remain where they add something (SRTM placement from the tile
name, the USGS DEM profiles without GDAL's padding rows, ESRI ASCII grids
that GDAL misreads silently when a header line is indented, Terragen, the
heightmap sidecars).

=================  ==============  =====  =====  ===============================
Extension          Name            Read   Write  Notes
=================  ==============  =====  =====  ===============================
.hgt               hgt             own    no     SRTM tile; place from the name
.tif .tiff         geotiff         GDAL   yes    any compression, COG, BigTIFF;
                                                 written float32, or COG
.bil .bsq .bip     envi            GDAL   no     ENVI or ESRI BIL, needs .hdr
.dem               usgs-dem        own    no     USGS ASCII DEM (1024-byte records)
.asc               esri-ascii      own    yes    ESRI ASCII grid (+ .prj CRS)
.img               erdas-imagine   GDAL   no     ERDAS Imagine (HFA)
.vrt               gdal-vrt        GDAL   no     GDAL virtual raster (mosaics)
.nc                netcdf          GDAL   no     NetCDF (CF)
.dt0 .dt1 .dt2     dted            GDAL   no     DTED level 0/1/2
.flt               gridfloat       GDAL   no     ESRI GridFloat, needs .hdr
.grd               grd             GDAL   no     Surfer, GMT or R raster grid
.sdat              saga            GDAL   no     SAGA grid, needs .sgrd
.ers               er-mapper       GDAL   no     ER Mapper raster
.rst               idrisi          GDAL   no     Idrisi raster
.bt                vtp-bt          GDAL   no     VTP Binary Terrain
.hf2               hf2             GDAL   no     HF2/HFZ heightfield
.gpkg              geopackage      GDAL   no     GeoPackage raster tiles
.jp2               jpeg2000        GDAL   no     JPEG 2000 (lossless if so made)
.bag               bag             GDAL   no     BAG bathymetry: band=1 elevation
.gtx               gtx             GDAL   no     NOAA GTX grid
.png               png             own    yes    8/16-bit gray; metres via sidecar
.npy               npy             own    yes    written as float32, NaN nodata
.ter               terragen        own    yes    int16 with scale; no nodata
.r16               r16             own    yes    LE uint16 levels; metres via sidecar
.r32               r32             own    yes    LE float32 metres
.exr               exr             own    yes    OpenEXR float32 Y channel; cell
                                                 size in header attributes
=================  ==============  =====  =====  ===============================

PNG, ``.r16``, ``.r32`` and ``.npy`` files are written with a JSON sidecar
``<same stem>.json`` holding the height range, cell size, georeference and
shape that those formats cannot store.

Every write goes to a temporary file in the destination directory that
then replaces the target (sidecar included), so an interrupted save never
leaves a truncated file.  Every failure a file can cause raises one
:class:`~terrasynth_core.errors.DEMFormatError` naming the file.
"""

from __future__ import annotations

from collections.abc import Callable
from os import PathLike
from pathlib import Path

from ..errors import DEMFormatError
from ..heightfield import HeightField
from . import esri_ascii, exr, gdal, gltf, hgt, mesh, npy, png, raw, terragen, usgs_dem
from ._common import (SIDECAR_EXTENSIONS, atomic_outputs, check_sidecar_free, open_new, remove_unfinished,
                      sidecar_path, wrap_errors, write_sidecar)

__all__ = [
    "MESH_EXTENSIONS",
    "READ_EXTENSIONS",
    "WRITE_EXTENSIONS",
    "format_name",
    "load_dem",
    "open_raster_windows",
    "remove_unfinished",
    "save_dem",
    "save_mesh",
    "sidecar_of",
]

#: Short format name by extension.
_FORMAT_NAMES = {
    ".hgt": "hgt",
    ".tif": "geotiff",
    ".tiff": "geotiff",
    ".bil": "envi",
    ".bsq": "envi",
    ".bip": "envi",
    ".dem": "usgs-dem",
    ".asc": "esri-ascii",
    ".img": "erdas-imagine",
    ".vrt": "gdal-vrt",
    ".nc": "netcdf",
    ".dt0": "dted",
    ".dt1": "dted",
    ".dt2": "dted",
    ".flt": "gridfloat",
    ".grd": "grd",
    ".sdat": "saga",
    ".ers": "er-mapper",
    ".rst": "idrisi",
    ".bt": "vtp-bt",
    ".hf2": "hf2",
    ".gpkg": "geopackage",
    ".jp2": "jpeg2000",
    ".bag": "bag",
    ".gtx": "gtx",
    ".png": "png",
    ".npy": "npy",
    ".ter": "terragen",
    ".r16": "r16",
    ".r32": "r32",
    ".exr": "exr",
}

#: The project's own readers; every other format is read through GDAL.
_READERS: dict[str, Callable[[Path], HeightField]] = {
    "hgt": hgt.read_hgt,
    "usgs-dem": usgs_dem.read_usgs_dem,
    "esri-ascii": esri_ascii.read_esri_ascii,
    "png": png.read_png,
    "npy": npy.read_npy,
    "terragen": terragen.read_terragen,
    "exr": exr.read_exr,
}

#: Readers of headerless files, which take the grid ``size``.
_RAW_READERS = {"r16": raw.read_r16, "r32": raw.read_r32}

#: Writers by format name, called as ``writer(field, binary_file)``; those of
#: :data:`_SIDECAR_FORMATS` return the sidecar content.
_WRITERS = {
    "esri-ascii": esri_ascii.write_esri_ascii,
    "png": png.write_png,
    "npy": npy.write_npy,
    "terragen": terragen.write_terragen,
    "r16": raw.write_r16,
    "r32": raw.write_r32,
}

#: Writers given the (temporary) path instead of an open file.
_PATH_WRITERS = {"geotiff": gdal.write_geotiff, "exr": lambda field, path, cog: exr.write_exr(field, path)}

#: Formats of 16-bit levels, whose writers take a ``level_range``.
_LEVEL_FORMATS = {"png", "r16"}

#: Formats written with a JSON sidecar (see :func:`._common.make_sidecar`).
_SIDECAR_FORMATS = {_FORMAT_NAMES[ext] for ext in SIDECAR_EXTENSIONS}

_MESH_WRITERS = {".obj": mesh.write_obj, ".stl": mesh.write_stl, ".ply": mesh.write_ply, ".glb": gltf.write_glb}

#: Extensions :func:`load_dem` reads.
READ_EXTENSIONS: tuple[str, ...] = tuple(_FORMAT_NAMES)
#: Extensions :func:`save_dem` writes.
WRITE_EXTENSIONS: tuple[str, ...] = tuple(
    ext for ext, name in _FORMAT_NAMES.items() if name in _WRITERS or name in _PATH_WRITERS
)
#: Extensions :func:`save_mesh` writes.
MESH_EXTENSIONS: tuple[str, ...] = tuple(_MESH_WRITERS)

#: Cell sizes (metres) the writers of formats that must state one put down
#: for a field without one; other formats leave it unknown.
_ASSUMED_CELL = {"terragen": terragen.DEFAULT_SCALE, "esri-ascii": esri_ascii.DEFAULT_CELL}


def assumed_cell_size(field: HeightField, path: str | PathLike) -> float | None:
    """The cell size (metres) writing ``field`` to ``path`` states though
    ``field`` has none (a Terragen file's scale, an ESRI grid's
    ``cellsize``, a mesh's spacing); None when the field has one or the
    format can leave it unknown."""
    if field.cell_size is not None:
        return None
    suffix = Path(path).suffix.lower()
    if suffix in _MESH_WRITERS:
        return mesh.DEFAULT_SPACING
    return _ASSUMED_CELL.get(_FORMAT_NAMES.get(suffix))


def format_name(path: str | PathLike) -> str:
    """Short name of the DEM format of ``path`` from its extension.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    str
        The name in the module's format table, e.g. ``"hgt"``,
        ``"geotiff"``, ``"erdas-imagine"`` or ``"r32"``.

    Raises
    ------
    DEMFormatError
        For an extension that is not a DEM format; the message lists the
        supported ones.
    """
    path = Path(path)
    name = _FORMAT_NAMES.get(path.suffix.lower())
    if name is None:
        raise DEMFormatError(
            f"{path}: unknown DEM extension {path.suffix!r}; supported: {', '.join(READ_EXTENSIONS)}"
        )
    return name


def sidecar_of(path: str | PathLike) -> Path | None:
    """The JSON sidecar :func:`save_dem` writes beside ``path``, ``None`` for formats without one."""
    path = Path(path)
    return sidecar_path(path) if _FORMAT_NAMES.get(path.suffix.lower()) in _SIDECAR_FORMATS else None


def load_dem(
    path: str | PathLike, *, size: tuple[int, int] | None = None, band: int | None = None
) -> HeightField:
    """Read a DEM file, choosing the reader from the extension.

    Parameters
    ----------
    path : str or path-like
        One of :data:`READ_EXTENSIONS` (any case).
    size : (rows, cols), optional
        Grid shape of a headerless ``.r16``/``.r32`` file.  Without it the
        shape comes from the sidecar, else the grid must be square.  Ignored
        by the other formats, whose files say their own shape.
    band : int, optional
        1-based band of a multi-band raster read through GDAL; without it
        such a file is refused.  The project's own formats have one band
        (``band=1`` is accepted, others refused).

    Returns
    -------
    HeightField
        North-up float32 heights in metres with NaN for nodata;
        ``format`` is the short name of :func:`format_name`, ``source`` the
        path.  See :func:`terrasynth_core.io.gdal.read_gdal` for what GDAL
        reads give (scale and offset, height units, ``metadata``).

    Raises
    ------
    DEMFormatError
        Unknown extension, missing file, or content that cannot be read;
        always one line naming the file.
    """
    if str(path).startswith("builtin:") and not Path(path).exists():
        raise DEMFormatError(f"{path} is a built-in example, not a file: load it with "
                             "terrasynth_core.examples.resolve_dem (files and builtin:KEY alike)")
    path = Path(path)
    name = format_name(path)
    if not path.is_file():
        raise DEMFormatError(f"{path}: no such file" if not path.exists() else f"{path}: not a file")
    with wrap_errors(path, "read"):
        if name in _READERS or name in _RAW_READERS:
            if band not in (None, 1):
                raise DEMFormatError(f"{path}: band {band!r} does not exist; {name} files have one band")
            if name in _RAW_READERS:
                return _RAW_READERS[name](path, size=size)
            return _READERS[name](path)
        return gdal.read_gdal(path, band=band, fmt=name)


def open_raster_windows(path: str | PathLike, *, band: int | None = None) -> gdal.RasterWindows | None:
    """The file ``path`` as :class:`~terrasynth_core.io.gdal.RasterWindows`
    (read window by window, converted as :func:`load_dem` converts it),
    when its format is read through GDAL; ``None`` for the formats read
    whole (PNG, raw, NumPy, ASCII grids...) and for a path that is not a
    file (:func:`load_dem` says what is wrong with it).

    Raises
    ------
    DEMFormatError
        A GDAL raster that cannot be read, as :func:`load_dem` would.
    """
    path = Path(path)
    name = format_name(path)
    if name in _READERS or name in _RAW_READERS or not path.is_file():
        return None
    with wrap_errors(path, "read"):
        return gdal.RasterWindows(path, band=band)


def save_dem(field: HeightField, path: str | PathLike, *, cog: bool = False,
             level_range: tuple[float, float] | None = None) -> None:
    """Write ``field`` in the format given by the extension of ``path``.

    Parameters
    ----------
    field : HeightField
    path : str or path-like
        One of :data:`WRITE_EXTENSIONS` (any case).  PNG, ``.r16``, ``.r32``
        and ``.npy`` also get the sidecar ``<same stem>.json``; an existing
        ``<same stem>.json`` that is not a TerraSynth sidecar is never
        replaced, nor one that another heightmap of the same stem is read
        with, unless it stays the same (:class:`DEMFormatError` instead;
        see :func:`._common.check_sidecar_free`).
    cog : bool, default False
        For ``.tif``/``.tiff``: write a Cloud-Optimized GeoTIFF (tiled,
        with overviews, readable over HTTP range requests).
    level_range : (low, high) metres, optional
        For PNG and ``.r16``: the heights of the first and last 16-bit
        level instead of the field's min and max (tiles of one terrain
        share one range); must contain the heights.

    Notes
    -----
    What each format keeps:

    * ``.tif``: float32 heights exactly, NaN nodata, georeference and CRS
      (EPSG code, else WKT); DEFLATE with the floating-point predictor.
    * ``.asc``: float32 heights exactly, nodata, georeference; the CRS in
      ``<same stem>.prj`` (ESRI WKT).
    * ``.npy``, ``.r32``: float32 heights exactly, NaN nodata; placement
      in the sidecar.
    * ``.png``, ``.r16``: 16-bit levels between min and max (error at most
      half a level, about range / 131070), level 0 for nodata; placement in
      the sidecar.
    * ``.ter``: int16 with scale, error below range / 30000 for a range
      over about 0.6 cell sizes; nodata filled with the minimum.
    * ``.exr``: float32 heights exactly, NaN nodata; cell size and
      georeference in header attributes.

    Raises
    ------
    DEMFormatError
        Unsupported extension (or ``cog`` with another extension than
        ``.tif``/``.tiff``), unwritable destination, or a field the format
        cannot hold; the message names the file.
    """
    path = Path(path)
    name = _FORMAT_NAMES.get(path.suffix.lower())
    if name not in _WRITERS and name not in _PATH_WRITERS:
        raise DEMFormatError(
            f"cannot write {path}: unsupported extension {path.suffix!r}; "
            f"supported: {', '.join(WRITE_EXTENSIONS)}"
        )
    if cog and name != "geotiff":
        raise DEMFormatError(f"cannot write {path}: a Cloud-Optimized GeoTIFF needs a .tif or .tiff name")
    if level_range is not None and name not in _LEVEL_FORMATS:
        raise DEMFormatError(f"cannot write {path}: a level range is for 16-bit PNG and .r16 files only")
    if not isinstance(field, HeightField):
        raise TypeError(f"save_dem expects a HeightField, got {type(field).__name__}")
    if name in _PATH_WRITERS:
        with wrap_errors(path, "write"), atomic_outputs(path) as (temp,):
            _PATH_WRITERS[name](field, temp, cog=cog)
        return
    targets = (path, sidecar_path(path)) if name in _SIDECAR_FORMATS else (path,)
    prj = esri_ascii.prj_text(field, path) if name == "esri-ascii" else None
    if prj is not None:
        targets += (path.with_suffix(".prj"),)
    with wrap_errors(path, "write"), atomic_outputs(*targets) as temps:
        with open_new(temps[0]) as fh:
            options = {"level_range": level_range} if level_range is not None else {}
            sidecar = _WRITERS[name](field, fh, **options)
        if name in _SIDECAR_FORMATS:
            check_sidecar_free(path, sidecar)
            write_sidecar(sidecar, temps[1])
        if prj is not None:
            with open_new(temps[-1]) as fh:
                fh.write(prj.encode("ascii"))


def save_mesh(
    field: HeightField,
    path: str | PathLike,
    *,
    vertical_scale: float = 1.0,
    step: int = 1,
    target_triangles: int | None = None,
    texture=None,
) -> None:
    """Write the surface of ``field`` as a triangle mesh.

    Parameters
    ----------
    field : HeightField
    path : str or path-like
        ``.obj`` (text), ``.stl`` (binary), ``.ply`` (binary
        little-endian) or ``.glb`` (binary glTF 2.0 with normals and
        texture coordinates, Y up: see :mod:`.gltf`), any case.
    vertical_scale : float, default 1.0
        Factor on heights (vertical exaggeration).
    step : int, default 1
        Keep every ``step``-th row and column, to thin large grids.
    target_triangles : int, optional
        Simplify the mesh to about this many triangles
        (:func:`.mesh.simplified_mesh`: fewer where the ground is flat).
    texture : ndarray of uint8, shape (rows, cols, 3), optional
        ``.glb`` only: a colour picture of the grid (one pixel per cell),
        draped over the mesh and stored in the file.

    Notes
    -----
    Vertices are the valid nodes at ``x = col * dx``, ``y = (rows - 1 -
    row) * dy``, ``z = height * vertical_scale`` (metres; 1 per cell when the
    cell size is unknown); two triangles per cell, those touching nodata
    left out.  See :func:`terrasynth_core.io.mesh.mesh_arrays`.

    Raises
    ------
    DEMFormatError
        Unsupported extension, unwritable destination, no valid triangle.
    ParamsError
        Bad ``vertical_scale`` or ``step``.
    """
    path = Path(path)
    writer = _MESH_WRITERS.get(path.suffix.lower())
    if writer is None:
        raise DEMFormatError(
            f"cannot write {path}: unsupported mesh extension {path.suffix!r}; "
            f"supported: {', '.join(MESH_EXTENSIONS)}"
        )
    glb = path.suffix.lower() == ".glb"
    if texture is not None and not glb:
        raise DEMFormatError(f"cannot write {path}: a texture needs a .glb mesh")
    with wrap_errors(path, "write"), atomic_outputs(path) as (temp,):
        if target_triangles is None:
            vertices, faces = mesh.mesh_arrays(field, vertical_scale=vertical_scale, step=step)
        else:
            vertices, faces = mesh.simplified_mesh(field, target_triangles, vertical_scale=vertical_scale, step=step)
        with open_new(temp) as fh:
            if glb:
                uv = mesh.texture_coordinates(vertices, field)
                writer(vertices, faces, fh, uv=uv, texture=texture)
            else:
                writer(vertices, faces, fh)
