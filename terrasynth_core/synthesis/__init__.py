"""Feature-guided patch synthesis (Zhou et al. 2007): the session, its
parameters, artist controls, events and result."""

from ..controls.pins import Pin, PinError
from ..controls.water import Water
from ..controls.options import Controls, Stamp, Style
from .events import LandformProgress, PatchPlaced, StageFinished, StageStarted, SynthesisFinished
from .params import SynthesisParams
from .result import PatchRecord, SynthesisResult
from .session import Session
from .local import changed_cells, iter_resynthesize_region, resynthesize_region, stroke_selection
from .variations import run_variations

__all__ = [
    "Controls",
    "Pin",
    "PinError",
    "Stamp",
    "Style",
    "Water",
    "LandformProgress",
    "PatchPlaced",
    "PatchRecord",
    "Session",
    "StageFinished",
    "StageStarted",
    "SynthesisFinished",
    "SynthesisParams",
    "SynthesisResult",
    "changed_cells",
    "iter_resynthesize_region",
    "resynthesize_region",
    "run_variations",
    "stroke_selection",
]
