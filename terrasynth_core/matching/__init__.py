"""Matching (paper §4.1 and §4.2): ranking example feature samples against a
sketch sample, the FFT search for non-feature fill windows, and the match
cost both are chosen by."""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .candidates import Candidate, FeaturePool
    from .costs import OFFSET_WEIGHT, match_cost, overlap_ssd, settle
    from .fill_search import FillSearch

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".candidates": ("Candidate", "FeaturePool"),
    ".costs": ("OFFSET_WEIGHT", "match_cost", "overlap_ssd", "settle"),
    ".fill_search": ("FillSearch",),
})
