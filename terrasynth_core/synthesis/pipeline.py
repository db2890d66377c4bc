"""The stages of a run, in order, as events: analyse (feature order and
pools), features (stamps, then feature patches), fill, finish.

Each stage is a generator over the run's state that yields progress events
and returns what the next stage needs; :func:`run_pipeline` chains them.
Random numbers come from generators seeded by ``[seed, stage, i]`` (0:
feature sample i, 1: fill window i, 2: style region i), so what a patch
draws depends neither on thread timing nor on the other patches.
"""

from __future__ import annotations

import functools
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Iterator

import numpy as np
from threadpoolctl import ThreadpoolController

from ..controls.layout import StyleLayout
from ..controls.options import Controls
from ..exemplars.mapped_pages import keep_within_budget
from ..features.samples import FeatureSample
from ..matching.usage import UsageRegistry, window_cap
from ..order.bfs import feature_order
from ..placing.canvas import Canvas
from ..placing.windows import WindowQueue, estimate_fill_count, fill_windows, region_seeds
from .events import LandformProgress, PatchPlaced, StageFinished, StageStarted, SynthesisFinished
from .feature_ahead import FeatureKit, PrepareAhead, prepare_with
from .feature_patches import (Stations, all_excluded, memo_feature_pools, place_feature, place_stamp,
                              pool_key)
from .fill_patches import choose_fill, fill_searches, search_fill, window_examples
from .fill_workers import MIN_PARALLEL_WINDOWS, WAVE, FillKit, FillWorkers, window_task
from .finish import finish_heights
from .landform import DRAWN_NOTE, drawn_level, drawn_split, landform_from, preview_patch, split_sigma
from .params import SynthesisParams
from .result import PatchRecord, SynthesisResult
from .workers import running, warm_up

#: Fewest feature patches worth preparing on a worker process (sending it
#: the run's pools and examples costs more than a few patches save).
MIN_AHEAD_SAMPLES = 16

if TYPE_CHECKING:
    from .session import Session


@dataclass(eq=False)
class RunState:
    """What one run builds (kept out of the Session so a session can run
    again): the canvas, the records of the patches placed, warnings and
    timings."""

    session: Session
    params: SynthesisParams
    controls: Controls
    layout: StyleLayout
    canvas: Canvas
    warnings: list[str]
    records: list[PatchRecord] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    #: Feature pools and fill searches made ahead (during the landform pass).
    pools: dict | None = None
    searches: list | None = None
    #: Whether this run started the worker processes (:func:`.workers.warm_up`).
    warmed: bool = False

    @classmethod
    def start(cls, session: Session) -> "RunState":
        """An empty canvas (or the previous result of a re-synthesis) for
        ``session``."""
        p, c = session.params, session.controls
        canvas = Canvas(session.shape, float(np.mean(session.layout.relief)), patch_size=p.patch_size, seam=p.seam,
                        blend=p.blend, previous=c.previous, selection=c.selection)
        if session.band is not None:  # previous terrain the graph cuts may replace
            canvas.filled |= session.band
        return cls(session, p, c, session.layout, canvas, list(session.warnings))

    @property
    def processes(self) -> int:
        """Processes that fill windows (this one included)."""
        return self.params.thread_count

    @property
    def radius(self) -> float:
        return feature_radius(self.params)

    def placed(self, rec: PatchRecord, total: int) -> PatchPlaced:
        """Record a placed patch; its progress event."""
        self.records.append(rec)
        r0, r1, c0, c1 = rec.bbox
        return PatchPlaced(len(self.records) - 1, max(total, len(self.records)), rec.kind, rec.bbox,
                           self.canvas.heights[r0:r1, c0:c1].copy(), rec.cost)


@functools.cache
def _blas_threads() -> ThreadpoolController:
    """The process's BLAS libraries, found once (a search takes ~10 ms)."""
    return ThreadpoolController()


