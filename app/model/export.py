"""Writing the synthesized terrain: DEM formats and meshes at any size, engine presets and masks."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from terrasynth_core.errors import ParamsError
from terrasynth_core.export import export_for_engine, terrain_masks, write_masks
from terrasynth_core.features import resize_nearest
from terrasynth_core.heightfield import LEAST_SIDE, MOST_GRID_CELLS, HeightField
from terrasynth_core.io import MESH_EXTENSIONS, WRITE_EXTENSIONS, save_dem, save_mesh
from terrasynth_core.io.resample import resample_nodes
from terrasynth_core.pictures import shaded_relief

from .result import TerrainResult

#: Extensions :func:`export_terrain` writes: DEM formats, then meshes.
EXPORT_EXTENSIONS: tuple[str, ...] = tuple(WRITE_EXTENSIONS) + tuple(MESH_EXTENSIONS)


def resampled_field(result: TerrainResult, size: tuple[int, int] | None = None) -> HeightField:
    """The result as a :class:`HeightField`, resampled to ``size``.

    Parameters
    ----------
    result : TerrainResult
    size : (rows, cols), optional
        Output grid; default the result's.  The ground span between the
        first and last samples is kept, so the cell size scales inversely;
        area average when shrinking, cubic when growing
        (:func:`terrasynth_core.io.resample.resample_nodes`).

    Raises
    ------
    ParamsError
        For a size below 2x2 or above 64 million cells.
    """
    field = HeightField(result.heights, cell_size=result.cell_size, georef=result.georef,
                        source="synthesized terrain")
    if size is None or tuple(size) == result.shape:
        return field
    new_rows, new_cols = (int(v) for v in size)
    if min(new_rows, new_cols) < LEAST_SIDE or new_rows * new_cols > MOST_GRID_CELLS:
        raise ParamsError(f"export size {new_rows}x{new_cols}: expected {LEAST_SIDE}x{LEAST_SIDE} to "
                          f"{MOST_GRID_CELLS // 1_000_000} million cells")
    return resample_nodes(field, (new_rows, new_cols))


def export_terrain(result: TerrainResult, path: str | os.PathLike, *, size: tuple[int, int] | None = None,
                   vertical_scale: float = 1.0, step: int = 1, target_triangles: int | None = None,
                   texture: bool = False) -> Path:
    """Write ``result`` as a DEM or a mesh, chosen by the extension of ``path``.

    Parameters
    ----------
    result : TerrainResult
    path : str or path-like
        One of :data:`EXPORT_EXTENSIONS`.
    size : (rows, cols), optional
        Resample to this grid first (see :func:`resampled_field`).
    vertical_scale : float, default 1.0
        Height exaggeration, meshes only.
    step : int, default 1
        Keep every ``step``-th row and column, meshes only.
    target_triangles : int, optional
        Simplify the mesh to about this many triangles, meshes only.
    texture : bool, default False
        ``.glb`` only: drape the height colours under the hillshade (the
        2D view's picture) over the mesh.

    Returns
    -------
    Path
        The file written (DEM formats may add a JSON sidecar beside it).

    Raises
    ------
    DEMFormatError, ParamsError
        Unsupported extension, unwritable file or bad options, one line each.
    """
    path = Path(path)
    field = resampled_field(result, size)
    if path.suffix.lower() in MESH_EXTENSIONS:
        picture = None
        if texture and path.suffix.lower() == ".glb":
            picture = shaded_relief(field.heights, cell_size=field.cell_size)[..., :3]
        save_mesh(field, path, vertical_scale=vertical_scale, step=step, target_triangles=target_triangles,
                  texture=picture)
    else:
        save_dem(field, path)
    return path


def export_for_engine_preset(result: TerrainResult, preset: str, folder: str | os.PathLike, *,
                             size: int | None = None, tiles: int = 1, name: str = "terrain") -> str:
    """Write ``result`` for a game engine or DCC tool into ``folder``.

    Parameters
    ----------
    result : TerrainResult
    preset : str
        A key of :data:`terrasynth_core.export.PRESETS`.
    folder : str or path-like
        No existing file in it is replaced.
    size, tiles, name
        As in :func:`terrasynth_core.export.export_for_engine`.

    Returns
    -------
    str
        The one-line summary with the numbers to type into the engine.
    """
    done = export_for_engine(resampled_field(result), preset, folder, size=size, tiles=tiles, stem=name)
    return f"{done.summary()} (in {Path(folder) / done.files[-1].name})"


def _painted_layers(shape, water, style_ids):
    """The painted water and style layers on the terrain's grid; None where nothing is painted."""
    if water is not None:
        water = resize_nearest(np.asarray(water), shape) if np.any(water) else None
    if style_ids is not None:
        style_ids = resize_nearest(np.asarray(style_ids), shape) if (np.asarray(style_ids) >= 0).any() else None
    return water, style_ids


def export_masks(result: TerrainResult, folder: str | os.PathLike, *, fmt: str = "png8", name: str = "terrain",
                 water: np.ndarray | None = None, style_ids: np.ndarray | None = None) -> str:
    """Write the masks (splat maps) of ``result`` into ``folder``.

    Parameters
    ----------
    result : TerrainResult
    folder : str or path-like
        No existing file in it is replaced.
    fmt : {"png8", "png16", "exr"}
    name : str
        Start of the file names.
    water : ndarray of bool, optional
        The painted water (any shape: resized to the terrain's); without
        any water painted, water is what lies at or below sea level.
    style_ids : ndarray of int, optional
        The painted style regions (-1 none), resized likewise.

    Returns
    -------
    str
        What was written, and the notes.
    """
    water, style_ids = _painted_layers(result.shape, water, style_ids)
    masks = terrain_masks(resampled_field(result), water=water, style_ids=style_ids)
    written = write_masks(masks, folder, fmt=fmt, stem=name)
    notes = "".join(f"; {note}" for note in masks.notes)
    return f"{len(written) - 1} masks in {Path(folder)}{notes}"


def mask_preview(result: TerrainResult, name: str, *, water: np.ndarray | None = None,
                 style_ids: np.ndarray | None = None) -> np.ndarray | None:
    """One mask of ``result`` as :func:`export_masks` would write it, for the 2D view.

    Parameters
    ----------
    result : TerrainResult
    name : str
        One of :data:`terrasynth_core.export.MASK_NAMES` or ``"style_regions"``.
    water, style_ids : ndarray, optional
        The painted layers, as in :func:`export_masks`.

    Returns
    -------
    ndarray or None
        The mask (see :mod:`terrasynth_core.export.masks`); None when the
        terrain has none of it (no water, no style regions).
    """
    water, style_ids = _painted_layers(result.shape, water, style_ids)
    names = () if name == "style_regions" else (name,)
    masks = terrain_masks(resampled_field(result), water=water, style_ids=style_ids, names=names)
    return masks.masks.get(name)
