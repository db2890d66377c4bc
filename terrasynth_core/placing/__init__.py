"""Placing (paper §5): the output canvas and the graph-cut seam along which
a new patch meets the terrain already there (Kwatra et al. 2003)."""

from .canvas import Canvas, Cut
from .graph_cut import SeamResult, graph_cut_seam, seam_pixels

__all__ = ["Canvas", "Cut", "SeamResult", "graph_cut_seam", "seam_pixels"]
