"""Linked zoom and pan between two image views of the same grid.

The sketch canvas and the 2D terrain show the same cells; linked, the same
cell sits at the centre of both at the same scale (cells per screen pixel),
whatever each panel's size, so a stroke and the ridge it made line up.
(pyqtgraph's own ``setXLink`` maps ranges, not scales: two panels of
different widths would show different zooms.)

The view the user zoomed or panned last leads.  Any other change of the
leader (a fit, a new terrain's first view, a resize) carries over to the
follower; a change of the follower that the user did not make (its panel
resized or shown again) snaps it back to the leader.  A hidden leader
(the 2D tab behind the 3D one) leads nothing until shown.
"""

from __future__ import annotations

import pyqtgraph as pg
from PySide6.QtCore import QEvent, QObject

#: Mouse events on a view's viewport that make it the leader.
_USER_EVENTS = (QEvent.Wheel, QEvent.MouseButtonPress)


class ViewLink(QObject):
    """Keeps two ``pg.ViewBox`` es at the same centre and scale while on.

    Parameters
    ----------
    a, b : pg.ViewBox
        Boxes whose image cell ``(row, col)`` covers ``[col, col+1] x [row, row+1]``;
        ``a`` leads first.
    """

    def __init__(self, a: pg.ViewBox, b: pg.ViewBox) -> None:
        super().__init__(a.getViewWidget())
        self.boxes = (a, b)
        self.leader = a
        self.enabled = False
        self._busy = False
        self._viewports = {}
        for box in self.boxes:
            # The box reports a user's zoom (sigRangeChangedManually) only
            # after its range changed; the press or wheel comes first, so
            # the leader is known when the change arrives.
            viewport = box.getViewWidget().viewport()
            viewport.installEventFilter(self)
            self._viewports[viewport] = box
            box.sigRangeChangedManually.connect(lambda *_, box=box: self._moved_by_user(box))
            box.sigRangeChanged.connect(lambda *_, box=box: self._changed(box))

    def eventFilter(self, watched, event) -> bool:  # noqa: N802
        if event.type() in _USER_EVENTS and watched in self._viewports:
            self.leader = self._viewports[watched]
        return False

    def set_enabled(self, on: bool) -> None:
        """Link (the follower takes the leader's view now) or unlink."""
        self.enabled = bool(on)
        if self.enabled:
            self._follow(self.leader)

    def follower(self) -> pg.ViewBox:
        return self.boxes[1] if self.leader is self.boxes[0] else self.boxes[0]

    def _moved_by_user(self, box: pg.ViewBox) -> None:
        self.leader = box
        if self.enabled and not self._busy:
            self._follow(box)

    def _changed(self, box: pg.ViewBox) -> None:
        if not self.enabled or self._busy:
            return
        if box is self.leader:
            self._follow(box)
        else:
            self._follow(self.leader)  # the follower moved on its own: back in line

    def _follow(self, leader: pg.ViewBox) -> None:
        follower = self.boxes[1] if leader is self.boxes[0] else self.boxes[0]
        widget = leader.getViewWidget()
        if widget is None or not widget.isVisible():
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
