"""The app's document model: plain Python, no Qt.

:class:`Document` holds the :class:`Sketch` (strokes, style regions and
water, with undo history), the chosen :class:`ExampleRef` list, the styles
(:class:`StyleSpec`), elevation pins, stamps (:class:`StampSpec`), the
synthesis parameters and the last :class:`TerrainResult`;
:func:`save_project` / :func:`load_project` write and read it as one file;
:class:`RecoveryStore` autosaves it; :func:`example_map_document` makes one
of a built-in multi-style map, and :mod:`.region_maps` reads style-region
and water-mask PNGs into its layers.
"""

from .controls import StampSpec, StyleSpec, fitting_scale
from .document import Document, SynthesisRequest
from .events import Event
from .example_maps import EXAMPLE_MAPS, example_map_document
from .examples import ExampleRef, builtin_refs
from .history import SketchEdit, SketchHistory
from .project import PROJECT_EXTENSION, ProjectError, load_project, save_project
from .recovery import RecoveryStore
from .region_maps import style_layer_from_png, water_layer_from_png
from .result import TerrainResult
from .sketch import REGION_TOOLS, STROKE_TOOLS, TOOLS, Sketch, capsule_coverage, resize_nearest

__all__ = [
    "EXAMPLE_MAPS",
    "PROJECT_EXTENSION",
    "REGION_TOOLS",
    "STROKE_TOOLS",
    "TOOLS",
    "Document",
    "Event",
    "ExampleRef",
    "ProjectError",
    "RecoveryStore",
    "Sketch",
    "SketchEdit",
    "SketchHistory",
    "StampSpec",
    "StyleSpec",
    "SynthesisRequest",
    "TerrainResult",
    "builtin_refs",
    "capsule_coverage",
    "example_map_document",
    "fitting_scale",
    "load_project",
    "resize_nearest",
    "save_project",
    "style_layer_from_png",
    "water_layer_from_png",
]
