"""Fill patches (paper §4.2): the example windows that best continue the
terrain already in an output window, chosen by match cost plus seam cost."""

from __future__ import annotations

import numpy as np

from ..controls.layout import StyleLayout
from ..matching.costs import ROUGHNESS_WEIGHT, choose_near_best, match_cost, settle
from ..matching.fill_search import FillSearch
from ..memo import Memo, array_key
from ..placing.canvas import Canvas
from .params import SynthesisParams
from .result import PatchRecord


def fill_searches(layout: StyleLayout, params: SynthesisParams) -> list[FillSearch | None]:
    """One indexed search per example a style group on the output uses
    (None for the others: nothing asks them)."""
    used = {int(g) for g in np.unique(layout.group_map)}
    size = (params.patch_size, params.patch_size)
    return [
        _search(detail, size, ex.strong_mask, params.coarse_factor_for(detail.shape), params.overlap_cells,
                None if ex.valid is None else ~ex.valid)
        if any(i in layout.members[g] for g in used) else None
        for i, (ex, detail) in enumerate(zip(layout.examples, layout.detail))
    ]


#: Searches kept between sessions, by what they are made of.  The app makes
#: a session per run and per live stroke, and a search's set-up (the
#: windows on offer, their roughness prior, the indexes it has loaded) does
#: not change with the sketch: 0.4 s a stroke saved.
_SEARCHES = Memo(4, once=True)


def _search(detail: np.ndarray, window: tuple[int, int], feature_mask, coarse: int, overlap: int,
            void_mask=None) -> FillSearch:
    """A :class:`FillSearch`, shared with earlier sessions when its inputs
    are the same bytes (searches are read-only once made)."""
    return _SEARCHES.get((array_key(detail, feature_mask, void_mask), window, coarse, overlap),
                         lambda: FillSearch(detail, window, feature_mask=feature_mask, coarse_factor=coarse,
                                            overlap=overlap, void_mask=void_mask))


#: Examples a fill window is searched in at most.  Every example of a
#: style was searched for every window, so a window's time, and the pages
#: of the library it reads, grew with the library (a 1024x1024 run in
#: tiles: 15 s on 2 DEMs, 62-68 s on 20).  Past this many, a window is
#: searched in those of :data:`PROBED_EXAMPLES` with its nearest windows.
#: The built-ins' styles have fewer: their runs are unchanged.
SEARCHED_EXAMPLES = 8

#: Examples whose indexes are asked for a window's nearest windows: those
#: whose index centres come nearest to it (each index's centres asked
#: once, a few kB), so a window reads the lists of this many examples
#: however large the library.
PROBED_EXAMPLES = 2 * SEARCHED_EXAMPLES


