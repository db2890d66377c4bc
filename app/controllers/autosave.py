"""Autosave of unsaved work, recovery after a crash, and a clean end on
SIGTERM or SIGINT."""

from __future__ import annotations

import os
import signal
import socket
import sys

from PySide6.QtCore import QObject, QSocketNotifier, QTimer, Signal

from terrasynth_core.errors import TerraSynthError
from terrasynth_core.io import remove_unfinished

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

    # -- SIGTERM and SIGINT ------------------------------------------------------------------
    def handle_termination(self, signals=(signal.SIGTERM, signal.SIGINT)) -> None:
        """End the process cleanly on ``signals`` (call once, from the GUI thread).

        Without this, SIGTERM ends Python at once and Ctrl-C waits for the next
        Python code: a save, autosave or export running on a pool thread
        leaves its hidden ``.NAME.HEX.tmp`` beside the target.  Here the signal
        wakes the event loop (a socket the C-level handler writes to, so an
        idle window reacts at once), and :meth:`terminate` runs.
        """
        reader, writer = socket.socketpair()
        reader.setblocking(False)
        writer.setblocking(False)
        self._wakeup = (reader, writer)
        signal.set_wakeup_fd(writer.fileno())
        self._notifier = QSocketNotifier(reader.fileno(), QSocketNotifier.Read, self)
        # Reading drains the byte; the Python-level handler below has run by then.
        self._notifier.activated.connect(lambda *_: reader.recv(64))
        for signum in signals:
            signal.signal(signum, lambda signum, _frame: self.terminate(signum))

    def terminate(self, signum: int) -> None:
        """Remove every unfinished temporary file, keep unsaved work in the
        recovery file, and end the process with status 128 + ``signum``.

        Writes still running on other threads never reach their rename (the
        process ends first), so the user's files stay as they were.
        """
        remove_unfinished()
        kept = ""
        if self.recovery is not None and self.document.dirty:
            try:
                self.recovery.save(self.document.snapshot())
                kept = "; unsaved work kept for recovery"
            except (TerraSynthError, OSError) as exc:
                kept = f"; unsaved work could not be kept: {exc}"
            remove_unfinished()
        print(f"terrasynth: stopped by {signal.Signals(signum).name}{kept}", file=sys.stderr, flush=True)
        os._exit(128 + signum)
