"""The status bar's account of a run and of the cell under the mouse.

Every widget here is permanent and of fixed width, and its text elides, so
long texts never move the others; every change of the terrain (a run
finished, failed or cancelled, a variation chosen, a project opened)
clears what the last run's counts said.
"""

from __future__ import annotations

from PySide6.QtCore import QRect, Qt
from PySide6.QtGui import QPainter
from PySide6.QtWidgets import QProgressBar, QStatusBar

from ..controllers import SynthesisController
from .overlay_widgets import ElidedLabel

#: Widths of the readout, stage and time labels, px.
READOUT_WIDTH, STAGE_WIDTH, TIME_WIDTH = 380, 170, 110
#: The progress bar's text while patches are counted.
PATCHES_FORMAT = "%v / %m patches"


class ElidingStatusBar(QStatusBar):
    """A status bar whose messages end in "…" where the permanent widgets
    begin, instead of being cut mid-word under them; the whole message is
    the bar's tooltip."""

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.messageChanged.connect(self.setToolTip)

    def message_rect(self) -> QRect:
        """Where the message is drawn: from the left edge to the first
        visible permanent widget."""
        right = min((w.geometry().left() for w in self.findChildren(ElidedLabel) + self.findChildren(QProgressBar)
                     if w.isVisible() and w.parent() is self), default=self.width())
        return QRect(6, 0, max(right - 12, 0), self.height())

    def shown_message(self) -> str:
        """The message as drawn."""
        return self.fontMetrics().elidedText(self.currentMessage(), Qt.ElideRight, self.message_rect().width())

    def paintEvent(self, event) -> None:
        if not self.currentMessage():
            super().paintEvent(event)
            return
        painter = QPainter(self)
        painter.setPen(self.palette().windowText().color())
        painter.drawText(self.message_rect(), Qt.AlignLeft | Qt.AlignVCenter, self.shown_message())
        painter.end()


class RunStatus:
    """Permanent status-bar widgets following a :class:`SynthesisController`
    and the document.

    Parameters
    ----------
    status_bar : QStatusBar
    synthesis : SynthesisController
    document : Document, optional
        Its ``"result"`` events clear the progress (a new terrain that no
        run of this controller is finishing).
    """

    def __init__(self, status_bar: QStatusBar, synthesis: SynthesisController, document=None) -> None:
        self.readout = ElidedLabel(width_hint=READOUT_WIDTH)
        self.readout.setToolTip("Row, column, height, slope and style under the mouse in the 2D terrain")
        self.stage_label = ElidedLabel("Ready", width_hint=STAGE_WIDTH)
        self.progress = QProgressBar(maximumWidth=260, textVisible=True)
        self.progress.setFormat("")  # (idle: no count; Qt's default range would read "0 / 100 patches")
        self.progress.setRange(0, 1)
        self.progress.setValue(0)
        self.time_label = ElidedLabel(width_hint=TIME_WIDTH)
        for widget, width in ((self.readout, READOUT_WIDTH), (self.stage_label, STAGE_WIDTH),
                              (self.progress, 260), (self.time_label, TIME_WIDTH)):
            widget.setFixedWidth(width)
            status_bar.addPermanentWidget(widget)
        synthesis.stage_changed.connect(self.stage_label.setText)
        synthesis.progress_changed.connect(self.show_progress)
        synthesis.finished.connect(self.show_finished)
        synthesis.failed.connect(self.reset)
        synthesis.cancelled.connect(self.reset)
        if document is not None:
            # A run's finish sets the document's result first, then reports
            # (show_finished), so this clears only what no run replaces.
            document.changed.connect(lambda what: self.reset(stage="Ready") if what == "result" else None)

    def show_progress(self, done: int, total: int, time_left: str) -> None:
        """``done`` of ``total`` patches (0 of 0: busy, the count is not known yet)."""
        # The controller throttles these: QProgressBar.setValue repaints at
        # once, and with an OpenGL widget in the window every repaint
        # composites the whole window.
        self.progress.setFormat(PATCHES_FORMAT)
        self.progress.setRange(0, total)
        self.progress.setValue(done)
        self.time_label.setText(time_left)

    def show_finished(self, result) -> None:
        """The run that made the core's ``SynthesisResult`` ``result`` is over:
        all its patches done (not the 1 of 1 the document's new result left)."""
        placed = len(result.patches)
        self.progress.setFormat(PATCHES_FORMAT if placed else "done")
        self.progress.setRange(0, max(placed, 1))
        self.progress.setValue(max(placed, 1))
        self.time_label.setText(f"{result.total_seconds:.1f} s")

    def show_readout(self, text: str | None) -> None:
        self.readout.setText(text or "")

    def reset(self, *_args, stage: str | None = None) -> None:
        """Empty progress and time; ``stage`` replaces the stage text when given."""
        self.progress.setFormat("")
        self.progress.setRange(0, 1)
        self.progress.setValue(0)
        self.time_label.clear()
        if stage is not None:
            self.stage_label.setText(stage)