def run_pipeline(state: RunState) -> Iterator[object]:
    """Run stage by stage, yielding the events; the last is
    :class:`SynthesisFinished` with the result.

    Parameters
    ----------
    state : RunState
        A fresh state (:meth:`RunState.start`) of a validated session.
    """
    t_start = time.perf_counter()
    # The run's own threads keep both cores busy; BLAS threads on top of
    # them only contend (a 300x300 Cholesky of a seam solve took 60x longer
    # with OpenBLAS's threads fighting the search thread).
    # The worker processes start now, while the landform pass runs, so
    # they are ready for the feature patches' preparation and the fill (if
    # the fill will be long enough to use them).
    p = state.params
    if estimate_fill_count(state.session.shape, p.patch_size, overlap=p.overlap_cells, n_features=0,
                           selection=state.controls.selection) >= MIN_PARALLEL_WINDOWS:
        warm_up(state.processes, p.patch_size)
        state.warmed = state.processes > 1
    with _blas_threads().limit(limits=1, user_api="blas"):
        # (Between stages, and after every patch, the mapped pages of a
        # large library are handed back past their budget: mapped_pages.)
        yield from landform_stage(state)
        keep_within_budget()
        samples, pools = yield from analyse_stage(state)
        keep_within_budget()
        yield from feature_stage(state, samples, pools)
        keep_within_budget()
        yield from fill_stage(state)
        yield from finish_stage(state, t_start)


def landform_stage(state: RunState):
    """The coarse pass (:mod:`.landform`): its terrain becomes the level
    field and the examples' detail is taken above the same split.  Its
    patches are announced as :class:`LandformProgress` with a preview on
    the output's grid, so a viewer shows landforms within a tenth of a
    second and a run can be cancelled during the pass."""
    if not state.params.landform:
        return
    t = time.perf_counter()
    yield StageStarted("landform", 0)
    coarse, f, note = state.session.coarse_pass()
    if coarse is None and note is not None:
        # The examples cannot give landforms (the pass would have run on a
        # map this size): the drawing gives them alone, and the examples
        # their detail above a wider split.
        drawn = drawn_level(state.session)
        if drawn is not None:
            detail, anchor = state.session.detail_above(drawn_split(state.params.patch_size))
            state.layout = replace(state.layout, level=drawn, detail=detail, anchor=anchor)
            note += DRAWN_NOTE
    if note:
        state.warnings.append(note)
    if coarse is not None:
        # What the full-resolution pass needs and the coarse one does not
        # change (the detail above the split, the feature pools, the fill
        # searches over that detail) is made on a helper thread meanwhile.
        ahead = ThreadPoolExecutor(max_workers=1, thread_name_prefix="terrasynth-ahead")
        made = ahead.submit(_made_ahead, state, split_sigma(state.params.patch_size))
        result = None
        events = coarse.iter_run()
        try:
            for event in events:
                if isinstance(event, PatchPlaced):
                    bbox, heights = preview_patch(event.bbox, event.heights, coarse.shape, state.session.shape)
                    yield LandformProgress(event.index + 1, event.total, bbox, heights)
                elif isinstance(event, SynthesisFinished):
                    result = event.result
            landform = landform_from(state.session, result, f)
            layout, state.pools, state.searches = made.result()
        finally:
            events.close()
            # A cancelled run does not wait for the helper thread.
            ahead.shutdown(wait=False, cancel_futures=True)
        state.layout = replace(layout, level=landform.level)
    state.timings["landform"] = time.perf_counter() - t
    yield StageFinished("landform", state.timings["landform"])


def _made_ahead(state: RunState, sigma: float) -> tuple[StyleLayout, dict, list]:
    """The layout with the examples' detail above the landform split, and
    what the run reads from that detail (:func:`examples_read`)."""
    detail, anchor = state.session.detail_above(sigma)
    layout = replace(state.layout, detail=detail, anchor=anchor)
    return (layout, *examples_read(layout, state.params))


def feature_radius(params: SynthesisParams) -> float:
    """A feature patch's inscribed radius, cells: its samples' spacing and
    its pools' neighbourhood."""
    return params.patch_size / 2


def examples_read(layout: StyleLayout, params: SynthesisParams) -> tuple[dict, list]:
    """What a run reads from its examples' detail before it places a patch,
    none of it from the output: the feature pools and the fill searches
    (both kept in the core by what they are made of, for the next run or
    live stroke)."""
    return (memo_feature_pools(layout, feature_radius(params), mirror=params.mirror),
            fill_searches(layout, params))


def analyse_stage(state: RunState):
    """The sketch samples in placing order, and the feature pools."""
    t = time.perf_counter()
    yield StageStarted("analyse", 0)
    graphs = (state.session.sketch_maps.ridges, state.session.sketch_maps.valleys)
    samples = feature_order(graphs, state.radius, spacing=state.radius, keep=lambda s: _sample_wanted(state, s),
                            raster=state.params.order == "raster")
    pools = state.pools or memo_feature_pools(state.layout, state.radius, mirror=state.params.mirror)
    state.timings["analyse"] = time.perf_counter() - t
    yield StageFinished("analyse", state.timings["analyse"])
    return samples, pools


