"""Warping (paper §4.1): thin-plate splines (Bookstein 1989) that carry an
example feature patch's control points onto the sketch's."""

from .thin_plate import ThinPlateSpline, warp_patch

__all__ = ["ThinPlateSpline", "warp_patch"]
