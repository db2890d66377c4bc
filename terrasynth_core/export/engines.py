"""Heightmaps the way each engine or DCC tool imports them.

=========  ============================  ===========================================
preset     file                          size
=========  ============================  ===========================================
unreal     16-bit grey PNG               127, 253, 505, 1009, 2017, 4033 or 8129 a side
unity      ``.r16`` little-endian        2^n + 1 a side, 33 to 4097
godot      32-bit float OpenEXR          any; square cells
blender    32-bit float OpenEXR          any; square cells
houdini    32-bit float OpenEXR          any; square cells
=========  ============================  ===========================================

Heightmaps are **node grids**: an engine puts one vertex per sample, so a
terrain of ``n`` samples spaced ``d`` metres spans ``(n - 1) d`` metres.
Resizing keeps that span (:func:`terrasynth_core.io.resample.resample_nodes`:
area average when shrinking, cubic when growing) and the heights in metres;
the spacing scales accordingly.  Unreal and Unity grids are square, so a
terrain that is not gets different X and Y spacings (both engines take
them).  Tiles (``tiles=K``) cut a grid of ``K (n - 1) + 1`` samples into
``K x K`` tiles of ``n`` that share their edge rows and columns, named
``_x{i}_y{j}`` (``i`` west to east, ``j`` north to south, Unreal's World
Partition convention); all tiles use one height range, so one height scale
fits them all.

Beside the heightmaps, ``<stem>.<preset>.json`` holds the import settings
(scales in centimetres for Unreal, sizes in metres for Unity, cell size for
the EXR tools), and each PNG or ``.r16`` gets TerraSynth's sidecar, so
``terrasynth-cli info`` and :func:`~terrasynth_core.io.load_dem` read it
back in metres.  Nothing in the output folder is ever replaced: if a file
the export would write exists, the export refuses before writing anything.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import DEMFormatError, ParamsError, SynthesisCancelled
from ..heightfield import LEAST_SIDE, HeightField
from ..io import load_dem, open_raster_windows, save_dem
from ..io._common import atomic_outputs, open_new, sidecar_path, wrap_errors
from ..io.resample import NodeGrid, already_square, node_grid_placement, resample_nodes, to_square_cells

#: The Landscape Technical Guide's recommended heightmap sizes (samples a side).
UNREAL_SIZES = (127, 253, 505, 1009, 2017, 4033, 8129)
#: Unity's heightmap resolutions: 2^n + 1.
UNITY_SIZES = tuple(2**n + 1 for n in range(5, 13))
#: Largest side of an EXR preset grid.
MAX_EXR_SIDE = 16384
#: Most tiles a side (32 x 32: 1024 heightmap files).
MAX_TILES = 32
#: Most samples a side of a whole grid of tiles (16 x 16 Unreal tiles of
#: 2017 samples hold 32257, 4 x 4 of 8129 32513: what the app's export
#: dialog offers).  The export makes one tile at a time; the terrain it reads
#: from memory (the app's, a DEM read whole) is the caller's.
MAX_TILED_SIDE = 32769


@dataclass(frozen=True)
class EnginePreset:
    """What one engine or tool gets.

    Attributes
    ----------
    name : str
        ``unreal``, ``unity``, ``godot``, ``blender`` or ``houdini``.
    title : str
        Shown in menus.
    extension : str
        Of the heightmap files.
    sizes : tuple of int or None
        Allowed samples a side (per tile); ``None``: any, cells kept square.
    tiles : bool
        Whether ``tiles > 1`` is supported.
    how_to_import : str
        One paragraph, also written into the settings JSON.
    """

    name: str
    title: str
    extension: str
    sizes: tuple[int, ...] | None
    tiles: bool
    how_to_import: str


PRESETS: dict[str, EnginePreset] = {p.name: p for p in (
    EnginePreset(
        "unreal", "Unreal Engine (Landscape)", ".png", UNREAL_SIZES, True,
        "Landscape mode > Manage > New > Import from File: pick the PNG (or, with tiles, the x0_y0 tile: "
        "Unreal finds the others by their _x{i}_y{j} names); set Scale X, Y, Z and the Location Z below."),
    EnginePreset(
        "unity", "Unity (Terrain)", ".r16", UNITY_SIZES, True,
        "Terrain > Terrain Settings > Import Raw: Depth 16 bit, Byte Order Windows, Resolution as below, "
        "tick Flip Vertically (rows run north to south), Terrain Size = width x height x length below; "
        "set the terrain's Y position to position_y_m. Tiles: one terrain each, at the positions below."),
    EnginePreset(
        "godot", "Godot (Terrain3D / HeightMapShape3D)", ".exr", None, False,
        "Terrain3D: Importer > height_file_name = the EXR, import_scale 1 (values are metres), "
        "vertex_spacing = cell size. HeightMapShape3D: Image.load_from_file, then "
        "update_map_data_from_image(image, 0, 1) keeps metres; scale the node by the cell size on X and Z."),
    EnginePreset(
        "blender", "Blender (Displace)", ".exr", None, False,
        "Add a Grid with as many vertices as the EXR has pixels and the size below, a Displace modifier "
        "with an Image Texture of the EXR (Color Space Non-Color, Extension Extend), Strength 1, Midlevel 0, "
        "Coordinates UV: heights come out in metres."),
    EnginePreset(
        "houdini", "Houdini (HeightField File)", ".exr", None, False,
        "HeightField File SOP: File = the EXR, Layer = height, Grid Spacing = cell size below, "
        "Height Scale 1 (values are metres); or a HeightField of the size below and a HeightField Layer "
        "import."),
)}


@dataclass(frozen=True)
class EngineExport:
    """What :func:`export_for_engine` wrote.

    Attributes
    ----------
    preset : str
    files : tuple of Path
        Heightmaps, their sidecars and the settings JSON, in writing order.
    settings : dict
        The content of the settings JSON.
    notes : list of str
        What was done to the input on the way (nodata filled, cells
        resampled to square, size chosen).
    """

    preset: str
    files: tuple[Path, ...]
    settings: dict
    notes: list

    def summary(self) -> str:
        """One line with the numbers to type into the engine."""
        s = self.settings
        if self.preset == "unreal":
            sc = s["scale_cm"]
            return (f"Unreal: Scale X {sc['x']:.4f} Y {sc['y']:.4f} Z {sc['z']:.4f} (cm), "
                    f"Location Z {s['location_cm']['z']:.2f} cm; {s['size']} x {s['size']} per tile")
        if self.preset == "unity":
            size = s["terrain_size_m"]
            return (f"Unity: resolution {s['size']}, width {size['width']:.3f} m, length {size['length']:.3f} m, "
                    f"height {size['height']:.3f} m, position Y {s['position_y_m']:.3f} m")
        rows, cols = s["shape"]
        dy, dx = s["cell_size_m"]
        return f"{PRESETS[self.preset].title}: {cols} x {rows} samples, cell {dx:.4f} x {dy:.4f} m, heights in metres"


def preset_names() -> tuple[str, ...]:
    """Names of :data:`PRESETS`."""
    return tuple(PRESETS)


def default_size(preset: EnginePreset, longest: int, tiles: int = 1) -> int:
    """Samples a side (per tile) that keep every sample of a grid ``longest`` long.

    The smallest allowed size whose tiled grid ``tiles (n - 1) + 1`` is at
    least ``longest`` (the largest allowed if none is); the grid itself for
    presets without fixed sizes.
    """
    if preset.sizes is None:
        return longest
    for n in preset.sizes:
        if tiles * (n - 1) + 1 >= longest:
            return n
    return preset.sizes[-1]


def engine_ready(field: HeightField) -> tuple[HeightField, list[str]]:
    """``field`` with square ground cells in metres and no nodata, and notes on what changed.

    Geographic or non-square cells are resampled to square cells of the
    finer side (:func:`~terrasynth_core.io.resample.to_square_cells`, then
    cropped to the valid area); nodata is filled from its neighbours
    (engines have no holes); an unknown cell size is taken as 1 m.
    """
    notes = []
    if field.cell_size is None:
        field = to_square_cells(field, 1.0)
        notes.append("the DEM has no cell size: cells taken as 1 m")
    else:
        before = field.cell_size
        squared = to_square_cells(field, min(before))
        if squared is not field:
            field = squared.crop_valid()
            notes.append(f"cells of {before[0]:g} x {before[1]:g} m (dy x dx) resampled to square "
                         f"{field.cell_size[0]:g} m cells, {field.shape[0]} x {field.shape[1]}")
    if field.nodata_count:
        notes.append(f"{field.nodata_count} nodata cells filled from their neighbours (engines have no holes)")
        field = field.fill_nodata()
    return field, notes


def preset_shape(preset: EnginePreset, field: HeightField, size: int | None, tiles: int) -> tuple[int, int]:
    """The whole grid's ``(rows, cols)`` for ``preset`` at ``size`` samples a side (per tile).

    Fixed-size presets: ``tiles (size - 1) + 1`` on both sides.  EXR
    presets: ``size`` on the longer side, the other side keeping the cells
    square (``size`` ``None``: the field's own shape).
    """
    if preset.sizes is not None:
        side = tiles * (size - 1) + 1
        return side, side
    return field.shape if size is None else longer_side_shape(field, size)


def longer_side_shape(field: HeightField, size: int) -> tuple[int, int]:
    """``(rows, cols)`` with ``size`` samples on the longer side and about
    square cells over the same span (the EXR presets' and the masks' rule).

    Raises
    ------
    ParamsError
        ``size`` outside 2 to :data:`MAX_EXR_SIDE`.
    """
    if not 2 <= size <= MAX_EXR_SIDE:
        raise ParamsError(f"size {size}: expected 2 to {MAX_EXR_SIDE} samples on the longer side")
    rows, cols = field.shape
    dy, dx = field.cell_size or (1.0, 1.0)
    span_y, span_x = (rows - 1) * dy, (cols - 1) * dx
    cell = max(span_y, span_x) / (size - 1)
    return max(2, round(span_y / cell) + 1), max(2, round(span_x / cell) + 1)


def _check_options(preset_name: str, size: int | None, tiles: int) -> EnginePreset:
    preset = PRESETS.get(preset_name)
    if preset is None:
        raise ParamsError(f"unknown preset {preset_name!r}; expected one of {', '.join(PRESETS)}")
    if not (isinstance(tiles, int) and 1 <= tiles <= MAX_TILES):
        raise ParamsError(f"tiles must be a whole number from 1 to {MAX_TILES}, got {tiles!r}")
    if tiles > 1 and not preset.tiles:
        raise ParamsError(f"the {preset_name} preset writes one heightfield; tiles are for unreal and unity")
    if size is not None:
        if preset.sizes is not None and size not in preset.sizes:
            raise ParamsError(f"size {size} is not one of the {preset_name} heightmap sizes: "
                              f"{', '.join(map(str, preset.sizes))}")
        if preset.sizes is None and not 2 <= size <= MAX_EXR_SIDE:
            raise ParamsError(f"size {size}: expected 2 to {MAX_EXR_SIDE} samples on the longer side")
    return preset


def _tile_paths(out_dir: Path, stem: str, ext: str, tiles: int) -> list[tuple[int, int, Path]]:
    if tiles == 1:
        return [(0, 0, out_dir / f"{stem}{ext}")]
    return [(i, j, out_dir / f"{stem}_x{i}_y{j}{ext}") for j in range(tiles) for i in range(tiles)]


def _checked_paths(preset: EnginePreset, out_dir: Path, stem: str, tiles: int, **hint) -> tuple[list, Path]:
    """The heightmaps' ``(i, j, path)`` and the settings' path of an export
    into ``out_dir``, after refusing a folder that cannot take them or any
    of its files (sidecars included) that exists (``hint``: as in
    :func:`refuse_existing`)."""
    check_folder(out_dir)
    tile_paths = _tile_paths(out_dir, stem, preset.extension, tiles)
    settings_path = out_dir / f"{stem}.{preset.name}.json"
    heightmaps = [p for _, _, p in tile_paths]
    sidecars = [sidecar_path(p) for p in heightmaps] if preset.extension in (".png", ".r16") else []
    refuse_existing([*heightmaps, *sidecars, settings_path], **hint)
    return tile_paths, settings_path


def folder_beside(out: Path, preset: str) -> Path:
    """The folder a terrain file ``out``'s export for ``preset`` goes into
    beside it, ``OUTSTEM_PRESET`` (``world.tif`` -> ``world_unreal``), as a
    tiled run's ``--engine`` and the app's *Render large* write it."""
    out = Path(out)
    return out.with_name(f"{out.stem}_{preset}")


class _Grid:
    """A grid's shape and square cells, for planning an export before it exists."""

    def __init__(self, shape: tuple[int, int]):
        self.shape, self.cell_size = tuple(shape), (1.0, 1.0)


def check_export(preset: str, out_dir, *, shape: tuple[int, int], size: int | None = None, tiles: int = 1,
                 stem: str = "terrain", hint: str = "choose an empty folder or another --name") -> None:
    """Refuse (one line) what exporting a terrain of ``shape`` square cells
    would refuse, before the terrain exists: the options, the grid's size,
    the name, the folder, a file it would replace (``hint`` ends that
    message).  For a caller that exports at the end of a long run.

    An EXR preset at the terrain's own size is one whole grid, refused past
    :data:`MAX_EXR_SIDE` (give ``size``).

    Raises
    ------
    ParamsError, DEMFormatError
    """
    check_stem(stem)
    chosen = _check_options(preset, size, tiles)
    _, grid = _plan(chosen, _Grid(shape), size, tiles, [])
    if chosen.sizes is None and max(grid) > MAX_EXR_SIDE:
        raise ParamsError(f"a {preset} EXR of {grid[0]} x {grid[1]} samples is one whole grid in memory: give its "
                          f"size, the longer side, up to {MAX_EXR_SIDE}")
    _checked_paths(chosen, Path(out_dir), stem, tiles, hint=hint)


def check_stem(stem: str) -> None:
    """Refuse a start of file names that is empty or names a folder
    (``/``, ``\\``, ``..``, a Windows drive's ``:``): every file an export
    writes goes into its folder.

    Raises
    ------
    ParamsError
    """
    if (not isinstance(stem, str) or not stem.strip() or stem in (".", "..")
            or any(c in stem for c in ("/", "\\", ":", "\0"))):
        raise ParamsError(f"name {stem!r}: expected the start of a file name without folders, e.g. 'terrain'")


def check_folder(out_dir: Path) -> None:
    """Refuse an output folder that is a file, or whose parent folder does
    not exist (one line): the export creates the folder itself, not a
    mistyped path to it.

    Raises
    ------
    DEMFormatError
    """
    if out_dir.exists() and not out_dir.is_dir():
        raise DEMFormatError(f"{out_dir} is a file; the output must be a folder (it is created if missing)")
    parent = out_dir.absolute().parent
    if not out_dir.exists() and not parent.is_dir():
        if parent.exists():
            raise DEMFormatError(f"{parent} is a file; the output folder {out_dir.name} must be in a folder")
        raise DEMFormatError(f"folder {parent} does not exist: the export creates only its own folder "
                             f"{out_dir.name}, in a folder that exists")


def refuse_existing(paths, hint: str = "choose an empty folder or another --name") -> None:
    """Refuse (one line) when any of ``paths`` exists: an export never replaces a file.

    Parameters
    ----------
    paths : iterable of path-like
    hint : str
        What the user can do instead, ending the message.

    Raises
    ------
    DEMFormatError
        Naming the first existing file.
    """
    for path in paths:
        if os.path.lexists(path):  # (a dangling link too: writing would replace it)
            raise DEMFormatError(f"{path} exists; an export never replaces files: {hint}")


@contextmanager
def writing_into(out_dir: Path) -> Iterator[list[Path]]:
    """Make ``out_dir`` if missing, for a block that writes new files into
    it and appends each to the list yielded.  If the block fails, those
    files are removed, and the folder too when this call made it and
    nothing else was put there: a failed export leaves no trace."""
    written: list[Path] = []
    created = not out_dir.exists()
    try:
        out_dir.mkdir(exist_ok=True)
        yield written
    except BaseException:
        for path in written:  # only what the block created
            path.unlink(missing_ok=True)
        if created:
            try:
                out_dir.rmdir()
            except OSError:
                pass  # something else is in it now
        raise


def preset_grid(field: HeightField, preset: str, *, size: int | None = None,
                tiles: int = 1) -> tuple[HeightField, int | None, list[str]]:
    """The whole grid ``preset`` gets from ``field``: engine-ready, resampled to its size.

    Parameters
    ----------
    field : HeightField
    preset : str
        A key of :data:`PRESETS`.
    size : int, optional
        As in :func:`export_for_engine` (default :func:`default_size`).
    tiles : int, default 1

    Returns
    -------
    grid : HeightField
        Square metres cells, no nodata, of :func:`preset_shape`.
    size : int or None
        The size used (per tile), ``None`` for an EXR preset kept as is.
    notes : list of str
        What was done (:func:`engine_ready`, the size chosen, the resampling).

    Raises
    ------
    ParamsError
        As :func:`export_for_engine`.
    """
    chosen = _check_options(preset, size, tiles)
    ready, notes = engine_ready(field)
    size, shape = _plan(chosen, ready, size, tiles, notes)
    return resample_nodes(ready, shape), size, notes


def _plan(preset: EnginePreset, ready, size: int | None, tiles: int, notes: list) -> tuple[int | None, tuple]:
    """The size per tile and the whole grid's shape for an engine-ready
    ``ready`` (anything with ``shape`` and ``cell_size``); adds to ``notes``
    what was chosen and how the grid is resampled."""
    if size is None and preset.sizes is not None:
        size = default_size(preset, max(ready.shape), tiles)
        notes.append(f"size {size} chosen: the smallest {preset.name} size that keeps every sample")
    if size is not None and tiles * (size - 1) + 1 > MAX_TILED_SIDE:
        raise ParamsError(f"{tiles} x {tiles} tiles of {size} samples make a grid of {tiles * (size - 1) + 1} "
                          f"samples a side; at most {MAX_TILED_SIDE}: fewer tiles or a smaller size")
    shape = preset_shape(preset, ready, size, tiles)
    if tuple(shape) != tuple(ready.shape):
        notes.append(f"resampled from {ready.shape[0]} x {ready.shape[1]} to {shape[0]} x {shape[1]} samples "
                     f"({'area average' if shape[0] * shape[1] < ready.shape[0] * ready.shape[1] else 'cubic'})")
    return size, tuple(shape)


def export_for_engine(field: HeightField, preset: str, out_dir, *, size: int | None = None, tiles: int = 1,
                      stem: str = "terrain", cancel=None) -> EngineExport:
    """Write ``field`` as ``preset`` heightmaps (and settings) into ``out_dir``.

    Parameters
    ----------
    field : HeightField
        Heights in metres, shape (rows, cols), any cell size (see
        :func:`engine_ready`).
    preset : str
        A key of :data:`PRESETS`.
    out_dir : str or path-like
        Created if missing, in a folder that exists.  No existing file is replaced.
    size : int, optional
        Samples a side per tile (fixed-size presets: one of their sizes;
        default :func:`default_size`), or on the longer side for EXR
        presets (default: as is).
    tiles : int, default 1
        ``K`` for a ``K x K`` grid of tiles (unreal, unity).
    stem : str, default "terrain"
        Start of every file name.
    cancel : callable, optional
        ``cancel()`` True stops the export between bands and tiles.

    Returns
    -------
    EngineExport

    Raises
    ------
    ParamsError
        Unknown preset, a size the preset does not take, tiles where not
        supported or making a grid over :data:`MAX_TILED_SIDE`, a ``stem``
        with folders in it.
    DEMFormatError
        A file the export would write exists, or writing failed (the files
        this call wrote are removed).
    SynthesisCancelled
        ``cancel()`` turned True (the files this call wrote are removed).
    """
    check_stem(stem)
    chosen = _check_options(preset, size, tiles)
    ready, notes = engine_ready(field)
    return _export(_FieldWindows(ready), chosen, Path(out_dir), size, tiles, stem, notes, cancel)


def export_file_for_engine(path, preset: str, out_dir, *, size: int | None = None, tiles: int = 1,
                           stem: str = "terrain", band: int | None = None,
                           input_size: tuple[int, int] | None = None, cancel=None) -> EngineExport:
    """:func:`export_for_engine` of a DEM file, read window by window.

    A raster GDAL reads (a world-size terrain's GeoTIFF) with square cells
    in metres and no nodata is never held whole: each tile reads only the
    cells its resampling reaches, so memory follows the tile, not the
    terrain.  Any other file (another format, cells to make square, nodata
    to fill) is read whole and exported as :func:`export_for_engine` does.
    The files written are the same either way.

    Parameters
    ----------
    path : str or path-like
        The DEM.
    band : int, optional
        1-based band of a multi-band raster.
    input_size : (rows, cols), optional
        Of a headerless ``.r16``/``.r32`` file (``size`` of
        :func:`~terrasynth_core.io.load_dem`).
    preset, out_dir, size, tiles, stem, cancel
        As in :func:`export_for_engine`.

    Returns
    -------
    EngineExport

    Raises
    ------
    ParamsError, DEMFormatError
        As :func:`export_for_engine` and :func:`~terrasynth_core.io.load_dem`.
    """
    check_stem(stem)
    chosen = _check_options(preset, size, tiles)
    path = Path(path)
    raster = open_raster_windows(path, band=band)
    if (raster is not None and min(raster.shape) >= LEAST_SIDE and raster.cell_size is not None
            and already_square(raster, min(raster.cell_size))):
        try:
            return _export(raster, chosen, Path(out_dir), size, tiles, stem, [], cancel)
        except _NeedsWhole:
            pass  # found before anything was written: read whole below
    field = load_dem(path, size=input_size, band=band)
    return export_for_engine(field, preset, out_dir, size=size, tiles=tiles, stem=stem, cancel=cancel)


class _NeedsWhole(Exception):
    """A windowed source holds nodata, which only the whole grid can fill
    (or an infinite height, which the whole read refuses by name)."""


class _FieldWindows:
    """A field in memory as the windowed source :func:`_export` reads."""

    def __init__(self, field: HeightField):
        self.field, self.shape, self.cell_size, self.georef = field, field.shape, field.cell_size, field.georef

    def read(self, r0: int, r1: int, c0: int, c1: int):
        return self.field.heights[r0:r1, c0:c1]


#: Rows of the resampled grid made at a time (their float64 temporaries are
#: a few tens of MB on the widest grid).
_BAND_ROWS = 256


def _export(source, preset: EnginePreset, out_dir: Path, size: int | None, tiles: int, stem: str,
            notes: list, cancel=None) -> EngineExport:
    """Write the heightmaps of an engine-ready windowed ``source`` (``shape``,
    ``cell_size``, ``georef`` and ``read(r0, r1, c0, c1)``), one tile at a time.

    The grid is resampled in bands of rows for the height range every tile
    shares, then again tile by tile to write, never held whole (one tile,
    the whole grid, keeps its bands).

    Raises
    ------
    _NeedsWhole
        Before anything is written.
    """
    size, shape = _plan(preset, source, size, tiles, notes)
    tile_paths, settings_path = _checked_paths(preset, out_dir, stem, tiles)
    grid = NodeGrid(source.shape, shape)

    def read(i0, i1, j0, j1):
        if cancel is not None and cancel():
            raise SynthesisCancelled("export cancelled")
        block = source.read(i0, i1, j0, j1)
        if not np.isfinite(block).all():
            raise _NeedsWhole  # (nodata to fill, or an infinity to refuse, naming the file)
        return block

    def block(r0, r1, c0, c1):
        # In bands of rows: the filters' float64 temporaries stay a band's size.
        out = np.empty((r1 - r0, c1 - c0), np.float32)
        for b0 in range(r0, r1, _BAND_ROWS):
            b1 = min(b0 + _BAND_ROWS, r1)
            out[b0 - r0:b1 - r0] = grid.window(read, b0, b1, c0, c1)
        return out

    # One tile is the whole grid: the range's bands are kept as it, not
    # made again.  Several are made again tile by tile (never held whole).
    whole = np.empty(shape, np.float32) if tiles == 1 else None
    lo, hi = np.inf, -np.inf
    for r0 in range(0, shape[0], _BAND_ROWS):
        band = grid.window(read, r0, min(r0 + _BAND_ROWS, shape[0]), 0, shape[1])
        lo, hi = min(lo, float(band.min())), max(hi, float(band.max()))
        if whole is not None:
            whole[r0:r0 + len(band)] = band
    cell_size, georef = node_grid_placement(source, shape)
    settings = _settings(preset, shape, cell_size, (lo, hi), size, tiles, tile_paths)
    level_range = (lo, hi if hi > lo else lo + 1.0) if preset.extension != ".exr" else None
    side = size if tiles > 1 else None
    with writing_into(out_dir) as written:
        for i, j, path in tile_paths:
            r0, c0 = (j * (side - 1), i * (side - 1)) if side else (0, 0)
            r1, c1 = (r0 + side, c0 + side) if side else shape
            tile = HeightField(whole if whole is not None else block(r0, r1, c0, c1), cell_size=cell_size,
                               georef=None if georef is None else georef.at(r0, c0))
            save_dem(tile, path, level_range=level_range)
            written.append(path)
            if preset.extension != ".exr":
                written.append(sidecar_path(path))
        settings["notes"] = notes
        with wrap_errors(settings_path, "write"), atomic_outputs(settings_path) as (temp,), open_new(temp) as fh:
            fh.write((json.dumps(settings, indent=2) + "\n").encode("utf-8"))
        written.append(settings_path)
    return EngineExport(preset.name, tuple(written), settings, notes)


def _settings(preset: EnginePreset, shape: tuple[int, int], cell_size: tuple[float, float],
              height_range: tuple[float, float], size: int, tiles: int, tile_paths) -> dict:
    """The settings JSON: what to type into the engine, and the terrain's metres."""
    rows, cols = shape
    dy, dx = cell_size
    lo, hi = height_range
    span = hi - lo if hi > lo else 1.0
    settings = {
        "format": "terrasynth-engine-export",
        "preset": preset.name,
        "files": [p.name for _, _, p in tile_paths],
        "shape": [rows, cols],
        "cell_size_m": [dy, dx],
        "extent_m": {"north_south": (rows - 1) * dy, "east_west": (cols - 1) * dx},
        "height_range_m": [lo, hi],
        "how_to_import": preset.how_to_import,
    }
    if preset.name == "unreal":
        # Unreal: height_cm = Location.Z + (level - 32768) * Scale.Z / 128.
        z_scale = 12800.0 * span / 65535.0
        settings.update({
            "size": size, "tiles": tiles,
            "scale_cm": {"x": dx * 100.0, "y": dy * 100.0, "z": z_scale},
            "location_cm": {"z": lo * 100.0 + 256.0 * z_scale},
        })
    elif preset.name == "unity":
        # Unity maps levels 0..65535 to 0..height above the terrain's position.
        width, length = (size - 1) * dx, (size - 1) * dy
        settings.update({
            "size": size, "tiles": tiles, "byte_order": "little-endian (Windows)", "flip_vertically": True,
            "terrain_size_m": {"width": width, "length": length, "height": span},
            "position_y_m": lo,
            "tile_positions_m": [{"file": p.name, "x": i * width, "z": (tiles - 1 - j) * length}
                                 for i, j, p in tile_paths],
        })
    return settings


def unreal_heights_m(levels, settings: dict):
    """Metres of Unreal landscape levels under the settings' Z scale and location.

    What Unreal computes from the PNG on import, for checking the numbers:
    ``(Location.Z + (level - 32768) * Scale.Z / 128) / 100``.
    """
    z = settings["scale_cm"]["z"]
    return (settings["location_cm"]["z"] + (levels.astype("float64") - 32768.0) * z / 128.0) / 100.0


def unity_heights_m(levels, settings: dict):
    """Metres of Unity terrain levels: ``position_y + level / 65535 * height``."""
    return settings["position_y_m"] + levels.astype("float64") / 65535.0 * settings["terrain_size_m"]["height"]


__all__ = ["EngineExport", "EnginePreset", "PRESETS", "UNITY_SIZES", "UNREAL_SIZES", "default_size",
           "check_export", "engine_ready", "export_file_for_engine", "export_for_engine", "folder_beside",
           "longer_side_shape", "preset_grid",
           "preset_names", "preset_shape", "refuse_existing", "unity_heights_m", "unreal_heights_m"]
