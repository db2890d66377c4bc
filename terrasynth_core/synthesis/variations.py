"""Several results of one sketch (one per seed), made in parallel.

Synthesis is largely Python-level work (graph cuts, patch bookkeeping) that
holds the interpreter lock, so variations run in separate processes, one
per core.  Processes are *spawned*, never forked: forking a process that
runs Qt or other threads is unsafe.  The parent builds one session first,
so bad input fails at once with the usual message, and the example analysis
it does lands in the disk cache the workers then read.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Callable, Sequence

from ..errors import ParamsError, SynthesisCancelled
from ..controls.options import Controls
from .params import SynthesisParams
from .result import SynthesisResult
from .session import Session

#: Seconds between polls of the cancel callable.
POLL_SECONDS = 0.1
#: Most variations one call makes (each is a whole synthesis).
MAX_VARIATIONS = 64


def run_variations(examples: Sequence, sketch=None, *, seeds: Sequence[int], shape=None,
                   params: SynthesisParams = SynthesisParams(), controls: Controls | None = None,
                   workers: int | None = None, example_sets: Sequence[Sequence] | None = None,
                   progress: Callable[[int, SynthesisResult], None] | None = None,
                   cancel: Callable[[], bool] | None = None) -> list[SynthesisResult]:
    """Synthesize one result per seed (or per example set), in parallel.

    Parameters
    ----------
    examples, sketch, shape, params, controls
        As for :class:`~.session.Session`; ``params.seed`` is replaced by
        each seed.
    seeds : sequence of int
        One variation per seed, all different unless ``example_sets``
        tells the variations apart.
    example_sets : sequence of sequences of examples, optional
        Variation ``i`` uses ``example_sets[i]`` instead of ``examples``
        (the same sketch in other styles); as many as ``seeds``.
    workers : int, optional
        Processes; default one per core, at most one per seed.  1 runs the
        variations one after another in this process.
    progress : callable(index, result), optional
        Called in the calling thread as each variation finishes (``index``
        into ``seeds``).
    cancel : callable() -> bool, optional
        Polled about ten times a second; True stops every variation and
        raises :class:`SynthesisCancelled`.

    Returns
    -------
    list of SynthesisResult
        In the order of ``seeds``.

    Raises
    ------
    ParamsError
        No seeds, repeated seeds, or anything :class:`Session` refuses.
    """
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise ParamsError("variations need at least one seed")
    if len(seeds) > MAX_VARIATIONS:
        raise ParamsError(f"{len(seeds)} variations asked for; at most {MAX_VARIATIONS} are made at once")
    if example_sets is None:
        sets = [list(examples)] * len(seeds)
        if len(set(seeds)) != len(seeds):
            raise ParamsError(f"variation seeds repeat: {seeds}")
    else:
        sets = [list(e) for e in example_sets]
        if len(sets) != len(seeds):
            raise ParamsError(f"{len(sets)} example sets for {len(seeds)} seeds: give one set per variation")
    if any(s < 0 for s in seeds):
        raise ParamsError(f"seeds must be non-negative integers, got {seeds}")
    cores = os.cpu_count() or 1
    workers = min(len(seeds), cores) if workers is None else int(workers)
    if workers < 1:
        raise ParamsError(f"workers must be at least 1, got {workers}")
    # Validate (and analyse the examples into the cache) here, once per set.
    for ex in sets[:1] if example_sets is None else sets:
        Session(ex, sketch, shape=shape, params=dataclasses.replace(params, seed=seeds[0]), controls=controls)
    results: list[SynthesisResult | None] = [None] * len(seeds)
    if workers == 1:
        for i, seed in enumerate(seeds):
            session = Session(sets[i], sketch, shape=shape, params=dataclasses.replace(params, seed=seed),
                              controls=controls)
            results[i] = session.run(cancel=cancel)
            if progress is not None:
                progress(i, results[i])
        return results
    # Each process gets its share of the cores for its FFTs.
    per_process = dataclasses.replace(params, workers=max(1, (params.workers or cores) // workers))
    ctx = multiprocessing.get_context("spawn")
    stop = ctx.Event()
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                             initargs=(stop,)) as pool:
        futures = {
            pool.submit(_one, sets[i], sketch, shape, dataclasses.replace(per_process, seed=seed), controls): i
            for i, seed in enumerate(seeds)
        }
        pending = set(futures)
        try:
            while pending:
                done, pending = wait(pending, timeout=POLL_SECONDS, return_when=FIRST_COMPLETED)
                for fut in done:
                    i = futures[fut]
                    results[i] = fut.result()
                    if progress is not None:
                        progress(i, results[i])
                if pending and cancel is not None and cancel():
                    raise SynthesisCancelled("variations cancelled")
        except BaseException:
            # Stop the running variations at their next patch and drop the
            # queued ones before the pool shuts down.
            stop.set()
            for fut in pending:
                fut.cancel()
            raise
    return results


#: The cancel flag of the pool this worker process belongs to.
_STOP = None


def _init_worker(stop) -> None:
    global _STOP
    _STOP = stop


def _one(examples, sketch, shape, params, controls) -> SynthesisResult:
    """One variation, in a worker process."""
    session = Session(examples, sketch, shape=shape, params=params, controls=controls)
    return session.run(cancel=_STOP.is_set)
