"""Blending (paper §5): local Poisson seam removal (Pérez et al. 2003) and
its first-derivative-continuous variant."""

from .poisson import remove_seam

__all__ = ["remove_seam"]
