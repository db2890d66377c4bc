"""Autosave of unsaved work and recovery after a crash."""

from __future__ import annotations

from PySide6.QtCore import QObject, QTimer, Signal

from terrasynth_core.errors import TerraSynthError

from ..model import Document, RecoveryStore
from ..workers import run_in_background

#: Autosave period while there are unsaved changes, in ms.
AUTOSAVE_MS = 30_000


class AutosaveController(QObject):
    """Writes the document to a :class:`RecoveryStore` now and then, on the thread pool.

    Parameters
    ----------
    document : Document
    recovery : RecoveryStore or None
        None disables autosave and recovery.
    interval_ms : int
        Autosave period.
    parent : QObject, optional

    Signals
    -------
    status(str, int)
        A message for the status bar and how many ms to show it.
    error(str, str)
        A title and a message for an error dialog.
    """

    status = Signal(str, int)
    error = Signal(str, str)

    def __init__(self, document: Document, recovery: RecoveryStore | None, *, interval_ms: int = AUTOSAVE_MS,
                 parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.document = document
        self.recovery = recovery
        self._saved_generation = -1
        self._timer = QTimer(self, interval=interval_ms)
        self._timer.timeout.connect(self.autosave)
        if recovery is not None:
            self._timer.start()

    def autosave(self) -> None:
        """Write unsaved work to the recovery file, unless it is there already."""
        if self.recovery is None or not self.document.dirty:
            return
        if self.document.generation == self._saved_generation:
            return
        self._saved_generation = self.document.generation
        snapshot = self.document.snapshot()
        recovery = self.recovery
        run_in_background(lambda: recovery.save(snapshot), self._autosaved, self._autosave_failed)

    def _autosaved(self, _value) -> None:
        self.status.emit("Autosaved", 2000)

    def _autosave_failed(self, message: str) -> None:
        self.status.emit(f"Autosave failed: {message}", 10_000)

    def recoverable(self) -> str | None:
        """What a previous session left unsaved, in words; None when nothing."""
        if self.recovery is None or not self.recovery.exists():
            return None
        return self.recovery.describe()

    def recover(self) -> bool:
        """Make the recovered work the document; False (and :attr:`error`) when it cannot be read."""
        try:
            self.document.assign(self.recovery.load())
        except TerraSynthError as exc:
            self.error.emit("Cannot recover", str(exc))
            return False
        return True

    def discard(self) -> None:
        """Forget the recovered work (declined, or the session ended cleanly)."""
        if self.recovery is not None:
            self.recovery.discard()

    def stop(self) -> None:
        self._timer.stop()
