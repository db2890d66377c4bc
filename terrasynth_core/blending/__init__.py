"""Blending (paper §5): local Poisson seam removal (Pérez et al. 2003) and
its first-derivative-continuous variant."""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .poisson import remove_seam

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".poisson": ("remove_seam",),
})