def _sample_wanted(state: RunState, sample: FeatureSample) -> bool:
    """Stamps override the sketch under them; a re-synthesis only places
    features centred in its selection."""
    rows, cols = state.session.shape
    r = min(max(int(round(sample.center[0])), 0), rows - 1)
    c = min(max(int(round(sample.center[1])), 0), cols - 1)
    for st in state.layout.stamps:
        r0, r1, c0, c1 = st.bbox
        if r0 <= r < r1 and c0 <= c < c1 and st.valid[r - r0, c - c0]:
            return False
    return not state.canvas.locked[r, c]


def feature_stage(state: RunState, samples: list[FeatureSample], pools: dict):
    """Stamps, then one feature patch per sample."""
    t = time.perf_counter()
    p, lay = state.params, state.layout
    fill_estimate = estimate_fill_count(state.session.shape, p.patch_size, overlap=p.overlap_cells,
                                        n_features=len(samples), selection=state.controls.selection)
    total = len(lay.stamps) + len(samples) + fill_estimate
    yield StageStarted("features", len(lay.stamps) + len(samples))
    for i, stamp in enumerate(lay.stamps):
        yield state.placed(place_stamp(state.canvas, stamp, lay.level, index=len(state.records), stamp_index=i),
                           total)
    fallbacks: dict[tuple[str, int, int], int] = {}
    rigid = {"ridge": 0, "valley": 0}
    # Variety: no example window supplies more than its share of the run's
    # feature patches, and neighbours never share one (matching/usage.py).
    usage = UsageRegistry(p.patch_size)
    n_kind = {kind: sum(s.kind == kind for s in samples) for kind in ("ridge", "valley")}
    stations = Stations(state.session.sketch_maps, lay.examples, state.radius)
    # The next patch is prepared (ranked and warped, which does not read
    # the output) while this one is placed, on a worker process once the
    # run's are warm (a thread would hold the interpreter lock against this
    # one: :mod:`.feature_ahead`).  It ranks against a snapshot of the
    # windows used, taken now: what it prepares does not depend on timing
    # or on where it ran (same seed, same bytes); the placing checks the
    # prepared candidates again against every patch.
    kit = FeatureKit(pools, lay.detail, stations, state.session.shape, p.patch_size)
    processes = state.processes if state.warmed and len(samples) >= MIN_AHEAD_SAMPLES else 1
    with PrepareAhead(kit, processes=processes) as ahead:
        def ranking_rng(i):
            return np.random.default_rng([p.seed, 0, i])

        def prepare(i):
            key = pool_key(pools, lay, samples[i], state.warnings, patch_size=p.patch_size)
            cap = window_cap(len(samples), n_kind[samples[i].kind], pools[key].size())
            return key, cap, ahead.submit(samples[i], key, 3 * p.k, ranking_rng(i), usage.snapshot(), cap)

        pending = prepare(0) if samples else None
        for i, sample in enumerate(samples):
            key, cap, future = pending
            got = pools[key].nearest_degree(sample.degree)
            if got != sample.degree:
                fell = (sample.kind, sample.degree, got)
                fallbacks[fell] = fallbacks.get(fell, 0) + 1
            prepared = future.result()
            if all_excluded(prepared, usage, sample.center, cap):
                # The patch placed since the snapshot excludes every
                # candidate (most often the previous patch, whose window
                # fits this stretch of the stroke best too): prepared again
                # here, against every patch, rather than repeat a window
                # or take one past its cap.
                prepared = prepare_with(kit, sample, key, 3 * p.k, ranking_rng(i), usage.snapshot(), cap)
            rigid[sample.kind] += prepared[2]
            pending = prepare(i + 1) if i + 1 < len(samples) else None
            rec = place_feature(state.canvas, sample, prepared, lay, index=len(state.records), radius=state.radius,
                                k=p.k, feature_weight=p.feature_weight, usage=usage, cap=cap,
                                rng=np.random.default_rng([p.seed, 3, i]))
            if rec is not None:
                usage.record(rec.example, rec.source, rec.bbox, sample.center)
                yield state.placed(rec, total)
            keep_within_budget()
    for (kind, want, got), n in sorted(fallbacks.items()):
        state.warnings.append(
            f"no degree-{want} {kind} patch in the examples: used degree {got} instead ({n} patch(es))"
        )
    for kind, n in rigid.items():
        if n:
            state.warnings.append(
                f"{n} of {n_kind[kind]} {kind} patches placed unbent: no example {kind} bends onto those strokes "
                "without folding or streaking (the examples' are too curved or too few); a larger or more varied "
                "example, or straighter strokes, would help")
    state.timings["features"] = time.perf_counter() - t
    yield StageFinished("features", state.timings["features"])


