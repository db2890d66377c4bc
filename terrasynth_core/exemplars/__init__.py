"""Example analysis: nodata handling, PPA features, feature samples and the
mask of strong features, memoised in memory and cached on disk."""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .prepare import ExampleAnalysis, prepare_example

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".prepare": ("ExampleAnalysis", "prepare_example"),
})
