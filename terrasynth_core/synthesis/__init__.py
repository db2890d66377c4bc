"""Feature-guided patch synthesis (Zhou et al. 2007): the session, its
parameters, events and result."""

from .events import PatchPlaced, StageFinished, StageStarted, SynthesisFinished
from .params import SynthesisParams
from .session import PatchRecord, Session, SynthesisResult

__all__ = [
    "PatchPlaced",
    "PatchRecord",
    "Session",
    "StageFinished",
    "StageStarted",
    "SynthesisFinished",
    "SynthesisParams",
    "SynthesisResult",
]
