"""Progress events yielded by :meth:`Session.iter_run`.

Small frozen records: a GUI turns each into a signal, the CLI into a progress
bar tick.  Every event is also a cancellation checkpoint.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator, Literal

import numpy as np

from ..errors import SynthesisCancelled

#: Stages of a run, in order.
STAGES = ("landform", "analyse", "features", "fill", "finish")

PatchKind = Literal["stamp", "branch", "end", "path", "fill"]


@dataclass(frozen=True)
class StageStarted:
    """A stage begins; ``total`` is how many patches it will place (0 if none)."""

    stage: str
    total: int


@dataclass(frozen=True, eq=False)
class PatchPlaced:
    """One patch is in the output.

    Parameters
    ----------
    index : int
        Patch number, from 0, over the whole run.
    total : int
        Patches the run will place in all (fill counts are an estimate until
        the fill stage starts).
    kind : {"stamp", "branch", "end", "path", "fill"}
    bbox : (r0, r1, c0, c1)
        Half-open output window the patch changed (after Poisson blending).
    heights : ndarray of float32, shape (r1 - r0, c1 - c0)
        The output heights in ``bbox`` after placing the patch, a copy: a
        viewer can paste it into its own buffer without sharing memory with
        the worker.
    cost : float
        The chosen candidate's total cost.
    """

    index: int
    total: int
    kind: PatchKind
    bbox: tuple[int, int, int, int]
    heights: np.ndarray
    cost: float


@dataclass(frozen=True)
class LandformProgress:
    """A patch of the coarse landform pass was placed: ``done`` of about
    ``total``.  Lets a consumer show that the run moves, and cancel it,
    during the pass, and paint a preview of the landforms as they grow.

    Parameters
    ----------
    done, total : int
    bbox : (r0, r1, c0, c1)
        The coarse patch's window, in output cells.
    heights : ndarray of float32, shape (r1 - r0, c1 - c0)
        The coarse terrain there, stretched onto the output's cells
        (metres; a preview: the full-resolution pass replaces it).
    """

    done: int
    total: int
    bbox: tuple[int, int, int, int]
    heights: np.ndarray


@dataclass(frozen=True)
class StageFinished:
    """A stage ends.

    Parameters
    ----------
    stage : str
        One of :data:`STAGES`.
    seconds : float
        Wall time the stage took.
    """

    stage: str
    seconds: float


@dataclass(frozen=True, eq=False)
class SynthesisFinished:
    """The last event; ``result`` is a :class:`SynthesisResult`."""

    result: object


def drive(events: Iterator[object], *, progress: Callable[[object], None] | None = None,
          cancel: Callable[[], bool] | None = None, what: str = "synthesis"):
    """Run a generator of events to its end and return the result of its
    :class:`SynthesisFinished`.

    Parameters
    ----------
    events : iterator
        A run's events (``Session.iter_run()`` and the like).
    progress : callable, optional
        Called with every event.
    cancel : callable, optional
        Polled after every event; when it returns True the run stops and
        :class:`~..errors.SynthesisCancelled` ("``what`` cancelled") is raised.
    """
    result = None
    for event in events:
        if progress is not None:
            progress(event)
        if cancel is not None and cancel():
            events.close()
            raise SynthesisCancelled(f"{what} cancelled")
        if isinstance(event, SynthesisFinished):
            result = event.result
    return result
