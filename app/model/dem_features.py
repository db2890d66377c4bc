"""Turning the ridges and valleys of a real DEM into sketch strokes."""

from __future__ import annotations

import numpy as np

from terrasynth_core.features import FeatureGraph, FeatureNode, FeaturePath, extract_features
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import load_dem


def scaled_graph(graph: FeatureGraph, shape: tuple[int, int]) -> FeatureGraph:
    """``graph`` stretched from its grid onto a grid of ``shape`` (rows, cols).

    Cell centres map onto cell centres, so corner cells stay corner cells.
    """
    (rows, cols), (new_rows, new_cols) = graph.shape, shape
    sr = (new_rows - 1) / max(rows - 1, 1)
    sc = (new_cols - 1) / max(cols - 1, 1)
    nodes = tuple(FeatureNode(n.id, n.row * sr, n.col * sc, n.type, n.degree) for n in graph.nodes)
    paths = tuple(FeaturePath(p.start, p.end, np.asarray(p.points, float) * (sr, sc)) for p in graph.paths)
    return FeatureGraph(graph.kind, tuple(shape), nodes, paths)


def dem_feature_layers(field: HeightField, shape: tuple[int, int], *, width: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Ridge and valley stroke layers of a DEM, fitted to a sketch of ``shape``.

    Parameters
    ----------
    field : HeightField
        The DEM; nodata is filled first so every cell has a height.
    shape : (rows, cols)
        Size of the sketch to fill (the DEM is stretched to it).
    width : int, default 3
        Stroke width in sketch cells.

    Returns
    -------
    ridge, valley : ndarray of uint8, shape ``shape``
        Full-intensity strokes (255) on the features, 0 elsewhere.
    """
    maps = extract_features(field.fill_nodata().heights)
    ridge = scaled_graph(maps.ridges, shape).rasterize(width)
    valley = scaled_graph(maps.valleys, shape).rasterize(width) & ~ridge
    return (ridge * np.uint8(255)).astype(np.uint8), (valley * np.uint8(255)).astype(np.uint8)


def dem_file_feature_layers(path, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`dem_feature_layers` of the DEM file at ``path`` (slow: reads and traces it).

    Raises
    ------
    TerraSynthError
        When the file is not a readable DEM.
    """
    return dem_feature_layers(load_dem(path), shape)
