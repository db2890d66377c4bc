"""Ridges and valleys: PPA on DEMs, analysis of sketches, the feature graph.

* :func:`extract_features` runs PPA on a DEM (:mod:`.ppa`);
* :func:`read_sketch` / :func:`sketch_features` turn a red/blue sketch into
  the same kind of graphs (:mod:`.sketch`);
* both share the mask-to-graph pipeline of :mod:`.network`.

:func:`terrasynth_core.pictures.render_overlay` draws the graphs over a
hillshade.
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .graph import FeatureGraph, FeatureMaps, FeatureNode, FeaturePath
    from .ppa import PPAParams, extract_features, extract_ridges, extract_valleys
    from .sketch import SketchMap, SketchParams, read_sketch, resize_nearest, save_sketch, sketch_features

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".graph": ("FeatureGraph", "FeatureMaps", "FeatureNode", "FeaturePath"),
    ".ppa": ("PPAParams", "extract_features", "extract_ridges", "extract_valleys"),
    ".sketch": (
        "SketchMap", "SketchParams", "read_sketch", "resize_nearest", "save_sketch", "sketch_features"
    ),
})
