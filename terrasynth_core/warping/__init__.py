"""Warping (paper §4.1): thin-plate splines (Bookstein 1989) that carry an
example feature patch's control points onto the sketch's, and their bending
energy, which ranks the candidates."""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .frame import framed, framed_bending_energies
    from .thin_plate import ThinPlateSpline, bending_energies, warp_distortion, warp_patch

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".frame": ("framed", "framed_bending_energies"),
    ".thin_plate": ("ThinPlateSpline", "bending_energies", "warp_distortion", "warp_patch"),
})
