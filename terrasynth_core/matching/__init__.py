"""Matching (paper §4.1 and §4.2): ranking example feature samples against a
sketch sample, and the FFT search for non-feature fill windows."""

from .candidates import Candidate, FeaturePool
from .fill_search import FillSearch

__all__ = ["Candidate", "FeaturePool", "FillSearch"]
