"""Feature graphs derived from the document: the sketch's and the terrain's.

Computing a graph takes a while (thinning, a graph walk), so the model only
keeps the latest one and knows when it is out of date.  A controller asks
for a :meth:`DerivedGraph.job` (a snapshot taken on the GUI thread and a
function to run elsewhere) and hands the answer back to
:meth:`DerivedGraph.deliver`, which drops answers to questions that are no
longer current.
"""

from __future__ import annotations

from typing import Callable

from terrasynth_core.features import FeatureMaps, extract_features, sketch_features

from .document import Document
from .observable import Observable
from .sketch_layers import Sketch


class DerivedGraph:
    """The latest ridge and valley graph of something that changes.

    Attributes
    ----------
    invalidated : Observable
        Emitted with no argument when the source changed, so :attr:`maps`
        (still the last graph made) is out of date.
    """

    def __init__(self) -> None:
        self.invalidated = Observable()
        self._maps: FeatureMaps | None = None
        self._generation = 0  # bumped by every change of the source
        self._maps_generation = -1

    @property
    def maps(self) -> FeatureMaps | None:
        """The last graph made (maybe out of date), or None."""
        return self._maps

    @property
    def up_to_date(self) -> bool:
        return self._maps is not None and self._maps_generation == self._generation

    @property
    def busy(self) -> bool:
        """True while the source is being edited and a graph would be stale at once."""
        return False

    def invalidate(self) -> None:
        self._generation += 1
        self.invalidated.emit()

    def job(self) -> tuple[int, Callable[[], FeatureMaps]] | None:
        """``(generation, compute)`` for the current source, None when there is none.

        The source is copied here, so ``compute`` may run on any thread.
        """
        compute = self._snapshot()
        return None if compute is None else (self._generation, compute)

    def deliver(self, generation: int, maps: FeatureMaps) -> bool:
        """Keep ``maps`` if they answer the current source; True if kept."""
        if generation != self._generation:
            return False
        self._maps, self._maps_generation = maps, generation
        return True

    def _snapshot(self) -> Callable[[], FeatureMaps] | None:
        raise NotImplementedError


class SketchGraph(DerivedGraph):
    """The graph the synthesis will follow: the sketch's strokes, thinned."""

    def __init__(self, sketch: Sketch) -> None:
        super().__init__()
        self.sketch = sketch
        sketch.changed.connect(lambda _bbox: self.invalidate())

    @property
    def busy(self) -> bool:
        return self.sketch.stroking

    def _snapshot(self) -> Callable[[], FeatureMaps]:
        sketch_map = self.sketch.to_sketch_map()
        return lambda: sketch_features(sketch_map)


class TerrainGraph(DerivedGraph):
    """Ridges and valleys extracted from the document's terrain."""

    def __init__(self, document: Document) -> None:
        super().__init__()
        self.document = document
        document.changed.connect(self._document_changed)

    def _document_changed(self, what: str) -> None:
        if what == "result":
            self.invalidate()

    def _snapshot(self) -> Callable[[], FeatureMaps] | None:
        result = self.document.result
        if result is None:
            return None
        heights = result.heights  # never written: a new run makes a new result
        return lambda: extract_features(heights)
