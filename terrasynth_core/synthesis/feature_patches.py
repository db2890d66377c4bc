"""Feature patches (paper §4.1) and stamps: candidates from the style's
pool, warped onto the sketch, chosen by match cost plus seam cost.

A feature patch is prepared (ranked and warped, reading only the examples)
and then placed (matched against the output, cut and merged), so that the
preparation of the next patch can run elsewhere (a worker process or a
helper thread: :mod:`.feature_ahead`) while this one is placed.
"""

from __future__ import annotations

import functools
import hashlib

import numpy as np
from scipy import ndimage

from ..controls.layout import StyleLayout
from ..exemplars import cache
from ..features.graph import FeatureMaps
from ..features.samples import FeatureSample
from ..features.stations import LineStations
from ..matching.candidates import Candidate, FeaturePool
from ..matching.costs import choose_near_best, match_cost, overlap_ssd, settle
from ..matching.usage import UsageRegistry
from ..memo import Memo, array_key
from ..placing.canvas import Canvas, Cut
from ..placing.windows import patch_window
from ..warping.frame import framed
from ..warping.thin_plate import ThinPlateSpline, WarpWindow
from .result import PatchRecord

#: Share of a warped patch's cells that must come from inside its example.
MIN_VALID_SHARE = 0.98

#: Most a feature warp may stretch the example one way against the other
#: (:func:`~terrasynth_core.warping.thin_plate.warp_distortion`) inside its
#: patch's disc: beyond it ridges turn into streaks.
MAX_STRETCH = 2.0


def feature_pools(layout: StyleLayout, radius: float, *, mirror: bool, stored: str | None = None) -> dict:
    """Feature pools per (kind, style group), and per (kind, None) over all
    examples.

    Parameters
    ----------
    layout : StyleLayout
    radius : float
        Inscribed-circle radius in cells (half the patch).
    mirror : bool
        Also offer mirror images.
    stored : str, optional
        The example cache's key for the pools' arrays (stored and mapped);
        None keeps them in memory.
    """
    pools = {}
    everyone = list(range(len(layout.examples)))
    # One map per example serves both kinds.  It is read on what a patch
    # copies, the example's detail: above the landform split that is the
    # band the patch adds to the level (a valley deep in it stays deep in
    # the output, one deep only at the landform scale is the landform
    # pass's to place); without a split, the example's heights.
    # Each map (float64, as large as its example) is read and dropped
    # before the next is made: a library's maps never all in memory.
    standing: dict = {"ridge": [], "valley": []}
    for ex, detail in zip(layout.examples, layout.detail):
        m = standing_map(detail, 2 * radius) if any(ex.samples[k] for k in standing) else None
        for kind in standing:
            standing[kind].append(sample_prominence(m, ex.samples[kind], kind))
        del m
    for kind in ("ridge", "valley"):
        for g, members in enumerate(layout.members + [everyone]):
            key = (kind, g if g < len(layout.members) else None)
            keep = None if stored is None else functools.partial(_kept, f"{stored}-{kind}-{key[1]}")
            pools[key] = FeaturePool([(i, layout.examples[i].samples[kind]) for i in members], radius,
                                     mirror=mirror, prominence=[standing[kind][i] for i in members], keep=keep)
    return pools


#: Feature pools kept between sessions (:func:`memo_feature_pools`).
_POOLS = Memo(4, once=True)
#: Version of the pools' stored arrays: raised when what they hold changes.
POOLS_VERSION = 1


def memo_feature_pools(layout: StyleLayout, radius: float, *, mirror: bool) -> dict:
    """:func:`feature_pools`, shared with earlier sessions
    whose layout gave it the same inputs.

    A session is made for every run and every live stroke, and the pools
    (each example's standing map and its samples' prominence, about 0.3 s
    for a 1201x1201 example) depend only on the examples, never on the
    sketch.  The key holds what the pools are made of: each example's
    analysis key (by content, not identity: a tiled run over a library
    larger than the analysis memo reads analyses back from disk, and
    keyed by identity each tile made, and kept, another full set of
    pools), the detail's bytes, the style groups, the radius and the
    mirror option.  Pools are read-only once made.
    """
    key = (tuple(ex.key for ex in layout.examples), array_key(*layout.detail),
           tuple(tuple(int(i) for i in m) for m in layout.members), float(radius), bool(mirror))
    stored = f"pools-v{POOLS_VERSION}-{hashlib.sha1(repr(key).encode()).hexdigest()}"
    return _POOLS.get(key, lambda: feature_pools(layout, radius, mirror=mirror, stored=stored))


