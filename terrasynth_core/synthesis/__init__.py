"""Feature-guided patch synthesis (Zhou et al. 2007): the session, its
parameters, artist controls, events and result."""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from ..controls.pins import Pin, PinError
    from ..controls.water import Water
    from ..controls.options import Controls, Stamp, Style
    from .events import LandformProgress, PatchPlaced, StageFinished, StageStarted, SynthesisFinished
    from .params import SynthesisParams
    from .result import PatchRecord, SynthesisResult
    from .session import Session
    from .local import (changed_cells, iter_resynthesize_region, prepare_resynthesis, resynthesize_region,
                        stroke_selection)
    from .variations import run_variations
    from .workers import import_engine

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    "..controls.pins": ("Pin", "PinError"),
    "..controls.water": ("Water",),
    "..controls.options": ("Controls", "Stamp", "Style"),
    ".events": ("LandformProgress", "PatchPlaced", "StageFinished", "StageStarted", "SynthesisFinished"),
    ".params": ("SynthesisParams",),
    ".result": ("PatchRecord", "SynthesisResult"),
    ".session": ("Session",),
    ".local": ("changed_cells", "iter_resynthesize_region", "prepare_resynthesis", "resynthesize_region",
               "stroke_selection"),
    ".variations": ("run_variations",),
    ".workers": ("import_engine",),
})
