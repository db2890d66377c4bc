"""Keeping a derived feature graph (:mod:`terrasynth_app.model.feature_graphs`)
up to date off the GUI thread, while some view wants it."""

from __future__ import annotations

from PySide6.QtCore import QObject, QTimer, Signal

from ..model import DerivedGraph
from ..workers import run_in_background


class FeatureGraphController(QObject):
    """Computes ``graph`` on the thread pool when asked, and again after
    the source changes while it is wanted.

    Parameters
    ----------
    graph : DerivedGraph
    delay_ms : int, default 0
        Quiet time after the last change of the source before recomputing
        (a sketch changes on every mouse move of a stroke).
    parent : QObject, optional

    Signals
    -------
    ready(object)
        The graph's up-to-date ``FeatureMaps``.
    failed(str)
        One-line message.
    """

    ready = Signal(object)
    failed = Signal(str)

    def __init__(self, graph: DerivedGraph, *, delay_ms: int = 0, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.graph = graph
        self.wanted = False
        #: Generation being computed: a second request for it waits for that one.
        self._computing: int | None = None
        self._timer = QTimer(self, singleShot=True, interval=delay_ms)
        self._timer.timeout.connect(self.request)
        graph.invalidated.connect(self._invalidated)

    def set_wanted(self, wanted: bool) -> None:
        """Keep the graph up to date from now on (or stop); asks for it at once."""
        self.wanted = wanted
        if wanted:
            self.request()

    def request(self) -> None:
        """Emit :attr:`ready` with the graph: at once when it is up to date,
        else once it is computed (nothing when there is no source)."""
        if self.graph.up_to_date:
            self.ready.emit(self.graph.maps)
            return
        if self.graph.busy:
            self._timer.start()  # mid-stroke: wait until it settles
            return
        job = self.graph.job()
        if job is None:
            return
        generation, compute = job
        if generation == self._computing:
            return
        self._computing = generation
        run_in_background(lambda: (generation, compute()), self._computed, self._failed)

    def _invalidated(self) -> None:
        if self.wanted:
            self._timer.start()

    def _computed(self, value) -> None:
        generation, maps = value
        self._computing = None
        if self.graph.deliver(generation, maps):
            self.ready.emit(maps)
        # else the source changed meanwhile; a newer request is queued

    def _failed(self, message: str) -> None:
        self._computing = None
        self.failed.emit(message)
