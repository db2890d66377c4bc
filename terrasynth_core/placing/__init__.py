"""Placing (paper §4.2 and §5): where patches go and in what order, the
output canvas, and the graph-cut seam along which a new patch meets the
terrain already there (Kwatra et al. 2003)."""

from .canvas import Canvas, Cut
from .graph_cut import SeamResult, graph_cut_seam, seam_pixels
from .windows import WindowQueue, estimate_fill_count, fill_windows, patch_window, region_seeds

__all__ = [
    "Canvas",
    "Cut",
    "SeamResult",
    "WindowQueue",
    "estimate_fill_count",
    "fill_windows",
    "graph_cut_seam",
    "patch_window",
    "region_seeds",
    "seam_pixels",
]
