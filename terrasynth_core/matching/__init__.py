"""Matching (paper §4.1 and §4.2): ranking example feature samples against a
sketch sample, the FFT search for non-feature fill windows, and the match
cost both are chosen by."""

from .candidates import Candidate, FeaturePool
from .costs import OFFSET_WEIGHT, match_cost, overlap_ssd, settle
from .fill_search import FillSearch

__all__ = ["OFFSET_WEIGHT", "Candidate", "FeaturePool", "FillSearch", "match_cost", "overlap_ssd", "settle"]
