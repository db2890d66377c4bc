"""Drawing a feature graph (ridges, valleys, node types) over an image."""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg

from terrasynth_core.features import FeatureGraph, FeatureMaps

_PATH_PENS = {"ridge": pg.mkPen((200, 0, 0), width=2), "valley": pg.mkPen((0, 70, 220), width=2)}
#: Node symbols by type: branch points as squares, endpoints as circles.
_NODE_STYLE = {
    "branch": dict(symbol="s", size=10, brush=pg.mkBrush(255, 210, 0), pen=pg.mkPen("k")),
    "end": dict(symbol="o", size=8, brush=pg.mkBrush(40, 200, 90), pen=pg.mkPen("k")),
}


class FeatureGraphOverlay:
    """Curves for the paths and markers for the nodes of ridge and valley graphs.

    Parameters
    ----------
    view_box : pg.ViewBox
        Box whose image has cell ``(row, col)`` covering ``[col, col+1] x [row, row+1]``.
    """

    def __init__(self, view_box: pg.ViewBox) -> None:
        self._curves = {kind: pg.PlotCurveItem(pen=pen, connect="finite") for kind, pen in _PATH_PENS.items()}
        self._nodes = pg.ScatterPlotItem(pxMode=True)
        for item in (*self._curves.values(), self._nodes):
            item.setZValue(20)
            view_box.addItem(item)
        self._maps: FeatureMaps | None = None
        self.set_visible(False)

    @property
    def maps(self) -> FeatureMaps | None:
        return self._maps

    def set_maps(self, maps: FeatureMaps | None) -> None:
        """Show ``maps`` (None clears the overlay)."""
        self._maps = maps
        spots = []
        for kind, graph in (("ridge", maps.ridges if maps else None), ("valley", maps.valleys if maps else None)):
            x, y = _polylines(graph)
            self._curves[kind].setData(x, y)
            if graph is not None:
                for node in graph.nodes:
                    spots.append(dict(pos=(node.col + 0.5, node.row + 0.5), **_NODE_STYLE.get(node.type, _NODE_STYLE["end"])))
        self._nodes.setData(spots)

    def set_visible(self, visible: bool) -> None:
        for item in (*self._curves.values(), self._nodes):
            item.setVisible(visible)

    def node_count(self) -> dict[str, int]:
        """Markers shown, by node type (for tests and the status bar)."""
        out = {"branch": 0, "end": 0}
        if self._maps is not None:
            for graph in (self._maps.ridges, self._maps.valleys):
                for t in out:
                    out[t] += graph.count(t)
        return out


def _polylines(graph: FeatureGraph | None) -> tuple[np.ndarray, np.ndarray]:
    """All paths as one (x, y) pair of arrays, NaN-separated (pyqtgraph's ``connect='finite'``)."""
    if graph is None or not graph.paths:
        return np.zeros(0), np.zeros(0)
    parts = []
    gap = np.full((1, 2), np.nan)
    for path in graph.paths:
        parts.append(np.asarray(path.points, dtype=float))
        parts.append(gap)
    pts = np.concatenate(parts)
    return pts[:, 1] + 0.5, pts[:, 0] + 0.5


def legend_text() -> str:
    """Rich-text legend of the overlay's symbols."""
    return ("<span style='color:#c80000'>&#9473;</span> ridge &nbsp; "
            "<span style='color:#0046dc'>&#9473;</span> valley &nbsp; "
            "<span style='color:#d2a800'>&#9632;</span> branch &nbsp; "
            "<span style='color:#28c85a'>&#9679;</span> end")


__all__ = ["FeatureGraphOverlay", "legend_text"]
