"""A run request and the events of running it: what the controllers hand a worker.

:class:`SynthesisRequest` is an immutable snapshot of the document taken on
the GUI thread; :func:`synthesis_events` and :func:`variation_events` are
generators that do the slow work (reading examples, synthesizing) when a
worker drains them, yielding the core's progress events and the app's own
(:class:`RunStarted`, :class:`VariationMade`).  Nothing here knows about Qt.
"""

from __future__ import annotations

import queue
import threading
from dataclasses import dataclass
from typing import Callable, Iterator, Sequence

import numpy as np

from terrasynth_core.pictures import height_range
from terrasynth_core.project import RunSpec
from terrasynth_core.synthesis import run_variations

from .result import TerrainResult

#: Largest seed the app hands out or shows (its seed box holds a 32-bit int).
MAX_SEED = 2**31 - 1


@dataclass(frozen=True, eq=False)
class SynthesisRequest(RunSpec):
    """Immutable inputs of one run, taken from the document on the GUI thread.

    The core's :class:`~terrasynth_core.project.RunSpec` (fields, and
    :meth:`make_session`, the slow part, meant for a worker thread), plus
    variations that come back as the app's :class:`TerrainResult` s.
    """

    def make_variations(self, seeds: Sequence[int], *, progress: Callable | None = None,
                        cancel: Callable[[], bool] | None = None, workers: int | None = None) -> list[TerrainResult]:
        """One terrain per seed, made in parallel processes.

        Parameters
        ----------
        seeds : sequence of int
            Distinct, non-negative.
        progress : callable(index, TerrainResult), optional
            Called (in this thread) as each variation finishes.
        cancel : callable() -> bool, optional
            Polled; True stops them all (``SynthesisCancelled`` is raised).
        workers : int, optional
            Processes; default one per core, at most one per seed.

        Returns
        -------
        list of TerrainResult
            In the order of ``seeds``.
        """
        fields = self.example_fields()
        terrains: dict[int, TerrainResult] = {}

        def finished(index: int, result) -> None:
            # The core reports every variation here, so the objects handed to
            # ``progress`` are the ones returned.
            terrains[index] = TerrainResult.from_synthesis(result)
            if progress is not None:
                progress(index, terrains[index])

        results = run_variations(fields, self.sketch_map, seeds=seeds, shape=self.shape, params=self.params,
                                 controls=self.make_controls(), workers=workers, progress=finished, cancel=cancel)
        return [terrains[i] for i in range(len(results))]


@dataclass(frozen=True, eq=False)
class RunInfo:
    """What the views need before the first patch arrives.

    Parameters
    ----------
    shape : (rows, cols)
    cell_size : (dy, dx) or None
        Ground size of an output cell, metres.
    vrange : (low, high)
        Heights the run's colours span, metres.
    base : ndarray of float32, shape (rows, cols), or None
        The terrain a re-synthesis starts from.
    """

    shape: tuple[int, int]
    cell_size: tuple[float, float] | None
    vrange: tuple[float, float]
    base: np.ndarray | None = None


def run_info(request: SynthesisRequest, cell_size: tuple[float, float] | None) -> RunInfo:
    """The run's cell size (the session's) and colour range: the terrain
    being re-synthesized, or the examples' and styles' joint height range
    (slow: reads the examples)."""
    if request.previous is not None:
        return RunInfo(request.shape, cell_size, height_range(request.previous), request.previous)
    fields = request.source_fields()
    bases = [s.base for s in request.styles if s.base is not None]
    low = min([f.min for f in fields] + bases)
    high = max([f.max for f in fields] + bases)
    # Patches are shifted to match their neighbours, so the output may leave
    # the examples' range a little; a margin keeps its tints from clipping.
    margin = 0.1 * (high - low)
    return RunInfo(request.shape, cell_size, (low - margin, high + margin))


@dataclass(frozen=True, eq=False)
class RunStarted:
    """The session is valid and the run starts: the first event of :func:`synthesis_events`."""

    info: RunInfo


@dataclass(frozen=True, eq=False)
class VariationMade:
    """Variation ``index`` (into the batch's seeds) is done."""

    index: int
    terrain: TerrainResult


def synthesis_events(request: SynthesisRequest) -> Iterator:
    """Run ``request``: :class:`RunStarted`, then the core's events
    (``StageStarted``, ``PatchPlaced``, ``StageFinished``, ``SynthesisFinished``).

    Everything happens when the generator is drained, on the caller's
    thread; closing it stops the run at the next patch.
    """
    session = request.make_session()
    cell = session.cell_size
    yield RunStarted(run_info(request, None if cell is None else (cell, cell)))
    yield from session.iter_run()


def variation_events(request: SynthesisRequest, seeds: Sequence[int], *,
                     poll_seconds: float = 0.1) -> Iterator[VariationMade | None]:
    """Make one variation per seed: a :class:`VariationMade` as each finishes.

    The core makes variations in worker processes and reports them by
    callback, so the batch runs on a helper thread; while waiting this
    yields None every ``poll_seconds`` (a cancel checkpoint for the
    consumer).  Closing the generator stops the batch.

    Returns
    -------
    list of TerrainResult
        In the order of ``seeds`` (the generator's return value).
    """
    return (yield from reported_events(
        lambda report, cancel: request.make_variations(
            seeds, progress=lambda index, terrain: report(VariationMade(index, terrain)), cancel=cancel),
        name="variations", poll_seconds=poll_seconds))


def reported_events(call, *, name: str, poll_seconds: float = 0.1) -> Iterator:
    """Run ``call(report, cancel)`` on a helper thread and yield what it
    reports, as it reports it.

    For core calls that report by callback instead of yielding (variations
    in worker processes, tiled runs on Dask).  While waiting this yields
    None every ``poll_seconds``: a cancel checkpoint for the consumer.
    Closing the generator sets ``cancel()`` and waits for the call to end.

    Parameters
    ----------
    call : callable ``(report, cancel) -> result``
        ``report(event)`` hands an event over; ``cancel()`` turns True
        once the consumer stops.
    name : str
        The helper thread's name.
    poll_seconds : float, default 0.1

    Returns
    -------
    object
        What ``call`` returned (the generator's return value); what it
        raised is raised here.
    """
    events: queue.SimpleQueue = queue.SimpleQueue()
    stop = threading.Event()
    outcome: dict = {}
    done = object()

    def work() -> None:
        try:
            outcome["result"] = call(events.put, stop.is_set)
        except BaseException as exc:  # handed to the consumer below
            outcome["error"] = exc
        finally:
            events.put(done)

    thread = threading.Thread(target=work, name=name, daemon=True)
    thread.start()
    try:
        while True:
            try:
                item = events.get(timeout=poll_seconds)
            except queue.Empty:
                yield None
                continue
            if item is done:
                break
            yield item
    finally:
        stop.set()
        thread.join()
    if "error" in outcome:
        raise outcome["error"]
    return outcome["result"]