def fill_stage(state: RunState):
    """Fill windows, most constrained first, until the output is full: in
    waves of independent windows, on every core (:mod:`.fill_workers`)."""
    t = time.perf_counter()
    p, lay, canvas = state.params, state.layout, state.canvas
    windows = fill_windows(canvas.filled, p.patch_size, overlap=p.overlap_cells)
    total = len(state.records) + len(windows)
    yield StageStarted("fill", len(windows))
    searches = state.searches or fill_searches(lay, p)
    state.timings["fill_setup"] = time.perf_counter() - t
    options = dict(patch_size=p.patch_size, k=p.k)
    # Heights are matched relative to the level field.
    level = lay.level
    # A style region no feature reached starts from a window of its
    # own terrain: grown only from its neighbours, it would copy
    # their smoothness (the SSD prefers the example's smoothest
    # windows there) instead of its own style.
    for g, bbox in region_seeds(lay.group_map, canvas.filled, windows):
        r0, r1, c0, c1 = bbox
        rng = np.random.default_rng([p.seed, 2, g])
        members = lay.members[g]
        found = search_fill(searches, lay.detail, lay.anchor, members, float(max(lay.relief[members])),
                            canvas.heights[r0:r1, c0:c1] - level[r0:r1, c0:c1],
                            canvas.filled[r0:r1, c0:c1].copy(), rng, **options)
        rec = choose_fill(canvas, bbox, found, lay.detail, level, index=len(state.records), patch_size=p.patch_size,
                          rng=rng)
        canvas.blend(rec.bbox)
        yield state.placed(rec, total)
    # A re-synthesis (a live stroke's crop) leaves the windows along its
    # selection's edge slivers of cells the windows further in hold too.
    # Not a tile's (it has a band): its borders met the finished strips less
    # well so (a 2048x2048 run's tile borders 1.08 -> 1.17 of the interiors).
    defer = state.controls.selection is not None and state.session.band is None
    remaining = WindowQueue(windows, canvas.filled, defer_shared=defer)
    kit = FillKit(searches, lay.detail, lay.anchor, p.seed, p.patch_size, p.k)
    number = 0
    # A short fill (a live stroke's crop) goes to the worker processes only
    # when they are up and warm already (starting them would cost it more
    # than they save); its kit stays with them for the next stroke.
    long = len(windows) >= MIN_PARALLEL_WINDOWS
    processes = state.processes if long or running(state.processes) else 1
    with FillWorkers(kit, processes) as workers:
        while wave := remaining.pop_wave(WAVE):
            tasks = []
            for j, bbox in enumerate(wave):
                members, relief = window_examples(lay, bbox)
                tasks.append(window_task(canvas, level, bbox, members, relief, number=number + j,
                                         index=len(state.records) + j))
            number += len(wave)
            for task, (crop, rec) in zip(tasks, workers.run(tasks)):
                canvas.merge(crop, task.box, task.bbox)
                remaining.update(task.bbox)
                yield state.placed(rec, total)
    state.timings["fill"] = time.perf_counter() - t
    yield StageFinished("fill", state.timings["fill"])


def finish_stage(state: RunState, t_start: float):
    """Height range, drainage, water and pins; then the result."""
    t = time.perf_counter()
    yield StageStarted("finish", 0)
    c = state.controls
    heights, patch_id, seams = state.canvas.finish()
    locked = state.canvas.locked if c.resynthesis else None
    p = state.params
    heights, pin_errors, notes = finish_heights(heights, c, state.layout, locked=locked, patch_size=p.patch_size,
                                                sketch=state.session.sketch_maps if p.drainage else None)
    state.warnings.extend(notes)
    state.timings["finish"] = time.perf_counter() - t
    yield StageFinished("finish", state.timings["finish"])
    yield SynthesisFinished(SynthesisResult(
        heights=heights,
        patch_id=patch_id,
        seam_mask=seams,
        patches=tuple(state.records),
        sketch_features=state.session.sketch_maps,
        timings=dict(state.timings),
        total_seconds=time.perf_counter() - t_start,
        warnings=tuple(state.warnings),
        params=state.params,
        style_map=None if c.style_map is None else c.style_map.copy(),
        pin_errors=pin_errors,
        selection=None if c.selection is None else c.selection.copy(),
        cell_size=state.layout.cell_size,
        georef=state.session.georef,
    ))
