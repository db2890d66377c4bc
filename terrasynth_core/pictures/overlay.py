"""Ridges and valleys drawn over the grey hillshade of their DEM."""

from __future__ import annotations

import numpy as np
from skimage.draw import disk

from ..errors import ParamsError
from ..features.graph import FeatureGraph, FeatureMaps
from ..features.network import graph_mask
from .shading import hillshade

#: Colours, RGB uint8.
RIDGE_COLOUR = (230, 30, 30)
VALLEY_COLOUR = (30, 90, 255)
BRANCH_COLOUR = (255, 220, 0)
END_COLOUR = (255, 255, 255)
NODATA_COLOUR = (40, 40, 48)


def _draw_nodes(rgb: np.ndarray, graph: FeatureGraph, radius: float) -> None:
    """Paint branch points and endpoints of ``graph`` into ``rgb`` in place."""
    for node in graph.nodes:
        colour = BRANCH_COLOUR if node.type == "branch" else END_COLOUR
        r = radius * (1.5 if node.type == "branch" else 1.0)
        rr, cc = disk((node.row, node.col), r, shape=rgb.shape[:2])
        rgb[rr, cc] = colour


def render_overlay(
    heights,
    maps: FeatureMaps,
    *,
    cell_size=None,
    line_width: int | None = None,
    show_nodes: bool = True,
) -> np.ndarray:
    """Ridges and valleys drawn over the hillshade of their DEM.

    Parameters
    ----------
    heights : ndarray, shape (rows, cols), or HeightField
        Heights in metres, NaN = nodata.
    maps : FeatureMaps
        Features extracted from ``heights`` (graph shapes must match).
    cell_size : float, (dy, dx) or None
        Cell size in metres for the hillshade; None takes the HeightField's,
        else 1.
    line_width : int or None
        Line width in cells; None picks 1 per 600 cells of the larger side
        (at least 1).
    show_nodes : bool, default True
        Mark branch points (yellow) and endpoints (white).

    Returns
    -------
    ndarray of uint8, shape (rows, cols, 3)
        Grey hillshade, ridges red, valleys blue; nodata cells dark grey.
    """
    shade = hillshade(heights, cell_size=cell_size)
    for graph in (maps.ridges, maps.valleys):
        if tuple(graph.shape) != shade.shape:
            raise ParamsError(
                f"{graph.kind} graph shape {tuple(graph.shape)} does not match heights shape {shade.shape}"
            )
    if line_width is None:
        line_width = max(1, round(max(shade.shape) / 600))
    if not (isinstance(line_width, (int, np.integer)) and 1 <= line_width <= 50):
        raise ParamsError(f"line_width must be an integer from 1 to 50 cells, got {line_width!r}")
    # A narrower grey range than the hillshade's own keeps the lines readable.
    grey = np.rint(40 + 200 * np.nan_to_num(shade, nan=0.0)).astype(np.uint8)
    rgb = np.repeat(grey[:, :, None], 3, axis=2)
    rgb[np.isnan(shade)] = NODATA_COLOUR
    for graph, colour in ((maps.valleys, VALLEY_COLOUR), (maps.ridges, RIDGE_COLOUR)):
        if graph.paths:
            rgb[graph_mask(graph, width=line_width)] = colour
    if show_nodes:
        radius = max(1.5, 1.2 * line_width)
        for graph in (maps.valleys, maps.ridges):
            _draw_nodes(rgb, graph, radius)
    return rgb
