"""A synthesis run: validated inputs, progress events, cancellation, result.

Usage::

    session = Session([load_dem("N44W072.hgt")], read_sketch("s.png"))
    for event in session.iter_run():      # a GUI worker turns these into signals
        ...
    result = session.run(progress=print)  # or drain it in one call

References
----------
Zhou, Sun, Turk, Rehg, "Terrain Synthesis from Digital Elevation Models",
IEEE TVCG 13(4), 2007.  Kwatra et al., "Graphcut Textures", SIGGRAPH 2003.
Perez, Gangnet, Blake, "Poisson Image Editing", SIGGRAPH 2003.
Bookstein, "Principal Warps", IEEE PAMI 11(6), 1989.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Callable, Iterator, Sequence

import numpy as np

from ..errors import ParamsError, SynthesisCancelled
from ..features import FeatureMaps
from ..features.sketch import SketchMap, sketch_features
from ..heightfield import HeightField
from .analysis import ExampleAnalysis, prepare_example
from .canvas import Canvas
from .events import PatchPlaced, StageFinished, StageStarted, SynthesisFinished
from .fill import FillSearch
from .params import SynthesisParams
from .pool import FeaturePool
from .samples import FeatureSample, sketch_samples


@dataclass(frozen=True)
class PatchRecord:
    """What was placed where, and why (a debug product of the result).

    ``source`` is the example window's top-left corner for fill patches and
    the example sample centre for feature patches, ``(row, col)``.
    """

    kind: str
    feature: str | None
    bbox: tuple[int, int, int, int]
    example: int
    source: tuple[float, float]
    mirrored: bool
    deformation: float
    ssd: float
    seam_cost: float
    cost: float


@dataclass(frozen=True, eq=False)
class SynthesisResult:
    """The output height field with its debug maps.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Synthesized heights in metres.
    patch_id : ndarray of int32, shape (rows, cols)
        Index into :attr:`patches` of the patch each cell came from.
    seam_mask : ndarray of bool, shape (rows, cols)
        Cells next to a graph-cut seam.
    patches : tuple of PatchRecord
    sketch_features : FeatureMaps
        The sketch's ridge and valley networks the run followed.
    timings : dict of str -> float
        Seconds per stage.
    total_seconds : float
    warnings : tuple of str
        Things the user should know (fallbacks, nodata handling, no strokes).
    params : SynthesisParams
    """

    heights: np.ndarray
    patch_id: np.ndarray
    seam_mask: np.ndarray
    patches: tuple[PatchRecord, ...]
    sketch_features: FeatureMaps
    timings: dict
    total_seconds: float
    warnings: tuple[str, ...]
    params: SynthesisParams

    def counts(self) -> dict[str, int]:
        """Patches placed by kind (branch, end, path, fill)."""
        out = {"branch": 0, "end": 0, "path": 0, "fill": 0}
        for p in self.patches:
            out[p.kind] += 1
        return out

    def report(self) -> dict:
        """JSON-ready summary: parameters, counts, timings, warnings."""
        return {
            "params": self.params.to_dict(),
            "shape": list(self.heights.shape),
            "patch_counts": self.counts(),
            "timings": {k: round(v, 4) for k, v in self.timings.items()},
            "total_seconds": round(self.total_seconds, 4),
            "height_range": [float(self.heights.min()), float(self.heights.max())],
            "warnings": list(self.warnings),
        }


class Session:
    """One synthesis problem: examples, a sketch, an output size, parameters.

    Everything is checked here, before any work; ``iter_run`` may be called
    again after changing nothing (same seed, same bytes) and a new session is
    cheap to make after an edit (example analysis is memoised).

    Parameters
    ----------
    examples : sequence of HeightField or 2-D arrays
        Example DEMs (heights in metres).  Nodata is cropped away (or filled
        when the valid rectangle is too small).
    sketch : SketchMap or None
        Ridge and valley strokes; ``None`` or a blank sketch gives a
        non-feature synthesis (reported in the warnings).
    shape : (rows, cols), optional
        Output size; default the sketch's.  The sketch is scaled to it.
    params : SynthesisParams
    """

    def __init__(self, examples: Sequence[HeightField | np.ndarray], sketch: SketchMap | None = None, *,
                 shape: tuple[int, int] | None = None, params: SynthesisParams = SynthesisParams()):
        if not isinstance(params, SynthesisParams):
            raise ParamsError(f"params must be SynthesisParams, got {type(params).__name__}")
        if not examples:
            raise ParamsError("no example DEM given: synthesis needs at least one")
        if shape is None:
            if sketch is None:
                raise ParamsError("give an output shape when there is no sketch")
            shape = sketch.shape
        rows, cols = (int(v) for v in shape)
        if min(rows, cols) < params.patch_size:
            raise ParamsError(
                f"output {rows}x{cols} is smaller than a patch ({params.patch_size}): "
                "make the output larger or the patch smaller"
            )
        if rows * cols > 64_000_000:
            raise ParamsError(f"output {rows}x{cols} exceeds 64 million cells")
        if sketch is not None and sketch.shape != (rows, cols):
            sketch = sketch.resized((rows, cols))
        self.shape = (rows, cols)
        self.sketch = sketch
        self.params = params
        self.warnings: list[str] = []
        self.examples: list[ExampleAnalysis] = []
        for i, ex in enumerate(examples):
            name = getattr(ex, "source", None) or f"example {i + 1}"
            analysis = prepare_example(ex, params.patch_size, name=str(name))
            if analysis.note:
                self.warnings.append(analysis.note)
            self.examples.append(analysis)
        self.sketch_maps = self._sketch_maps()
        self._check_features()

    # -- validation -----------------------------------------------------------
    def _sketch_maps(self) -> FeatureMaps:
        if self.sketch is None or not self.sketch.has_strokes:
            self.warnings.append("the sketch has no strokes: non-feature synthesis only")
            blank = SketchMap(np.zeros(self.shape, bool), np.zeros(self.shape, bool))
            return sketch_features(blank)
        return sketch_features(self.sketch)

    def _check_features(self) -> None:
        for graph in (self.sketch_maps.ridges, self.sketch_maps.valleys):
            if not graph.paths:
                continue
            have = sum(len(ex.samples[graph.kind]) for ex in self.examples)
            if have == 0:
                raise ParamsError(
                    f"the sketch has {graph.kind}s but no example has {graph.kind} features far enough "
                    f"from its border for a {self.params.patch_size}-cell patch: choose a larger or more "
                    "rugged example, or a smaller patch size"
                )

    # -- running --------------------------------------------------------------
    def run(self, *, progress: Callable[[object], None] | None = None,
            cancel: Callable[[], bool] | None = None) -> SynthesisResult:
        """Run to the end and return the result.

        Parameters
        ----------
        progress : callable, optional
            Called with every event.
        cancel : callable, optional
            Polled after every patch; when it returns True the run stops and
            :class:`SynthesisCancelled` is raised.
        """
        result = None
        for event in self.iter_run():
            if progress is not None:
                progress(event)
            if cancel is not None and cancel():
                raise SynthesisCancelled("synthesis cancelled")
            if isinstance(event, SynthesisFinished):
                result = event.result
        return result

    def iter_run(self) -> Iterator[object]:
        """Run step by step, yielding events (see :mod:`.events`).

        Closing the generator (or simply not asking for more) cancels the
        run cleanly at the next patch boundary.
        """
        return _Run(self).events()


#: Weight of the squared height shift (in reliefs) against the overlap SSD.
OFFSET_WEIGHT = 0.2


class _Run:
    """The state of one run (kept out of Session so a session can run again)."""

    def __init__(self, session: Session):
        self.s = session
        self.p = session.params
        self.rng = np.random.default_rng(self.p.seed)
        self.radius = self.p.patch_size / 2
        self.warnings = list(session.warnings)
        self.relief = float(np.mean([ex.relief for ex in session.examples]))
        self.canvas = Canvas(session.shape, self.p, self.relief)
        self.records: list[PatchRecord] = []
        self.timings: dict[str, float] = {}

    def events(self) -> Iterator[object]:
        t_start = time.perf_counter()
        t = time.perf_counter()
        yield StageStarted("analyse", 0)
        samples = self._ordered_samples()
        pools = {
            kind: FeaturePool([(i, ex.samples[kind]) for i, ex in enumerate(self.s.examples)], self.radius,
                              mirror=self.p.mirror)
            for kind in ("ridge", "valley")
        }
        self.timings["analyse"] = time.perf_counter() - t
        yield StageFinished("analyse", self.timings["analyse"])

        t = time.perf_counter()
        fill_estimate = self._fill_estimate(len(samples))
        total = len(samples) + fill_estimate
        yield StageStarted("features", len(samples))
        fallbacks: dict[tuple[str, int, int], int] = {}
        # One helper thread prepares the next patch (ranking and warping, which
        # do not read the output) while this one merges the current patch.
        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="terrasynth-prefetch") as pre:
            def prepare(i):
                return pre.submit(self._prepare_feature, i, samples[i], pools[samples[i].kind])

            pending = prepare(0) if samples else None
            for i, sample in enumerate(samples):
                got = pools[sample.kind].nearest_degree(sample.degree)
                if got != sample.degree:
                    key = (sample.kind, sample.degree, got)
                    fallbacks[key] = fallbacks.get(key, 0) + 1
                prepared = pending.result()
                pending = prepare(i + 1) if i + 1 < len(samples) else None
                placed = self._place_feature(sample, prepared)
                if placed is not None:
                    yield self._event(placed, total)
        for (kind, want, got), n in sorted(fallbacks.items()):
            self.warnings.append(
                f"no degree-{want} {kind} patch in the examples: used degree {got} instead ({n} patch(es))"
            )
        self.timings["features"] = time.perf_counter() - t
        yield StageFinished("features", self.timings["features"])

        t = time.perf_counter()
        windows = self._fill_windows()
        total = len(self.records) + len(windows)
        yield StageStarted("fill", len(windows))
        searches = [
            FillSearch(ex.heights, (self.p.patch_size, self.p.patch_size), feature_mask=ex.strong_mask,
                       coarse_factor=self.p.coarse_factor_for(ex.heights.shape), workers=self.p.thread_count)
            for ex in self.s.examples
        ]
        self.timings["fill_setup"] = time.perf_counter() - t
        # The search for the next window runs on the helper thread (FFTs free
        # the interpreter) while this thread blends the patch just placed.  It
        # gets a copy of its window taken before that blend, so what it sees
        # does not depend on timing: same seed, same bytes.
        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="terrasynth-search") as pre:
            def search(bbox, n):
                r0, r1, c0, c1 = bbox
                target = self.canvas.heights[r0:r1, c0:c1].copy()
                filled = self.canvas.filled[r0:r1, c0:c1].copy()
                rng = np.random.default_rng([self.p.seed, 1, n])
                return bbox, pre.submit(self._search_fill, searches, target, filled, rng)

            remaining = _WindowQueue(windows, self.canvas.filled)
            n_fill = 0
            bbox = remaining.pop()
            pending = search(bbox, n_fill) if bbox else None
            while pending is not None:
                bbox, future = pending
                placed = self._choose_fill(bbox, future.result())
                n_fill += 1
                remaining.update(placed.bbox)
                nxt = remaining.pop()
                pending = search(nxt, n_fill) if nxt else None
                self.canvas.blend(placed.bbox)
                yield self._event(placed, total)
        self.timings["fill"] = time.perf_counter() - t
        yield StageFinished("fill", self.timings["fill"])

        t = time.perf_counter()
        yield StageStarted("finish", 0)
        heights, patch_id, seams = self.canvas.finish()
        self.timings["finish"] = time.perf_counter() - t
        yield StageFinished("finish", self.timings["finish"])
        result = SynthesisResult(
            heights=heights,
            patch_id=patch_id,
            seam_mask=seams,
            patches=tuple(self.records),
            sketch_features=self.s.sketch_maps,
            timings=dict(self.timings),
            total_seconds=time.perf_counter() - t_start,
            warnings=tuple(self.warnings),
            params=self.p,
        )
        yield SynthesisFinished(result)

    # -- order ----------------------------------------------------------------
    def _ordered_samples(self) -> list[FeatureSample]:
        comps = []
        for graph in (self.s.sketch_maps.ridges, self.s.sketch_maps.valleys):
            comps.extend(sketch_samples(graph, self.radius, spacing=self.radius))
        # Longest networks first: they set the terrain's frame.
        comps.sort(key=lambda c: -len(c))
        samples = [s for comp in comps for s in comp]
        if self.p.order == "raster":
            samples.sort(key=lambda s: (round(s.center[0]), round(s.center[1])))
        return samples

    def _fill_estimate(self, n_features: int) -> int:
        step = self.p.patch_size - self.p.overlap_cells
        rows, cols = self.s.shape
        n = (-(-(rows - self.p.patch_size) // step) + 1) * (-(-(cols - self.p.patch_size) // step) + 1)
        return max(n - n_features // 2, 0)

    def _fill_windows(self) -> list[tuple[int, int, int, int]]:
        """A grid of patch windows with the configured overlap, the last row and
        column flush with the output's edge, minus those already full."""
        P = self.p.patch_size
        step = P - self.p.overlap_cells
        rows, cols = self.s.shape
        rs = np.unique(np.r_[np.arange(0, rows - P, step), rows - P])
        cs = np.unique(np.r_[np.arange(0, cols - P, step), cols - P])
        out = []
        for r in rs:
            for c in cs:
                if not self.canvas.filled[r:r + P, c:c + P].all():
                    out.append((int(r), int(r + P), int(c), int(c + P)))
        return out

    # -- placing --------------------------------------------------------------
    def _window(self, center: np.ndarray) -> tuple[int, int, int, int]:
        P = self.p.patch_size
        r0 = int(round(center[0] - P / 2))
        c0 = int(round(center[1] - P / 2))
        rows, cols = self.s.shape
        return max(r0, 0), min(r0 + P, rows), max(c0, 0), min(c0 + P, cols)

    def _prepare_feature(self, index: int, sample: FeatureSample, pool: FeaturePool):
        """Rank candidates for a sample and warp the best onto its window.

        Reads only the examples, never the output, so it can run ahead on
        another thread.  Its random tie-breaks come from a generator seeded
        by (seed, sample index), independent of thread timing.
        """
        from ..warping import ThinPlateSpline, warp_patch

        rng = np.random.default_rng([self.p.seed, 0, index])
        bbox = self._window(sample.center)
        r0, r1, c0, c1 = bbox
        if r1 - r0 < 4 or c1 - c0 < 4:
            return bbox, []
        warped = []
        for cand in pool.rank(sample, 3 * self.p.k, rng):
            tps = ThinPlateSpline.fit(cand.target, cand.control, regularization=1e-3)
            patch, valid = warp_patch(self.s.examples[cand.example].heights, tps, (r0, c0),
                                      (r1 - r0, c1 - c0), return_valid=True)
            if valid >= 0.98:
                warped.append((cand, patch))
        return bbox, warped

    def _place_feature(self, sample: FeatureSample, prepared) -> PatchRecord | None:
        bbox, warped = prepared
        if not warped:
            return None
        r0, r1, c0, c1 = bbox
        filled = self.canvas.filled[r0:r1, c0:c1]
        existing = self.canvas.heights[r0:r1, c0:c1]
        evaluated = []
        for cand, patch in warped:
            ssd, offset = _overlap_ssd(existing, patch, filled)
            score = self._match_cost(ssd, offset) + self.p.feature_weight * cand.deformation
            evaluated.append((score, ssd, offset, patch, cand))
        evaluated.sort(key=lambda t: t[0])
        rr, cc = np.ogrid[r0:r1, c0:c1]
        keep_new = (rr - sample.center[0]) ** 2 + (cc - sample.center[1]) ** 2 <= (self.radius / 2) ** 2
        best = None
        for score, ssd, offset, patch, cand in evaluated[: self.p.k]:
            cut = self.canvas.cut(bbox, patch + np.float32(offset), keep_new=keep_new)
            total = score + cut.normalized_cost
            if best is None or total < best[0]:
                best = (total, ssd, patch + np.float32(offset), cand, cut)
        total, ssd, patch, cand, cut = best
        self.canvas.place(bbox, patch, cut, len(self.records), protect=keep_new)
        self.canvas.blend(bbox)
        rec = PatchRecord(sample.patch_type, sample.kind, bbox, cand.example,
                          (float(cand.center[0]), float(cand.center[1])), cand.mirrored,
                          cand.deformation, ssd, cut.normalized_cost, total)
        self.records.append(rec)
        return rec

    def _search_fill(self, searches: list[FillSearch], target, filled, rng) -> list:
        """Candidate example windows for one output window, best first."""
        options = []
        for ei, search in enumerate(searches):
            for pos, ssd, offset in search.best(target, filled, self.p.k, rng):
                options.append((self._match_cost(ssd, offset), ssd, offset, ei, pos))
        options.sort(key=lambda t: t[0])
        return options[: self.p.k]

    def _choose_fill(self, bbox, options: list) -> PatchRecord:
        """Pick among the searched candidates by SSD plus seam cost and put it
        in the output (the caller blends it)."""
        P = self.p.patch_size
        best = None
        for score, ssd, offset, ei, (er, ec) in options:
            patch = self.s.examples[ei].heights[er:er + P, ec:ec + P] + np.float32(offset)
            cut = self.canvas.cut(bbox, patch)
            total = score + cut.normalized_cost
            if best is None or total < best[0]:
                best = (total, ssd, patch, ei, (er, ec), cut)
        total, ssd, patch, ei, pos, cut = best
        self.canvas.place(bbox, patch, cut, len(self.records))
        rec = PatchRecord("fill", None, bbox, ei, (float(pos[0]), float(pos[1])), False, 0.0, ssd,
                          cut.normalized_cost, total)
        self.records.append(rec)
        return rec

    def _match_cost(self, ssd: float, offset: float) -> float:
        """Overlap mismatch in units of the relief, plus a penalty on the height
        shift a candidate needs: without it the shifts random-walk and the
        terrain drifts far outside the example's heights over many patches."""
        return ssd / self.relief**2 + OFFSET_WEIGHT * (offset / self.relief) ** 2

    def _event(self, rec: PatchRecord, total: int) -> PatchPlaced:
        r0, r1, c0, c1 = rec.bbox
        return PatchPlaced(len(self.records) - 1, max(total, len(self.records)), rec.kind, rec.bbox,
                           self.canvas.heights[r0:r1, c0:c1].copy(), rec.cost)


