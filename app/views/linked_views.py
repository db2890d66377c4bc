"""Linked zoom and pan between two image views of the same grid.

The sketch canvas and the 2D terrain show the same cells; linked, the same
cell sits at the centre of both at the same scale (cells per screen pixel),
whatever each panel's size, so a stroke and the ridge it made line up.
(pyqtgraph's own ``setXLink`` maps ranges, not scales: two panels of
different widths would show different zooms.)
"""

from __future__ import annotations

import pyqtgraph as pg


class ViewLink:
    """Keeps two ``pg.ViewBox`` es at the same centre and scale while on.

    Parameters
    ----------
    a, b : pg.ViewBox
        Boxes whose image cell ``(row, col)`` covers ``[col, col+1] x [row, row+1]``.
    """

    def __init__(self, a: pg.ViewBox, b: pg.ViewBox) -> None:
        self.boxes = (a, b)
        self.enabled = False
        self._busy = False
        a.sigRangeChanged.connect(lambda *_: self._follow(a, b))
        b.sigRangeChanged.connect(lambda *_: self._follow(b, a))

    def set_enabled(self, on: bool) -> None:
        """Link (the second box follows the first now) or unlink."""
        self.enabled = bool(on)
        if self.enabled:
            self._follow(*self.boxes)

    def _follow(self, leader: pg.ViewBox, follower: pg.ViewBox) -> None:
        if not self.enabled or self._busy:
            return
        width, height = follower.width(), follower.height()
        if width <= 0 or height <= 0 or leader.width() <= 0:
            return
        (x0, x1), (y0, y1) = leader.viewRange()
        # Cells per pixel of the leader; the aspect is locked, so one number.
        scale = (x1 - x0) / leader.width()
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        self._busy = True
        try:
            follower.setRange(xRange=(cx - scale * width / 2, cx + scale * width / 2),
                              yRange=(cy - scale * height / 2, cy + scale * height / 2), padding=0)
        finally:
            self._busy = False


def view_state(box: pg.ViewBox) -> tuple[float, float, float]:
    """Centre ``(x, y)`` and cells per pixel of ``box``, for tests and checks."""
    (x0, x1), (y0, y1) = box.viewRange()
    return (x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / max(box.width(), 1e-9)
