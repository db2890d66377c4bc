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
from ..controls.pins import PinError, apply_pins
from ..controls.water import apply_water, flooded_land
from ..placing.canvas import Canvas, Cut
from ..controls.options import Controls
from .events import PatchPlaced, StageFinished, StageStarted, SynthesisFinished
from ..matching.fill_search import FillSearch
from .params import SynthesisParams
from ..matching.candidates import FeaturePool
from ..matching.costs import match_cost, overlap_ssd, settle
from ..features.samples import FeatureSample
from ..order.bfs import feature_order
from ..controls.layout import build_layout


@dataclass(frozen=True)
class PatchRecord:
    """What was placed where, and why (a debug product of the result).

    ``source`` is the example window's top-left corner for fill patches and
    the example sample centre for feature patches, ``(row, col)``; stamps
    have ``example`` -1 and ``source`` (stamp index, 0).
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
    style_map : ndarray of int16, shape (rows, cols), or None
        Style label per cell (-1 = the plain examples) when styles were used.
    pin_errors : tuple of PinError
        Height minus wanted height at each pin, metres.
    selection : ndarray of bool, shape (rows, cols), or None
        The cells a local re-synthesis changed (None for a full run).
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
    style_map: np.ndarray | None = None
    pin_errors: tuple[PinError, ...] = ()
    selection: np.ndarray | None = None

    def counts(self) -> dict[str, int]:
        """Patches placed by kind (branch, end, path, fill, stamp)."""
        out = {"branch": 0, "end": 0, "path": 0, "fill": 0, "stamp": 0}
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
            "pins": [{"row": e.row, "col": e.col, "target": e.target, "height": e.height, "error": e.error}
                     for e in self.pin_errors],
            "warnings": list(self.warnings),
        }


class Session:
    """One synthesis problem: examples, a sketch, an output size, parameters,
    and optionally the artist controls (style regions, water, stamps, pins,
    height range, local re-synthesis).

    Everything is checked here, before any work; ``iter_run`` may be called
    again after changing nothing (same seed, same bytes) and a new session is
    cheap to make after an edit (example analysis is memoised).

    Parameters
    ----------
    examples : sequence of HeightField or 2-D arrays
        Example DEMs (heights in metres), the style of every cell no style
        region claims.  Nodata is cropped away (or filled when the valid
        rectangle is too small).  May be empty when styles cover the map.
    sketch : SketchMap or None
        Ridge and valley strokes; ``None`` or a blank sketch gives a
        non-feature synthesis (reported in the warnings).
    shape : (rows, cols), optional
        Output size; default the sketch's (or the style map's, or the
        previous result's).  The sketch is scaled to it.
    params : SynthesisParams
    controls : Controls, optional
        See :class:`~.controls.Controls`.
    """

    def __init__(self, examples: Sequence[HeightField | np.ndarray], sketch: SketchMap | None = None, *,
                 shape: tuple[int, int] | None = None, params: SynthesisParams = SynthesisParams(),
                 controls: Controls | None = None):
        if not isinstance(params, SynthesisParams):
            raise ParamsError(f"params must be SynthesisParams, got {type(params).__name__}")
        controls = Controls() if controls is None else controls
        if not isinstance(controls, Controls):
            raise ParamsError(f"controls must be Controls, got {type(controls).__name__}")
        examples = list(examples or ())
        if not examples and not controls.styles:
            raise ParamsError("no example DEM given: synthesis needs at least one")
        if shape is None:
            for candidate in (sketch, controls.style_map, controls.previous):
                if candidate is not None:
                    shape = candidate.shape
                    break
            else:
                raise ParamsError("give an output shape when there is no sketch")
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
        self.controls = controls.checked(self.shape, params.patch_size, len(examples))
        self.layout = build_layout(examples, self.controls, self.shape, params.patch_size)
        self.examples = self.layout.examples
        self.warnings: list[str] = list(self.layout.notes)
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


class _Run:
    """The state of one run (kept out of Session so a session can run again)."""

    def __init__(self, session: Session):
        self.s = session
        self.p = session.params
        self.c = session.controls
        self.lay = session.layout
        self.rng = np.random.default_rng(self.p.seed)
        self.radius = self.p.patch_size / 2
        self.warnings = list(session.warnings)
        self.relief = float(np.mean(self.lay.relief))
        self.canvas = Canvas(session.shape, self.p, self.relief, previous=self.c.previous,
                             selection=self.c.selection)
        self.records: list[PatchRecord] = []
        self.timings: dict[str, float] = {}

    def events(self) -> Iterator[object]:
        t_start = time.perf_counter()
        t = time.perf_counter()
        yield StageStarted("analyse", 0)
        samples = self._ordered_samples()
        pools = self._pools()
        self.timings["analyse"] = time.perf_counter() - t
        yield StageFinished("analyse", self.timings["analyse"])

        t = time.perf_counter()
        fill_estimate = self._fill_estimate(len(samples))
        total = len(self.lay.stamps) + len(samples) + fill_estimate
        yield StageStarted("features", len(self.lay.stamps) + len(samples))
        for i, stamp in enumerate(self.lay.stamps):
            yield self._event(self._place_stamp(i, stamp), total)
        fallbacks: dict[tuple[str, int, int], int] = {}
        # One helper thread prepares the next patch (ranking and warping, which
        # do not read the output) while this one merges the current patch.
        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="terrasynth-prefetch") as pre:
            def prepare(i):
                return pre.submit(self._prepare_feature, i, samples[i], pools)

            pending = prepare(0) if samples else None
            for i, sample in enumerate(samples):
                got = self._pool(pools, sample).nearest_degree(sample.degree)
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
        used = {int(g) for g in np.unique(self.lay.group_map)}
        searches = [
            FillSearch(detail, (self.p.patch_size, self.p.patch_size), feature_mask=ex.strong_mask,
                       coarse_factor=self.p.coarse_factor_for(detail.shape), workers=self.p.thread_count)
            if any(i in self.lay.members[g] for g in used) else None
            for i, (ex, detail) in enumerate(zip(self.lay.examples, self.lay.detail))
        ]
        self.timings["fill_setup"] = time.perf_counter() - t
        # The search for the next window runs on the helper thread (FFTs free
        # the interpreter) while this thread blends the patch just placed.  It
        # gets a copy of its window taken before that blend, so what it sees
        # does not depend on timing: same seed, same bytes.  Heights are
        # matched relative to the level field.
        level = self.lay.level
        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="terrasynth-search") as pre:
            def search(bbox, n):
                r0, r1, c0, c1 = bbox
                target = self.canvas.heights[r0:r1, c0:c1] - level[r0:r1, c0:c1]
                filled = self.canvas.filled[r0:r1, c0:c1].copy()
                members, relief = self._window_examples(bbox)
                rng = np.random.default_rng([self.p.seed, 1, n])
                return bbox, pre.submit(self._search_fill, searches, members, relief, target, filled, rng)

            # A style region no feature reached starts from a window of its
            # own terrain: grown only from its neighbours, it would copy
            # their smoothness (the SSD prefers the example's smoothest
            # windows there) instead of its own style.
            for g, bbox in self._region_seeds(windows):
                r0, r1, c0, c1 = bbox
                rng = np.random.default_rng([self.p.seed, 2, g])
                members = self.lay.members[g]
                options = self._search_fill(searches, members, float(max(self.lay.relief[members])),
                                            self.canvas.heights[r0:r1, c0:c1] - level[r0:r1, c0:c1],
                                            self.canvas.filled[r0:r1, c0:c1].copy(), rng)
                placed = self._choose_fill(bbox, options)
                self.canvas.blend(placed.bbox)
                yield self._event(placed, total)
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
        heights, pin_errors = self._finish_heights(heights)
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
            style_map=None if self.c.style_map is None else self.c.style_map.copy(),
            pin_errors=pin_errors,
            selection=None if self.c.selection is None else self.c.selection.copy(),
        )
        yield SynthesisFinished(result)

    # -- the finished heights ------------------------------------------------
    def _finish_heights(self, heights: np.ndarray) -> tuple[np.ndarray, tuple[PinError, ...]]:
        """Height range, then water, then pins (both in final metres)."""
        locked = self.canvas.locked if self.c.resynthesis else None
        if self.lay.remap is not None and locked is None:
            lo, hi = self.lay.remap[:2]
            span = float(heights.max() - heights.min())
            if span > 0:
                heights = (lo + (heights.astype(np.float64) - heights.min()) * ((hi - lo) / span)).astype(np.float32)
        if self.c.water is not None:
            heights = apply_water(heights, self.c.water, bank_width=self.p.patch_size / 2, locked=locked)
            flooded = flooded_land(heights, self.c.water)
            if flooded:
                self.warnings.append(f"{flooded} land cells lie below the water level {self.c.water.level:g} m "
                                     "away from painted water: paint them as water or raise the level")
        heights, pin_errors = apply_pins(heights, self.c.pins, radius=self.c.pin_radius, locked=locked)
        for e in pin_errors:
            if locked is not None and locked[e.row, e.col]:
                self.warnings.append(f"pin at ({e.row}, {e.col}) is outside the selection: left as it was")
        if locked is not None:
            # Every step above keeps locked cells; this makes the promise
            # explicit (bit-identical outside the selection).
            heights = np.where(locked, self.c.previous, heights).astype(np.float32)
        return heights, pin_errors

    # -- order ----------------------------------------------------------------
    def _ordered_samples(self) -> list[FeatureSample]:
        graphs = (self.s.sketch_maps.ridges, self.s.sketch_maps.valleys)
        return feature_order(graphs, self.radius, spacing=self.radius, keep=self._sample_wanted,
                             raster=self.p.order == "raster")

    def _sample_wanted(self, sample: FeatureSample) -> bool:
        """Stamps override the sketch under them; a re-synthesis only
        places features centred in its selection."""
        r = min(max(int(round(sample.center[0])), 0), self.s.shape[0] - 1)
        c = min(max(int(round(sample.center[1])), 0), self.s.shape[1] - 1)
        for st in self.lay.stamps:
            r0, r1, c0, c1 = st.bbox
            if r0 <= r < r1 and c0 <= c < c1 and st.valid[r - r0, c - c0]:
                return False
        return not self.canvas.locked[r, c]

    def _fill_estimate(self, n_features: int) -> int:
        step = self.p.patch_size - self.p.overlap_cells
        rows, cols = self.s.shape
        n = (-(-(rows - self.p.patch_size) // step) + 1) * (-(-(cols - self.p.patch_size) // step) + 1)
        if self.c.resynthesis:
            n = int(np.ceil(n * self.c.selection.mean())) + 4
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

    # -- styles ---------------------------------------------------------------
    def _region_seeds(self, windows: list) -> list[tuple[int, tuple[int, int, int, int]]]:
        """For each style group with no terrain yet (and more than one group
        in the run), the empty window most inside it, nearest its centre."""
        groups = self.lay.group_map
        present = np.unique(groups)
        if present.size < 2:
            return []
        out = []
        for g in (int(v) for v in present):
            region = groups == g
            if (self.canvas.filled & region).any():
                continue
            centre = np.argwhere(region).mean(axis=0)
            best = None
            for bbox in windows:
                r0, r1, c0, c1 = bbox
                if self.canvas.filled[r0:r1, c0:c1].any():
                    continue
                share = region[r0:r1, c0:c1].mean()
                dist = np.hypot((r0 + r1) / 2 - centre[0], (c0 + c1) / 2 - centre[1])
                key = (-share, dist)
                if best is None or key < best[0]:
                    best = (key, bbox)
            if best is not None and best[0][0] < -0.5:
                out.append((g, best[1]))
        return out

    def _pools(self) -> dict:
        """Feature pools per (kind, style group), and over all examples."""
        pools = {}
        everyone = list(range(len(self.lay.examples)))
        for kind in ("ridge", "valley"):
            for g, members in enumerate(self.lay.members + [everyone]):
                key = (kind, g if g < len(self.lay.members) else None)
                pools[key] = FeaturePool([(i, self.lay.examples[i].samples[kind]) for i in members], self.radius,
                                         mirror=self.p.mirror)
        return pools

    def _pool(self, pools: dict, sample: FeatureSample) -> FeaturePool:
        """The pool of the style under a sample; all examples when that style
        has no feature of the kind (said once in the warnings)."""
        g = self.lay.group_at(*sample.center)
        pool = pools[(sample.kind, g)]
        if pool.size() == 0:
            note = (f"{self.lay.names[g]} has no {sample.kind} features for a {self.p.patch_size}-cell patch: "
                    f"its sketched {sample.kind}s use the other styles' examples")
            if note not in self.warnings:
                self.warnings.append(note)
            pool = pools[(sample.kind, None)]
        return pool

    def _window_examples(self, bbox) -> tuple[list[int], float]:
        """Examples of the styles present in a window, and their largest relief."""
        r0, r1, c0, c1 = bbox
        groups = np.unique(self.lay.group_map[r0:r1, c0:c1])
        members = sorted({i for g in groups for i in self.lay.members[int(g)]})
        return members, float(max(self.lay.relief[i] for i in members))

    # -- placing --------------------------------------------------------------
    def _window(self, center: np.ndarray) -> tuple[int, int, int, int]:
        P = self.p.patch_size
        r0 = int(round(center[0] - P / 2))
        c0 = int(round(center[1] - P / 2))
        rows, cols = self.s.shape
        return max(r0, 0), min(r0 + P, rows), max(c0, 0), min(c0 + P, cols)

    def _place_stamp(self, index: int, stamp) -> PatchRecord:
        """Put a stamp on the level field (pasted: it is the reference the
        terrain around it adapts to), its core protected from later cuts."""
        r0, r1, c0, c1 = bbox = stamp.bbox
        patch = stamp.detail + self.lay.level[r0:r1, c0:c1]
        take = stamp.valid & ~self.canvas.locked[r0:r1, c0:c1]
        self.canvas.place(bbox, patch, Cut(take, np.zeros(take.shape, bool), 0.0), len(self.records),
                          protect=stamp.core & take)
        self.canvas.blend(bbox)
        rec = PatchRecord("stamp", None, bbox, -1, (float(index), 0.0), False, 0.0, 0.0, 0.0, 0.0)
        self.records.append(rec)
        return rec

    def _prepare_feature(self, index: int, sample: FeatureSample, pools: dict):
        """Rank candidates for a sample and warp the best onto its window.

        Reads only the examples, never the output, so it can run ahead on
        another thread.  Its random tie-breaks come from a generator seeded
        by (seed, sample index), independent of thread timing.
        """
        from ..warping.thin_plate import ThinPlateSpline, warp_patch

        rng = np.random.default_rng([self.p.seed, 0, index])
        bbox = self._window(sample.center)
        r0, r1, c0, c1 = bbox
        if r1 - r0 < 4 or c1 - c0 < 4:
            return bbox, []
        warped = []
        for cand in self._pool(pools, sample).rank(sample, 3 * self.p.k, rng):
            tps = ThinPlateSpline.fit(cand.target, cand.control, regularization=1e-3)
            patch, valid = warp_patch(self.lay.detail[cand.example], tps, (r0, c0),
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
        level = self.lay.level[r0:r1, c0:c1]
        existing = self.canvas.heights[r0:r1, c0:c1] - level
        relief = float(self.lay.relief[warped[0][0].example])
        evaluated = []
        for cand, patch in warped:
            ssd, offset = settle(*overlap_ssd(existing, patch, filled))
            score = match_cost(ssd, offset, relief) + self.p.feature_weight * cand.deformation
            evaluated.append((score, ssd, offset, patch, cand))
        evaluated.sort(key=lambda t: t[0])
        rr, cc = np.ogrid[r0:r1, c0:c1]
        keep_new = (rr - sample.center[0]) ** 2 + (cc - sample.center[1]) ** 2 <= (self.radius / 2) ** 2
        best = None
        for score, ssd, offset, patch, cand in evaluated[: self.p.k]:
            placed = patch + np.float32(offset) + level
            cut = self.canvas.cut(bbox, placed, keep_new=keep_new, relief=relief)
            total = score + cut.normalized_cost
            if best is None or total < best[0]:
                best = (total, ssd, placed, cand, cut)
        total, ssd, patch, cand, cut = best
        self.canvas.place(bbox, patch, cut, len(self.records), protect=keep_new & cut.take_new)
        self.canvas.blend(bbox)
        rec = PatchRecord(sample.patch_type, sample.kind, bbox, cand.example,
                          (float(cand.center[0]), float(cand.center[1])), cand.mirrored,
                          cand.deformation, ssd, cut.normalized_cost, total)
        self.records.append(rec)
        return rec

    def _search_fill(self, searches: list, members: list[int], relief: float, target, filled, rng) -> list:
        """Candidate example windows for one output window, best first."""
        options = []
        for ei in members:
            for pos, ssd, offset in searches[ei].best(target, filled, self.p.k, rng):
                # Fill windows are anchored by their mean level: the search
                # favours some parts of an example (often its smooth valley
                # floors), and a region built from them would sit below its
                # style's level.  Feature patches keep their own level, so
                # sketched ridges still stand above their surroundings.
                er, ec = pos
                P = self.p.patch_size
                mean = float(self.lay.detail[ei][er:er + P, ec:ec + P].mean())
                ssd, offset = settle(ssd, offset, mean)
                cost = match_cost(ssd, offset + mean, relief)
                options.append((cost, ssd, offset, ei, pos, relief))
        options.sort(key=lambda t: t[0])
        return options[: self.p.k]

    def _choose_fill(self, bbox, options: list) -> PatchRecord:
        """Pick among the searched candidates by SSD plus seam cost and put it
        in the output (the caller blends it)."""
        P = self.p.patch_size
        r0, r1, c0, c1 = bbox
        level = self.lay.level[r0:r1, c0:c1]
        best = None
        for score, ssd, offset, ei, (er, ec), relief in options:
            patch = self.lay.detail[ei][er:er + P, ec:ec + P] + np.float32(offset) + level
            cut = self.canvas.cut(bbox, patch, relief=relief)
            total = score + cut.normalized_cost
            if best is None or total < best[0]:
                best = (total, ssd, patch, ei, (er, ec), cut)
        total, ssd, patch, ei, pos, cut = best
        self.canvas.place(bbox, patch, cut, len(self.records))
        rec = PatchRecord("fill", None, bbox, ei, (float(pos[0]), float(pos[1])), False, 0.0, ssd,
                          cut.normalized_cost, total)
        self.records.append(rec)
        return rec

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
