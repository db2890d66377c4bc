"""The status bar's account of a run: stage, patches done and time left."""

from __future__ import annotations

from PySide6.QtWidgets import QLabel, QProgressBar, QStatusBar

from ..controllers import SynthesisController


class RunStatus:
    """Three permanent status-bar widgets following a :class:`SynthesisController`.

    Parameters
    ----------
    status_bar : QStatusBar
    synthesis : SynthesisController
    """

    def __init__(self, status_bar: QStatusBar, synthesis: SynthesisController) -> None:
        self.stage_label = QLabel("Ready")
        self.progress = QProgressBar(maximumWidth=260, textVisible=True)
        self.progress.setFormat("%v / %m patches")
        self.progress.setValue(0)
        self.time_label = QLabel("")
        for widget in (self.stage_label, self.progress, self.time_label):
            status_bar.addPermanentWidget(widget)
        synthesis.stage_changed.connect(self.stage_label.setText)
        synthesis.progress_changed.connect(self.show_progress)
        synthesis.finished.connect(self.show_finished)
        synthesis.failed.connect(self.reset)
        synthesis.cancelled.connect(self.reset)

    def show_progress(self, done: int, total: int, time_left: str) -> None:
        """``done`` of ``total`` patches (0 of 0: busy, the count is not known yet)."""
        # The controller throttles these: QProgressBar.setValue repaints at
        # once, and with an OpenGL widget in the window every repaint
        # composites the whole window.
        self.progress.setRange(0, total)
        self.progress.setValue(done)
        self.time_label.setText(time_left)

    def show_finished(self, result) -> None:
        """The run that made the core's ``SynthesisResult`` ``result`` is over."""
        self.progress.setValue(self.progress.maximum())
        self.time_label.setText(f"{result.total_seconds:.1f} s")

    def reset(self, *_args) -> None:
        self.progress.setRange(0, 1)
        self.progress.setValue(0)
        self.time_label.clear()
