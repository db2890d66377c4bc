"""Warping (paper §4.1): thin-plate splines (Bookstein 1989) that carry an
example feature patch's control points onto the sketch's, and their bending
energy, which ranks the candidates."""

from .thin_plate import ThinPlateSpline, bending_energies, warp_patch

__all__ = ["ThinPlateSpline", "bending_energies", "warp_patch"]
