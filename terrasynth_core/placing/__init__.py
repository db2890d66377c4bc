"""Placing (paper §4.2 and §5): where patches go and in what order, the
output canvas, and the graph-cut seam along which a new patch meets the
terrain already there (Kwatra et al. 2003)."""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .canvas import Canvas, Cut
    from .graph_cut import SeamResult, graph_cut_seam, seam_pixels
    from .windows import WindowQueue, estimate_fill_count, fill_windows, patch_window, region_seeds

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".canvas": ("Canvas", "Cut"),
    ".graph_cut": ("SeamResult", "graph_cut_seam", "seam_pixels"),
    ".windows": ("WindowQueue", "estimate_fill_count", "fill_windows", "patch_window", "region_seeds"),
})