def _nearest_examples(searches: list, members: list[int], target: np.ndarray, filled: np.ndarray
                      ) -> tuple[list[int], dict]:
    """The examples to search for this window (``filled`` not empty), in
    ``members``' order, and their shortlists: of the :data:`PROBED_EXAMPLES`
    whose indexes' centres come nearest to it, those whose indexes hold its
    nearest windows, :data:`SEARCHED_EXAMPLES` in all, and every example
    too small for an index (scored whole); however many of those there
    are, at least half as many indexed ones.

    First by the centres: asking every example's index for its nearest
    windows read a few megabytes of each one's lists per
    window, so a process's resident pages grew with the library (a tiled
    worker over 32 DEMs, its mapped pages handed back past the budget
    after every window: 1.1 GB against 0.8 over 20).
    """
    zones = {ei: searches[ei].zone_index(filled) for ei in members}
    indexed = [ei for ei in members if zones[ei] is not None]
    small = [ei for ei in members if zones[ei] is None]
    room = max(SEARCHED_EXAMPLES - len(small), SEARCHED_EXAMPLES // 2)
    vectors = {ei: zones[ei].query_vector(target, filled) for ei in indexed}  # (each index's own axes)
    # (Ties go to the earlier example: the same choice on every process.)
    asked = sorted(indexed, key=lambda ei: (zones[ei].cluster_distance(vectors[ei]), ei))[:PROBED_EXAMPLES]
    found = {ei: zones[ei].search(vectors[ei], searches[ei].shortlist, distances=True) for ei in asked}
    nearest = {ei: float(dist[0]) if dist.size else float("inf") for ei, (_, dist) in found.items()}
    kept = set(sorted(asked, key=lambda ei: (nearest[ei], ei))[:room]) | set(small)
    chosen = [ei for ei in members if ei in kept]
    return chosen, {ei: None if ei in small else found[ei][0] for ei in chosen}


def window_examples(layout: StyleLayout, bbox) -> tuple[list[int], float]:
    """Examples of the styles present in a window, and their largest relief."""
    r0, r1, c0, c1 = bbox
    groups = np.unique(layout.group_map[r0:r1, c0:c1])
    members = sorted({i for g in groups for i in layout.members[int(g)]})
    return members, float(max(layout.relief[i] for i in members))


def search_fill(searches: list, detail: list[np.ndarray], anchor: np.ndarray, members: list[int], relief: float,
                target: np.ndarray, filled: np.ndarray, rng: np.random.Generator, *,
                patch_size: int, k: int) -> list[tuple]:
    """Candidate example windows for one output window, best first.

    Parameters
    ----------
    searches : list of FillSearch or None
        Per example (see :func:`fill_searches`).
    detail : list of ndarray of float32
        Each example's detail heights, metres.
    anchor : ndarray of float, shape (n_examples,)
        Each example's shift weight (``StyleLayout.anchor``).
    members : list of int
        The window's examples: all are searched, or, past
        :data:`SEARCHED_EXAMPLES`, those nearest to it
        (:func:`_nearest_examples`).
    relief : float
        Cost unit, metres.
    target : ndarray of float32, shape (patch_size, patch_size)
        The output window minus the level field, metres.
    filled : ndarray of bool, shape (patch_size, patch_size)
    rng : numpy.random.Generator
        Random tie-breaks of the searches.
    patch_size, k : int
        Window side; candidates kept per example and in all.

    Returns
    -------
    list of (cost, ssd, offset, example, (row, col), relief)
        At most ``k``, cheapest first.
    """
    options = []
    shortlists = dict.fromkeys(members)
    if len(members) > SEARCHED_EXAMPLES and filled.any():
        members, shortlists = _nearest_examples(searches, members, target, filled)
    for ei in members:
        for pos, ssd, offset, prior in searches[ei].best(target, filled, k, rng, shortlist=shortlists[ei]):
            # Fill windows are anchored by their mean level: the search
            # favours some parts of an example (often its smooth valley
            # floors), and a region built from them would sit below its
            # style's level.  Feature patches keep their own level, so
            # sketched ridges still stand above their surroundings.
            er, ec = pos
            mean = float(detail[ei][er:er + patch_size, ec:ec + patch_size].mean())
            weight = float(anchor[ei])
            ssd, offset = settle(ssd, offset, mean, weight)
            cost = match_cost(ssd, offset + mean, relief, weight) + ROUGHNESS_WEIGHT * prior
            options.append((cost, ssd, offset, ei, pos, relief))
    options.sort(key=lambda t: t[0])
    return options[:k]


def choose_fill(canvas: Canvas, bbox, options: list[tuple], detail: list[np.ndarray], level: np.ndarray, *,
                index: int, patch_size: int, rng: np.random.Generator) -> PatchRecord:
    """Pick among searched candidates by match cost plus seam cost (one of
    those near the cheapest, :func:`~..matching.costs.pick_near_best`) and
    merge it into ``canvas`` (the caller blends it).

    Parameters
    ----------
    canvas : Canvas
    bbox : (r0, r1, c0, c1)
    options : list of tuple
        What :func:`search_fill` returned.
    detail : list of ndarray of float32
        Each example's detail heights, metres.
    level : ndarray of float32, the canvas's shape
        The level field, metres.
    index : int
        The patch's index in the run's records.
    patch_size : int
    rng : numpy.random.Generator
        The window's own (seeded by the run's seed and the window).
    """
    r0, r1, c0, c1 = bbox
    level = level[r0:r1, c0:c1]

    def seam(option):
        _, _, offset, ei, (er, ec), relief = option
        patch = detail[ei][er:er + patch_size, ec:ec + patch_size] + np.float32(offset) + level
        cut = canvas.cut(bbox, patch, relief=relief)
        return cut.normalized_cost, (patch, cut)

    total, (_, ssd, _, ei, pos, _), (patch, cut) = choose_near_best(((o[0], o) for o in options), seam, rng)
    canvas.place(bbox, patch, cut, index)
    return PatchRecord("fill", None, bbox, ei, (float(pos[0]), float(pos[1])), False, 0.0, ssd,
                       cut.normalized_cost, total)
