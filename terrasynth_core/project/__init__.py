"""Project files and the runs they stand for, without Qt.

A ``.tsproj`` file holds a whole design: the sketch's stroke, style and
water layers, the examples, styles and stamps (DEMs by reference), pins,
parameters, the selection and the last result.  The app edits it
(``terrasynth_app.model`` turns :class:`ProjectData` into its document and
back); ``terrasynth-cli synth --project`` renders it headless through the
same :class:`RunSpec` the app's *Synthesize* builds.

- :mod:`.refs`: :class:`ExampleRef`, a DEM by built-in key or path, loaded once
- :mod:`.specs`: :class:`StyleSpec`, :class:`StampSpec`
- :mod:`.run`: :func:`stroke_map`, :func:`painted_styles`, :class:`RunSpec`, :func:`run_spec`
- :mod:`.file`: :class:`ProjectData`, :func:`read_project`, :func:`write_project`
- :mod:`.resize`: pins and stamps following a resized sketch
- :mod:`.footprints`: stamps too thin to place, refused with the scale that would do
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from ..errors import ProjectError
    from .file import (FORMAT_VERSION, MAX_LAYER_CELLS, MAX_SIDE, PROJECT_EXTENSION, ProjectData,
        ProjectResult, read_project, write_project)
    from .footprints import MIN_STAMP_CELLS, check_stamp_footprints
    from .refs import ExampleRef
    from .resize import resize_pins, resize_stamps
    from .run import STROKE_THRESHOLD, RunSpec, painted_styles, run_spec, stroke_map
    from .specs import RELIEF_SCALE_RANGE, StampSpec, StyleSpec

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    "..errors": ("ProjectError",),
    ".file": (
        "FORMAT_VERSION", "MAX_LAYER_CELLS", "MAX_SIDE", "PROJECT_EXTENSION", "ProjectData",
        "ProjectResult", "read_project", "write_project"
    ),
    ".footprints": ("MIN_STAMP_CELLS", "check_stamp_footprints"),
    ".refs": ("ExampleRef",),
    ".resize": ("resize_pins", "resize_stamps"),
    ".run": ("STROKE_THRESHOLD", "RunSpec", "painted_styles", "run_spec", "stroke_map"),
    ".specs": ("RELIEF_SCALE_RANGE", "StampSpec", "StyleSpec"),
})