def standing_map(heights: np.ndarray, size: float) -> np.ndarray:
    """How far each cell stands above the mean of the ``size`` x ``size``
    cells around it, in standard deviations of those cells.

    In units of the surroundings' own spread, a main ridge of gentle
    country ranks with one of rugged country: strokes get their
    neighbourhood's main features without every stroke taking the
    example's most rugged ground.

    Parameters
    ----------
    heights : ndarray of float32, shape (H, W)
        The example's heights or its detail band, metres.
    size : float
        Neighbourhood side, cells (a patch).

    Returns
    -------
    ndarray of float64, shape (H, W)
        Standard deviations (negative below the surroundings).
    """
    h = heights.astype(np.float64)
    around = ndimage.uniform_filter(h, int(size) | 1, mode="reflect")
    spread = np.sqrt(np.maximum(ndimage.uniform_filter(h * h, int(size) | 1, mode="reflect") - around**2, 1e-6))
    # The centre's own height is read over a small disc so that a sample a
    # cell off its crest or floor is not demoted.
    local = ndimage.uniform_filter(h, max(3, int(size) // 16 | 1), mode="reflect")
    return (local - around) / spread


#: Where a sample's prominence is read, besides its centre: fractions of the
#: way from the centre to each crossing.
PROMINENCE_STATIONS = (0.25, 0.5, 0.75)

#: Half-width, cells, of the square in which the feature line is looked for
#: around each station (the example's line wanders off the chord).
PROMINENCE_REACH = 3


def sample_prominence(standing: np.ndarray | None, samples: list[FeatureSample], kind: str) -> np.ndarray:
    """Each sample's prominence: how far its feature stands out (up for
    ridges, down for valleys) all along its line inside the patch.

    Read at the centre and at :data:`PROMINENCE_STATIONS` on the chords
    from the centre to each crossing, each the most prominent
    :func:`standing_map` value within :data:`PROMINENCE_REACH` cells, and
    averaged.  Read at the centre
    alone, the most prominent samples were peaks and pits: a valley deep at
    the patch's centre and shallow 20 cells along, so that a painted valley
    came out as a chain of basins with sills between them.

    Parameters
    ----------
    standing : ndarray of float, shape (H, W), or None
        The example's :func:`standing_map` (None only without samples).
    samples : list of FeatureSample
    kind : {"ridge", "valley"}

    Returns
    -------
    ndarray of float, shape (len(samples),)
        Standard deviations; larger is more prominent for either kind.
    """
    if not samples:
        return np.zeros(0)
    up = standing if kind == "ridge" else -standing
    up = ndimage.maximum_filter(up, size=2 * PROMINENCE_REACH + 1, mode="nearest")
    rows, cols = up.shape
    # Every station of every sample in flat arrays: centres, then each
    # crossing's stations, with the sample each belongs to.
    centres = np.array([s.center for s in samples], dtype=float)
    owner = np.repeat(np.arange(len(samples)), [s.degree for s in samples])
    crossings = np.concatenate([s.crossings for s in samples]).astype(float)
    along = crossings - centres[owner]
    pts = np.concatenate([centres] + [centres[owner] + t * along for t in PROMINENCE_STATIONS])
    whose = np.concatenate([np.arange(len(samples))] + [owner] * len(PROMINENCE_STATIONS))
    at = np.rint(pts).astype(np.int64)
    values = up[np.clip(at[:, 0], 0, rows - 1), np.clip(at[:, 1], 0, cols - 1)]
    return np.bincount(whose, values, len(samples)) / np.bincount(whose, minlength=len(samples))


def pool_key(pools: dict, layout: StyleLayout, sample: FeatureSample, warnings: list[str], *,
             patch_size: int) -> tuple[str, int | None]:
    """The key in ``pools`` of the style under a sample; all examples' when
    that style has no feature of the kind (said once in ``warnings``)."""
    g = layout.group_at(*sample.center)
    if pools[(sample.kind, g)].size() == 0:
        note = (f"{layout.names[g]} has no {sample.kind} features for a {patch_size}-cell patch: "
                f"its sketched {sample.kind}s use the other styles' examples")
        if note not in warnings:
            warnings.append(note)
        return sample.kind, None
    return sample.kind, g


#: Example networks' stations kept between sessions (:meth:`Stations._of`).
_EXAMPLE_STATIONS = Memo(8)
#: Version of the stations' stored point index: raised when its keys change.
STATIONS_VERSION = 1


def _kept(stored: str, name: str, make, dtype) -> np.ndarray:
    """An example's station index array, stored under ``stored`` and
    mapped (:func:`~terrasynth_core.exemplars.cache.kept_array`)."""
    return cache.kept_array(f"{stored}-{name}", make, name=name, dtype=dtype)


class Stations:
    """The stations (:mod:`~terrasynth_core.features.stations`) of the
    sketch's and the examples' feature lines, each network's made when
    first asked for.

    Parameters
    ----------
    sketch : FeatureMaps
        The sketch's networks, on the output's grid.
    examples : list
        The layout's examples (their ``features``, the networks their
        samples were taken on).
    radius : float
        The patch's inscribed radius, cells.
    """

    def __init__(self, sketch: FeatureMaps, examples: list, radius: float):
        self._graphs = {("sketch", kind): getattr(sketch, kind + "s") for kind in ("ridge", "valley")}
        self._graphs.update({(i, kind): getattr(ex.features, kind + "s")
                             for i, ex in enumerate(examples) for kind in ("ridge", "valley")})
        self._keys = [ex.key for ex in examples]
        self._radius = radius
        self._made: dict = {}
        # The sketch's stations by sample: its candidates all ask for them.
        self._drawn: dict = {}

    def _of(self, key) -> LineStations:
        if key not in self._made:
            graph = self._graphs[key]
            if key[0] == "sketch":
                self._made[key] = LineStations(graph, self._radius)
            else:
                # An example's network comes from its analysis: its stations
                # are kept for later sessions, by the analysis's content key.
                keep = functools.partial(_kept, f"stations-v{STATIONS_VERSION}-{self._keys[key[0]]}-{key[1]}")
                self._made[key] = _EXAMPLE_STATIONS.get(
                    (self._keys[key[0]], key[1], float(self._radius)), lambda: LineStations(graph, self._radius,
                                                                                            keep=keep))
        return self._made[key]

    def pairs(self, sample: FeatureSample, cand: Candidate) -> tuple[np.ndarray, np.ndarray] | None:
        """The stations both the stroke and the candidate's line have
        cleanly, paired in the order of ``cand.target`` and
        ``cand.control``: shapes (m, 2) and (m, 2); None when m is 0."""
        if sample.degree != len(cand.control) - 1:
            return None  # a stand-in degree: its crossings do not pair
        key = (sample.kind, np.asarray(sample.center, float).tobytes(), cand.target.tobytes())
        drawn = self._drawn.get(key)
        if drawn is None:
            drawn = self._drawn[key] = self._of(("sketch", sample.kind)).inner(sample.center, cand.target[1:])
        found = self._of((cand.example, sample.kind)).inner(cand.center, cand.control[1:])
        both = ~(np.isnan(drawn).any(axis=1) | np.isnan(found).any(axis=1))
        return (drawn[both], found[both]) if both.any() else None


def _fits(sample: FeatureSample, cand: Candidate, stations: Stations | None) -> list[tuple[np.ndarray, np.ndarray]]:
    """Control sets to fit the candidate's spline on, most faithful first:
    with the feature lines' stations, then without them."""
    src, dst = framed(cand.target, cand.control, reflect=cand.mirrored)
    pairs = None if stations is None else stations.pairs(sample, cand)
    if pairs is None:
        return [(src, dst)]
    return [(np.vstack([src, pairs[0]]), np.vstack([dst, pairs[1]])), (src, dst)]


def prepare_feature(sample: FeatureSample, pool: FeaturePool, detail: list[np.ndarray], *,
                    shape: tuple[int, int], patch_size: int, count: int, rng: np.random.Generator,
                    usage: UsageRegistry, cap: int,
                    stations: Stations | None = None) -> tuple[tuple, list[tuple[Candidate, np.ndarray]]]:
    """Rank candidates for a sample and warp them onto its window.

    Reads only the examples, never the output, so it can run ahead on
    another thread or process.

    Parameters
    ----------
    sample : FeatureSample
    pool : FeaturePool
    detail : list of ndarray of float32
        Each example's detail heights, metres.
    shape : (rows, cols)
        Output size.
    patch_size : int
    count : int
        Candidates to rank.
    rng : numpy.random.Generator
        Random tie-breaks of the ranking.
    usage : UsageRegistry
        A snapshot of the windows used so far (taken when this preparation
        was asked for, so the result does not depend on thread timing):
        windows over ``cap`` or used by a neighbour are ranked last, those
        used a little further along pay a ranking cost.
    cap : int
        Most feature patches one example window may supply.
    stations : Stations, optional
        The feature lines' stations: a warp that also carries the
        example's line onto the stroke halfway to each crossing is used
        where it does not fold or streak.

    Returns
    -------
    bbox : (r0, r1, c0, c1)
    warped : list of (Candidate, ndarray of float32)
        Candidates whose warp stays inside their example, best first.
    rigid : bool
        Every candidate's warp would fold or stretch over
        :data:`MAX_STRETCH`: ``warped`` holds them turned rigidly onto the
        sketch (the run says so in its warnings).
    """
    bbox = patch_window(sample.center, patch_size, shape)
    r0, r1, c0, c1 = bbox
    if r1 - r0 < 4 or c1 - c0 < 4:
        return bbox, [], False
    exclude = usage.exclusion(bbox, sample.center, cap)
    # The candidates' splines mostly share the sketch's control points: the
    # window keeps what depends only on them (kernel matrices, Jacobian
    # terms), and the spline systems are kept by those points.
    window = WarpWindow((r0, c0), (r1 - r0, c1 - c0))
    warped, distorted = [], []
    crowding = usage.crowding_of(bbox, sample.center)
    for cand in pool.rank(sample, count, rng, exclude=exclude, crowding=crowding):
        for src, dst in _fits(sample, cand, stations):
            tps = ThinPlateSpline.fit(src, dst, regularization=1e-3)
            if window.distortion(tps) <= MAX_STRETCH:
                break
        else:
            distorted.append(cand)
            continue
        patch, valid = window.warp(detail[cand.example], tps, return_valid=True)
        if valid >= MIN_VALID_SHARE:
            warped.append((cand, patch))
    rigid = not warped and bool(distorted)
    if rigid:
        # Every candidate would fold or streak: turn the best ones rigidly
        # onto the sketch instead (the feature follows the stroke's chord,
        # the ground keeps its shape).
        for cand in distorted:
            tps = ThinPlateSpline.similarity(cand.target, cand.control, reflect=cand.mirrored)
            patch, valid = window.warp(detail[cand.example], tps, return_valid=True)
            if valid >= MIN_VALID_SHARE:
                warped.append((cand, patch))
    return bbox, warped, rigid


def place_feature(canvas: Canvas, sample: FeatureSample, prepared, layout: StyleLayout, *, index: int,
                  radius: float, k: int, feature_weight: float, usage: UsageRegistry,
                  cap: int, rng: np.random.Generator) -> PatchRecord | None:
    """Choose among prepared candidates by match cost, deformation and seam
    cost (one of those near the cheapest,
    :func:`~..matching.costs.pick_near_best`), and merge it into ``canvas``
    (blended).

    Parameters
    ----------
    canvas : Canvas
    sample : FeatureSample
    prepared : tuple
        What :func:`prepare_feature` returned.
    layout : StyleLayout
        Level field and reliefs.
    index : int
        The patch's index in the run's records.
    radius : float
        Inscribed-circle radius, cells: the centre disc of half of it is
        protected from later cuts.
    k : int
        Candidates (best by cost) for which the seam is computed.
    feature_weight : float
        Weight of the deformation cost.
    usage : UsageRegistry
        Every feature patch placed so far: prepared candidates whose window
        is over ``cap`` or used by a neighbour are dropped (all but the
        least used when every one is), those used a little further along
        pay its crowding cost.  The placed patch is not recorded here; the
        caller does that.
    cap : int
        Most feature patches one example window may supply.
    rng : numpy.random.Generator
        The sample's own (seeded by the run's seed and the sample).

    Returns
    -------
    PatchRecord or None
        None when no candidate survived the preparation.
    """
    bbox, warped, _ = prepared
    if not warped:
        return None
    warped = allowed(warped, usage, bbox, sample.center, cap)
    crowding = usage.crowding(*_sources(warped), bbox, sample.center)
    r0, r1, c0, c1 = bbox
    filled = canvas.filled[r0:r1, c0:c1]
    level = layout.level[r0:r1, c0:c1]
    existing = canvas.heights[r0:r1, c0:c1] - level
    relief = float(layout.relief[warped[0][0].example])
    evaluated = []
    for (cand, patch), crowded in zip(warped, crowding):
        weight = float(layout.anchor[cand.example])
        ssd, offset = settle(*overlap_ssd(existing, patch, filled), weight=weight)
        score = (match_cost(ssd, offset, relief, weight) + feature_weight * cand.deformation + cand.plainness
                 + crowded)
        evaluated.append((score, ssd, offset, patch, cand))
    evaluated.sort(key=lambda t: t[0])
    rr, cc = np.ogrid[r0:r1, c0:c1]
    keep_new = (rr - sample.center[0]) ** 2 + (cc - sample.center[1]) ** 2 <= (radius / 2) ** 2

    def seam(option):
        _, _, offset, patch, _ = option
        placed = patch + np.float32(offset) + level
        cut = canvas.cut(bbox, placed, keep_new=keep_new, relief=relief)
        return cut.normalized_cost, (placed, cut)

    total, (_, ssd, _, _, cand), (patch, cut) = choose_near_best(((e[0], e) for e in evaluated[:k]), seam, rng)
    canvas.place(bbox, patch, cut, index, protect=keep_new & cut.take_new)
    canvas.blend(bbox)
    return PatchRecord(sample.patch_type, sample.kind, bbox, cand.example,
                       (float(cand.center[0]), float(cand.center[1])), cand.mirrored,
                       cand.deformation, ssd, cut.normalized_cost, total)


def allowed(warped: list, usage: UsageRegistry, bbox, centre, cap: int) -> list:
    """The prepared candidates the full registry allows (order kept); when
    it allows none, those of the least penalty (least used)."""
    penalty = usage.penalties(*_sources(warped), bbox, centre, cap)
    least = penalty.min()
    return [w for w, p in zip(warped, penalty) if p == least]


def all_excluded(prepared, usage: UsageRegistry, centre, cap: int) -> bool:
    """Whether the full registry excludes every candidate of a preparation
    (:func:`prepare_feature`'s result; False without candidates)."""
    bbox, warped, _ = prepared
    return bool(warped) and bool(usage.penalties(*_sources(warped), bbox, centre, cap).min() >= 1)


def _sources(warped: list) -> tuple[np.ndarray, np.ndarray]:
    """The example and sample centre of each prepared candidate."""
    return (np.array([c.example for c, _ in warped]),
            np.array([c.center for c, _ in warped], dtype=float).reshape(-1, 2))


def place_stamp(canvas: Canvas, stamp, level: np.ndarray, *, index: int, stamp_index: int) -> PatchRecord:
    """Put a rendered stamp on the level field (pasted: it is the reference
    the terrain around it adapts to), its core protected from later cuts.

    Parameters
    ----------
    canvas : Canvas
    stamp : RenderedStamp
    level : ndarray of float32, shape (rows, cols)
        The level field, metres.
    index : int
        The patch's index in the run's records.
    stamp_index : int
        The stamp's index in the controls (kept in the record's source).
    """
    r0, r1, c0, c1 = bbox = stamp.bbox
    patch = stamp.detail + level[r0:r1, c0:c1]
    take = stamp.valid & ~canvas.locked[r0:r1, c0:c1]
    canvas.place(bbox, patch, Cut(take, np.zeros(take.shape, bool), 0.0), index, protect=stamp.core & take)
    canvas.blend(bbox)
    return PatchRecord("stamp", None, bbox, -1, (float(stamp_index), 0.0), False, 0.0, 0.0, 0.0, 0.0)
