"""Controllers: Qt objects that run the model's work and tell the views.

:class:`SynthesisController` and :class:`VariationsController` run the
model's event generators on a latest-request-wins worker;
:class:`FilesController` reads and writes projects, sketches, imports and
exports; :class:`AutosaveController` autosaves and recovers;
:class:`FeatureGraphController` keeps a derived feature graph up to date;
:class:`LiveController` re-makes the terrain near each finished stroke;
:class:`LargeRenderController` renders the document at a world size, tiled.
Views import only the names listed here.
"""

from .autosave import AUTOSAVE_MS, AutosaveController
from .feature_graphs import FeatureGraphController
from .files import FilesController
from .large_render import LargeRenderController
from .live import LIVE_DELAY_MS, LiveController
from .synthesis import SynthesisController, VariationsController, new_seeds

__all__ = [
    "AUTOSAVE_MS",
    "AutosaveController",
    "FeatureGraphController",
    "FilesController",
    "LargeRenderController",
    "LIVE_DELAY_MS",
    "LiveController",
    "SynthesisController",
    "VariationsController",
    "new_seeds",
]
