"""Example analysis: nodata handling, PPA features, feature samples and the
mask of strong features, memoised in memory and cached on disk."""

from .prepare import ExampleAnalysis, prepare_example

__all__ = ["ExampleAnalysis", "prepare_example"]
