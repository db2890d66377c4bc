"""The app's model: plain Python, no Qt.

:class:`Document` holds the :class:`Sketch` (strokes, style regions and
water, with undo history), the chosen :class:`ExampleRef` list, the styles
(:class:`StyleSpec`), elevation pins, stamps (:class:`StampSpec`), the
synthesis parameters and the last :class:`TerrainResult`;
:func:`save_project` / :func:`load_project` write and read it as one file;
:class:`RecoveryStore` autosaves it; :func:`example_map_document` makes one
of a built-in multi-style map, and :mod:`.region_maps` reads style-region
and water-mask PNGs into its layers.

A run is a :class:`SynthesisRequest` (a snapshot of the document) and the
generators :func:`synthesis_events` / :func:`variation_events` that a worker
drains; :func:`live_request` / :func:`live_events` do the same for a live
update after a stroke.  Derived data: :class:`SketchGraph` and :class:`TerrainGraph`, the
feature graphs of the sketch and of the terrain.
"""

from .brushes import capsule_coverage
from .control_specs import StampSpec, StyleSpec, fitting_scale
from .dem_features import dem_feature_layers, dem_file_feature_layers
from .document import Document
from .example_library import ExampleRef, builtin_refs
from .example_maps import EXAMPLE_MAPS, example_map_document
from .export import export_for_engine_preset, export_masks, export_terrain, mask_preview
from .feature_graphs import DerivedGraph, SketchGraph, TerrainGraph
from .history import SketchEdit, SketchHistory
from .live import LiveRequest, LiveUpdated, live_events, live_preparation, live_request, same_strokes
from .observable import Observable
from .project import PROJECT_EXTENSION, ProjectError, load_project, save_project
from .recovery import RecoveryStore
from .region_maps import style_layer_from_png, water_layer_from_png
from .result import TerrainResult
from .run_request import (MAX_SEED, RunInfo, RunStarted, SynthesisRequest, VariationMade, run_info, synthesis_events,
                          variation_events)
from .sketch_layers import REGION_TOOLS, STROKE_TOOLS, TOOLS, Sketch, resize_nearest

__all__ = [
    "EXAMPLE_MAPS",
    "MAX_SEED",
    "PROJECT_EXTENSION",
    "REGION_TOOLS",
    "STROKE_TOOLS",
    "TOOLS",
    "DerivedGraph",
    "LiveRequest",
    "LiveUpdated",
    "Document",
    "ExampleRef",
    "Observable",
    "ProjectError",
    "RecoveryStore",
    "RunInfo",
    "RunStarted",
    "Sketch",
    "SketchEdit",
    "SketchGraph",
    "SketchHistory",
    "StampSpec",
    "StyleSpec",
    "SynthesisRequest",
    "TerrainGraph",
    "TerrainResult",
    "VariationMade",
    "builtin_refs",
    "capsule_coverage",
    "dem_feature_layers",
    "dem_file_feature_layers",
    "example_map_document",
    "export_terrain",
    "fitting_scale",
    "live_events",
    "live_preparation",
    "live_request",
    "load_project",
    "resize_nearest",
    "export_for_engine_preset",
    "export_masks",
    "mask_preview",
    "run_info",
    "same_strokes",
    "save_project",
    "style_layer_from_png",
    "synthesis_events",
    "variation_events",
    "water_layer_from_png",
]
