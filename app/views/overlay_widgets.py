"""Widgets that keep the layout still: labels that elide instead of growing,
and overlays that float over a view instead of taking a row of the layout.

An overlay pinned to a corner of its host is moved when the host resizes;
it never changes the size of anything, so showing or hiding it cannot
shift the image under the mouse.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QEvent, QObject, QRect, QSize, Qt, Signal
from PySide6.QtGui import QColor, QFont, QImage, QPainter, QPen
from PySide6.QtWidgets import QFrame, QHBoxLayout, QLabel, QPushButton, QSizePolicy, QVBoxLayout, QWidget

from terrasynth_core.pictures import height_ticks, ramp_strip

#: Corners (and the centre, and the top edge) an overlay can be pinned to.
CORNERS = ("top", "top_left", "bottom_left", "bottom_right", "centre")
#: Gap between an overlay and its host's edge, px.
MARGIN = 8


class ElidedLabel(QFrame):
    """One line of text cut with "…" to the width it is given; the full text
    is its tooltip.  Its size hint never depends on the text, so a long
    message cannot widen a panel.

    Parameters
    ----------
    text : str
    width_hint : int, default 120
        Preferred width in px (the layout may give more or less).
    """

    def __init__(self, text: str = "", parent: QWidget | None = None, *, width_hint: int = 120) -> None:
        super().__init__(parent)
        self._text = ""
        self._width_hint = width_hint
        # Preferred, not Ignored: a box layout gives an Ignored widget no room,
        # even with a fixed width.  The hints (not the text) bound it.
        self.setSizePolicy(QSizePolicy.Preferred, QSizePolicy.Fixed)
        self.setText(text)

    def text(self) -> str:
        return self._text

    def setText(self, text: str) -> None:  # noqa: N802 (QLabel's name, so it can stand in for one)
        self._text = text or ""
        self.setToolTip(self._text)
        self.update()

    def clear(self) -> None:
        self.setText("")

    def shown_text(self) -> str:
        """The text as drawn at the current width."""
        return self.fontMetrics().elidedText(self._text, Qt.ElideRight, max(self.contentsRect().width(), 0))

    def sizeHint(self) -> QSize:
        return QSize(self._width_hint, self.fontMetrics().height() + 2)

    def minimumSizeHint(self) -> QSize:
        return QSize(0, self.fontMetrics().height() + 2)

    def paintEvent(self, event) -> None:
        super().paintEvent(event)
        painter = QPainter(self)
        painter.drawText(self.contentsRect(), Qt.AlignLeft | Qt.AlignVCenter, self.shown_text())


class _Pin(QObject):
    """Keeps ``overlay`` at ``corner`` of ``host`` as the host resizes."""

    def __init__(self, overlay: QWidget, host: QWidget, corner: str) -> None:
        super().__init__(overlay)
        self.overlay, self.host, self.corner = overlay, host, corner
        host.installEventFilter(self)
        overlay.installEventFilter(self)
        self.place()

    def eventFilter(self, watched, event) -> bool:  # noqa: N802
        # A child's new text posts a LayoutRequest to its parent, the host.
        if event.type() in (QEvent.Resize, QEvent.Show, QEvent.LayoutRequest) and (
                watched is self.host or (watched is self.overlay and event.type() == QEvent.Show)):
            self.place()
        return False

    def place(self) -> None:
        w, h = self.host.width(), self.host.height()
        hint = self.overlay.sizeHint()
        size = QSize(min(hint.width(), max(w - 2 * MARGIN, 0)), hint.height())
        if self.corner == "top":
            size.setWidth(max(w - 2 * MARGIN, 0))
            size.setHeight(self.overlay.heightForWidth(size.width()) if self.overlay.hasHeightForWidth()
                           else hint.height())
        x = {"top_left": MARGIN, "top": MARGIN, "bottom_left": MARGIN, "bottom_right": w - size.width() - MARGIN,
             "centre": (w - size.width()) // 2}[self.corner]
        y = {"top_left": MARGIN, "top": MARGIN, "bottom_left": h - size.height() - MARGIN,
             "bottom_right": h - size.height() - MARGIN, "centre": (h - size.height()) // 2}[self.corner]
        self.overlay.setGeometry(QRect(x, y, size.width(), size.height()))
        self.overlay.raise_()


def pin_overlay(overlay: QWidget, host: QWidget, corner: str) -> QWidget:
    """Float ``overlay`` over ``host`` at ``corner`` (one of :data:`CORNERS`);
    returns ``overlay``.  The overlay becomes a child of ``host`` and takes
    no place in any layout."""
    if corner not in CORNERS:
        raise ValueError(f"corner must be one of {CORNERS}, got {corner!r}")
    overlay.setParent(host)
    overlay.setAttribute(Qt.WA_StyledBackground, True)
    _Pin(overlay, host, corner)
    return overlay


def note_label(text: str = "") -> QLabel:
    """A word-wrapped note on a dark translucent box, for overlays."""
    label = QLabel(text, wordWrap=True)
    label.setStyleSheet("QLabel { background: rgba(20, 20, 20, 190); color: #eeeeee; padding: 4px; "
                        "border-radius: 3px; }")
    return label


class WarningBanner(QFrame):
    """A warning across the top of a view with buttons that fix it.

    Signals
    -------
    fix_clicked(int)
        The index of the fix chosen.
    """

    fix_clicked = Signal(int)

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("warning_banner")
        self.setStyleSheet("#warning_banner { background: rgba(170, 40, 20, 225); border-radius: 3px; } "
                           "QLabel { color: white; font-weight: bold; }")
        self.label = QLabel(wordWrap=True)
        self.fix_buttons: list[QPushButton] = []
        self._buttons = QVBoxLayout()
        layout = QHBoxLayout(self)
        layout.setContentsMargins(8, 4, 8, 4)
        layout.addWidget(self.label, 1)
        layout.addLayout(self._buttons)
        self.setVisible(False)

    def show_warning(self, text: str | None, fixes: tuple[str, ...] = ()) -> None:
        """Show ``text`` with a button per fix; None hides the banner."""
        if text is None:
            self.setVisible(False)
            return
        self.label.setText(text)
        while len(self.fix_buttons) < len(fixes):
            button = QPushButton()
            index = len(self.fix_buttons)
            button.clicked.connect(lambda _checked=False, i=index: self.fix_clicked.emit(i))
            self._buttons.addWidget(button)
            self.fix_buttons.append(button)
        for i, button in enumerate(self.fix_buttons):
            button.setVisible(i < len(fixes))
            if i < len(fixes):
                button.setText(fixes[i])
        self.setVisible(True)


class HeightLegend(QWidget):
    """The height colour ramp with heights in metres, and the water level.

    Draws :func:`~terrasynth_core.pictures.ramp_strip` (the same ramp as the
    2D and 3D views) with round heights from
    :func:`~terrasynth_core.pictures.height_ticks`.
    """

    #: Width and height of the ramp, px.
    RAMP_SIZE = (14, 150)

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.vrange: tuple[float, float] | None = None
        self.water_level: float | None = None
        strip = ramp_strip(self.RAMP_SIZE[1], width=self.RAMP_SIZE[0])
        self._strip = QImage(np.ascontiguousarray(strip).data, strip.shape[1], strip.shape[0], 3 * strip.shape[1],
                             QImage.Format_RGB888).copy()
        font = QFont(self.font())
        font.setPointSizeF(max(font.pointSizeF() - 1, 7))
        self.setFont(font)
        self.setVisible(False)

    def set_range(self, vrange: tuple[float, float] | None, water_level: float | None = None) -> None:
        """Heights at the ramp's ends (None hides the legend) and the water level to mark."""
        self.vrange = vrange
        self.water_level = water_level
        self.setVisible(vrange is not None)
        self.update()

    def ticks(self) -> list[float]:
        return [] if self.vrange is None else height_ticks(*self.vrange)

    def sizeHint(self) -> QSize:
        fm = self.fontMetrics()
        return QSize(self.RAMP_SIZE[0] + 16 + fm.horizontalAdvance("-10000 m"), self.RAMP_SIZE[1] + fm.height() + 16)

    def _y(self, height: float, top: int) -> float:
        low, high = self.vrange
        return top + (high - height) / (high - low) * (self.RAMP_SIZE[1] - 1)

    def paintEvent(self, event) -> None:
        if self.vrange is None:
            return
        painter = QPainter(self)
        painter.fillRect(self.rect(), QColor(20, 20, 20, 190))
        fm = self.fontMetrics()
        left, top = 6, 6 + fm.height() // 2
        painter.drawImage(left, top, self._strip)
        painter.setPen(QColor(235, 235, 235))
        text_x = left + self.RAMP_SIZE[0] + 6
        for tick in self.ticks():
            y = self._y(tick, top)
            painter.drawLine(left + self.RAMP_SIZE[0], round(y), left + self.RAMP_SIZE[0] + 3, round(y))
            painter.drawText(text_x, round(y + fm.ascent() / 2 - 1), f"{tick:g} m")
        if self.water_level is not None and self.vrange[0] <= self.water_level <= self.vrange[1]:
            y = round(self._y(self.water_level, top))
            painter.setPen(QPen(QColor(60, 150, 255), 3))
            painter.drawLine(left - 3, y, left + self.RAMP_SIZE[0] + 3, y)
        painter.end()
