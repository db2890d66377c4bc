"""The document: sketch, examples, parameters and the last result.

Views subscribe to its events and translate user actions into its methods;
nothing here knows about Qt, so the whole editing logic is testable with
plain pytest.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from terrasynth_core.errors import ParamsError
from terrasynth_core.examples import DEFAULT_EXAMPLE, DEFAULT_SKETCH, resource_path
from terrasynth_core.features import SketchMap, read_sketch
from terrasynth_core.synthesis import Session, SynthesisParams

from .events import Event
from .examples import ExampleRef
from .result import TerrainResult
from .sketch import Sketch


class Document:
    """Everything a project file holds, with change events.

    Parameters
    ----------
    sketch : Sketch
    examples : list of ExampleRef
    params : SynthesisParams, optional
    result : TerrainResult or None, optional
    path : Path or None, optional
        File the document was read from or last saved to.

    Attributes
    ----------
    changed : Event
        Emitted with what changed: ``"examples"``, ``"params"``,
        ``"result"``, ``"path"`` or ``"dirty"`` (the unsaved-changes flag).
        Sketch edits are announced by ``document.sketch.changed``.
    """

    def __init__(self, sketch: Sketch, examples: list[ExampleRef], *, params: SynthesisParams | None = None,
                 result: TerrainResult | None = None, path: Path | None = None) -> None:
        self.sketch = sketch
        self._examples = list(examples)
        self._params = params if params is not None else SynthesisParams()
        self._result = result
        self._path = Path(path) if path is not None else None
        self.changed = Event()
        # Every change bumps the generation; the document is dirty while it
        # differs from the generation last saved.
        self._generation = 0
        self._saved_generation = 0
        self.sketch.changed.connect(self._sketch_changed)

    @classmethod
    def default(cls) -> "Document":
        """The first-start document: the default built-in example and sketch."""
        sketch = Sketch.from_sketch_map(read_sketch(resource_path("sketches", DEFAULT_SKETCH)))
        return cls(sketch, [ExampleRef(builtin=DEFAULT_EXAMPLE)])

    # -- properties ---------------------------------------------------------------
    @property
    def examples(self) -> list[ExampleRef]:
        return list(self._examples)

    @property
    def params(self) -> SynthesisParams:
        return self._params

    @property
    def result(self) -> TerrainResult | None:
        return self._result

    @property
    def path(self) -> Path | None:
        return self._path

    @property
    def output_shape(self) -> tuple[int, int]:
        """Size of the terrain to synthesize: the sketch's."""
        return self.sketch.shape

    @property
    def generation(self) -> int:
        """Counter bumped by every change (autosave compares it)."""
        return self._generation

    @property
    def dirty(self) -> bool:
        """True when there are changes not saved to :attr:`path`."""
        return self._generation != self._saved_generation

    @property
    def title(self) -> str:
        """File name for the window title, ``"Untitled"`` before the first save."""
        return self._path.name if self._path is not None else "Untitled"

    # -- edits ----------------------------------------------------------------------
    def set_examples(self, examples: list[ExampleRef]) -> None:
        examples = list(examples)
        if examples == self._examples:
            return
        self._examples = examples
        self._touch("examples")

    def add_example(self, example: ExampleRef) -> None:
        """Add ``example`` unless it is already chosen."""
        if example not in self._examples:
            self.set_examples(self._examples + [example])

    def remove_example(self, example: ExampleRef) -> None:
        self.set_examples([e for e in self._examples if e != example])

    def set_params(self, params: SynthesisParams) -> None:
        if not isinstance(params, SynthesisParams):
            raise ParamsError(f"params must be SynthesisParams, got {type(params).__name__}")
        if params == self._params:
            return
        self._params = params
        self._touch("params")

    def set_result(self, result: TerrainResult | None) -> None:
        self._result = result
        self._touch("result")

    def mark_saved(self, path: Path) -> None:
        """Record that the document was written to ``path``."""
        self._path = Path(path)
        self._saved_generation = self._generation
        self.changed.emit("path")
        self.changed.emit("dirty")

    def mark_unsaved(self) -> None:
        """Flag changes that are not in :attr:`path` (e.g. after recovery)."""
        self._touch("dirty")

    def assign(self, other: "Document") -> None:
        """Take over ``other``'s contents (a project was opened).

        The sketch object stays the same, so views stay connected; its history
        is cleared.  The result is clean unless ``other`` was dirty.
        """
        self.sketch.reset(other.sketch.ridge, other.sketch.valley)
        self._examples = other.examples
        self._params = other.params
        self._result = other.result
        self._path = other.path
        self._generation += 1
        self._saved_generation = self._generation if not other.dirty else -1
        for what in ("examples", "params", "result", "path", "dirty"):
            self.changed.emit(what)

    def snapshot(self) -> "Document":
        """A copy whose sketch no later edit can touch (for autosaving on a thread).

        The result's arrays are shared: nothing writes into a result.
        """
        copy = Document(Sketch(self.sketch.ridge, self.sketch.valley), self._examples, params=self._params,
                        result=self._result, path=self._path)
        if self.dirty:
            copy.mark_unsaved()
        return copy

    # -- synthesis --------------------------------------------------------------------
    def synthesis_request(self) -> "SynthesisRequest":
        """A snapshot of what to synthesize, safe to hand to a worker thread.

        Raises
        ------
        ParamsError
            When no example is chosen.
        """
        if not self._examples:
            raise ParamsError("no example DEM chosen: add one from the example library")
        sketch_map = self.sketch.to_sketch_map() if self.sketch.has_strokes else None
        return SynthesisRequest(tuple(self._examples), sketch_map, self.output_shape, self._params)

    # -- internals --------------------------------------------------------------------
    def _touch(self, what: str) -> None:
        was_dirty = self.dirty
        self._generation += 1
        if what != "dirty":
            self.changed.emit(what)
        if not was_dirty or what == "dirty":
            self.changed.emit("dirty")

    def _sketch_changed(self, _bbox) -> None:
        # During a stroke the sketch changes on every mouse move; the document
        # only needs to know it is dirty.
        was_dirty = self.dirty
        self._generation += 1
        if not was_dirty:
            self.changed.emit("dirty")


@dataclass(frozen=True, eq=False)
class SynthesisRequest:
    """Immutable inputs of one run, taken from the document on the GUI thread.

    :meth:`make_session` does the slow part (reading and analysing the
    examples) and is meant to be called on a worker thread.
    """

    examples: tuple[ExampleRef, ...]
    sketch_map: SketchMap | None
    shape: tuple[int, int]
    params: SynthesisParams

    def make_session(self) -> Session:
        """Load the examples and build the validated core session.

        Raises
        ------
        TerraSynthError
            For an unreadable example or inconsistent inputs.
        """
        fields = [ref.load() for ref in self.examples]
        return Session(fields, self.sketch_map, shape=self.shape, params=self.params)

