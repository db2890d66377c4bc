"""Controllers: Qt objects that run the model's work and tell the views.

:class:`SynthesisController` and :class:`VariationsController` run the
model's event generators on a latest-request-wins worker;
:class:`FilesController` reads and writes projects, sketches, imports and
exports; :class:`AutosaveController` autosaves and recovers;
:class:`FeatureGraphController` keeps a derived feature graph up to date.
Views import only the names listed here.
"""

from .autosave import AUTOSAVE_MS, AutosaveController
from .feature_graphs import FeatureGraphController
from .files import FilesController
from .synthesis import SynthesisController, VariationsController, new_seeds

__all__ = [
    "AUTOSAVE_MS",
    "AutosaveController",
    "FeatureGraphController",
    "FilesController",
    "SynthesisController",
    "VariationsController",
    "new_seeds",
]