class _WindowQueue:
    """Fill windows, most constrained first: the one with the largest filled
    share, so fill grows out from the placed features (top-left first among
    equals).  Shares are updated only for windows a placed patch touches."""

    def __init__(self, windows: list, filled: np.ndarray):
        self.filled = filled
        self.boxes = np.array(windows, dtype=np.int64).reshape(-1, 4)
        self.share = np.array([filled[r0:r1, c0:c1].mean() for r0, r1, c0, c1 in self.boxes])
        self.done = np.zeros(len(self.boxes), dtype=bool)

    def update(self, bbox) -> None:
        r0, r1, c0, c1 = bbox
        b = self.boxes
        touched = ~self.done & (b[:, 0] < r1) & (b[:, 1] > r0) & (b[:, 2] < c1) & (b[:, 3] > c0)
        for i in np.flatnonzero(touched):
            w0, w1, v0, v1 = b[i]
            self.share[i] = self.filled[w0:w1, v0:v1].mean()

    def pop(self) -> tuple[int, int, int, int] | None:
        """The next window not yet full, or None; windows filled in the
        meantime are dropped."""
        while not self.done.all():
            i = int(np.argmax(np.where(self.done, -1.0, self.share)))
            self.done[i] = True
            if self.share[i] < 1.0:
                return tuple(int(v) for v in self.boxes[i])
        return None


def _overlap_ssd(existing: np.ndarray, patch: np.ndarray, filled: np.ndarray) -> tuple[float, float]:
    """Mean squared difference over the filled cells after the best vertical
    offset, and that offset (to add to ``patch``)."""
    n = int(filled.sum())
    if n == 0:
        return 0.0, 0.0
    diff = existing[filled].astype(np.float64) - patch[filled]
    offset = float(diff.mean())
    return float(((diff - offset) ** 2).mean()), offset
