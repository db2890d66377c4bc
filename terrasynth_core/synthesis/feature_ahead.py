"""Feature patches prepared one ahead of their placing, on another core.

Preparing a feature patch (ranking its candidates and warping them onto the
stroke, :func:`~.feature_patches.prepare_feature`) reads only the examples;
placing it (matching, cutting and blending against the output) reads the
output.  So the next patch is prepared while the current one is placed.
Both hold the interpreter lock for most of their work (warps, graph cuts,
small array operations), so a helper *thread* barely overlaps them
(measured: a 1000x1000 run's feature stage took as long with the
preparation on a thread as in line); a worker process (:mod:`.workers`)
does.  The preparation is a pure function of what it is sent, including a
snapshot of the windows used so far taken when it is asked for, so the
result is the same bytes on a process, a thread or in line.
"""

from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..features.samples import FeatureSample
from ..matching.usage import UsageRegistry
from .feature_patches import Stations, prepare_feature
from .workers import KitWorkers, ready


@dataclass(frozen=True, eq=False)
class FeatureKit:
    """What every feature preparation of a run reads.

    Parameters
    ----------
    pools : dict
        Feature pools by (kind, style group or None)
        (:func:`~.feature_patches.feature_pools`).
    detail : list of ndarray of float32
        Each example's detail heights, metres.
    stations : Stations
        The sketch's and examples' feature-line stations.
    shape : (rows, cols)
        The output.
    patch_size : int
    """

    pools: dict
    detail: list
    stations: Stations
    shape: tuple[int, int]
    patch_size: int


def prepare_with(kit: FeatureKit, sample: FeatureSample, pool: tuple, count: int, rng: np.random.Generator,
                 usage: UsageRegistry, cap: int):
    """:func:`~.feature_patches.prepare_feature` of ``sample`` from the
    kit's pool ``pool`` (its key)."""
    return prepare_feature(sample, kit.pools[pool], kit.detail, shape=kit.shape, patch_size=kit.patch_size,
                           count=count, rng=rng, usage=usage, cap=cap, stations=kit.stations)


class PrepareAhead:
    """Runs feature preparations on the run's worker processes once they
    are warm, on a helper thread until then; use as a context manager.

    Parameters
    ----------
    kit : FeatureKit
    processes : int
        The run's processes (this one included, as for the fill): above 1,
        each preparation goes to its workers if they have started and
        imported (:func:`.workers.ready`; a fresh process's first
        preparations would wait a second for that), else to the thread.
        1: the thread only.
    """

    def __init__(self, kit: FeatureKit, *, processes: int):
        self.kit = kit
        self.processes = max(1, int(processes))
        self._workers = KitWorkers(kit, self.processes) if self.processes > 1 else None
        self._thread = None

    def __enter__(self) -> "PrepareAhead":
        return self

    def __exit__(self, *exc) -> None:
        if self._thread is not None:
            self._thread.shutdown(wait=True, cancel_futures=True)
        if self._workers is not None:
            self._workers.__exit__(*exc)

    def submit(self, sample: FeatureSample, pool: tuple, count: int, rng: np.random.Generator,
               usage: UsageRegistry, cap: int) -> Future:
        """Start preparing ``sample``: a future of what
        :func:`~.feature_patches.prepare_feature` returns.  ``usage`` must be
        a snapshot (:meth:`UsageRegistry.snapshot`)."""
        if self._workers is not None and (self._workers.started or ready()):
            return self._workers.submit(prepare_with, sample, pool, count, rng, usage, cap)
        if self._thread is None:
            self._thread = ThreadPoolExecutor(max_workers=1, thread_name_prefix="terrasynth-prefetch")
        return self._thread.submit(prepare_with, self.kit, sample, pool, count, rng, usage, cap)
