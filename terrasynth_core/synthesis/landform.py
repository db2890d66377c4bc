"""The landform pass: structure bigger than a patch, coarse to fine.

A patch of the full-resolution pass spans one hillside; on its own it
cannot place the example's main ridges and valleys, many patches long, with
their spurs and tributaries.  So a run first synthesizes the same problem
(the sketch, the styles, the same method) on a grid two to four times
coarser (:data:`FACTORS`), where a patch spans whole landforms and the strokes are matched to
the example's main features.  That coarse terrain, brought back to the
output's size and low-passed, becomes the level field: the full-resolution
pass copies only the examples' detail *above* that level (each example minus
the same low-pass of itself), so the two passes add up to every scale of the
example, like two levels of a Laplacian pyramid.

References
----------
Zhou et al. 2007 synthesize at one scale; multi-resolution synthesis of this
kind follows Wei and Levoy, "Fast Texture Synthesis using Tree-structured
Vector Quantization", SIGGRAPH 2000, and Lefebvre and Hoppe, "Parallel
Controllable Texture Synthesis", SIGGRAPH 2005.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from scipy import interpolate, ndimage

from ..controls.levels import steer_level
from ..controls.options import Controls
from ..controls.water import smoothstep
from ..errors import ParamsError
from ..features.network import graph_mask
from ..features.sketch import sketch_features
from ..heightfield import HeightField
from ..exemplars.mapped_pages import checked
from ..exemplars.prepare import WIDE_VOIDS
from ..measures import surface_gradient
from ..placing.windows import estimate_fill_count
from .finish import within_examples_range
from .workers import running

if TYPE_CHECKING:
    from ..features.graph import FeatureMaps
    from .session import Session

#: Down-samplings of the landform pass (output and examples alike), most
#: preferred first: the largest one the examples are big enough for.
FACTORS = (4, 3, 2)

#: Ground a coarse patch spans, in full-resolution patch sizes.
COARSE_SPAN = 2.0

#: Smallest coarse patch, in coarse cells: below it a coarse patch holds too
#: little of a landform to be matched.
MIN_COARSE_PATCH = 24

#: Smallest example side at the coarse grid, in coarse patches: the coarse
#: pass needs a few windows to choose from.
MIN_EXAMPLE_PATCHES = 1.5

#: Fewest landform-scale feature samples (of each kind the sketch has) the
#: coarse examples must hold.
MIN_COARSE_SAMPLES = 4

#: Fewest coarse fill windows for which the pass uses worker processes
#: that are still starting: about 1.5 s of fill at 5 ms a window, which
#: outlasts a fresh worker's imports.  Measured in fresh processes: at
#: 1000x1000 (71 windows) the pass took as long either way; at 2000x2000
#: (about 300) 7.5-8.4 s in one process against 6.7-7.1 s.
COARSE_PARALLEL_WINDOWS = 256

#: Standard deviation of the low-pass that splits landform from detail, in
#: full-resolution patch sizes.  Its half-power wavelength is about 5.3
#: sigma, a little more than a patch: wavelengths a patch cannot hold come
#: from the landform pass, shorter ones from the patches.
SPLIT_SIGMA = 0.2


@dataclass(frozen=True)
class Landform:
    """The landform pass's outcome.

    Parameters
    ----------
    level : ndarray of float32, shape (rows, cols)
        Coarse terrain at the output's size, low-passed
        (:func:`landform_lowpass`), metres: bent through the pins, flat
        under stamps, and in a re-synthesis the previous terrain's outside
        the selection.
    sigma : float
        The low-pass's standard deviation, output cells: the examples'
        detail is each example minus the same low-pass of itself.
    coarse : SynthesisResult
        The coarse run (for inspection and the tests).
    factor : int
        The coarse grid's down-sampling.
    """

    level: np.ndarray
    sigma: float
    coarse: object
    factor: int


def split_sigma(patch_size: int) -> float:
    """The landform/detail split's Gaussian standard deviation, cells."""
    return SPLIT_SIGMA * patch_size


def coarse_patch(patch_size: int, factor: int) -> int:
    """The landform pass's patch size in coarse cells."""
    return max(MIN_COARSE_PATCH, int(round(COARSE_SPAN * patch_size / factor)))


def coarse_factor(patch_size: int, smallest: int) -> int | None:
    """The landform pass's down-sampling for examples whose smallest side
    is ``smallest`` cells: the largest of :data:`FACTORS` at which that side
    still holds :data:`MIN_EXAMPLE_PATCHES` coarse patches (None: none)."""
    for f in FACTORS:
        if smallest // f >= MIN_EXAMPLE_PATCHES * coarse_patch(patch_size, f):
            return f
    return None


def landform_pass(session: Session) -> tuple[Landform | None, str | None]:
    """Synthesize the session's problem on a coarse grid, in one call (see
    :func:`coarse_session` and :func:`landform_from`).

    Returns
    -------
    landform : Landform or None
        None when the pass cannot serve (see :func:`coarse_session`).
    note : str or None
        Why the pass was skipped, for the run's warnings.
    """
    coarse, f, note = coarse_session(session)
    if coarse is None:
        return None, note
    return landform_from(session, coarse.run(), f), None


def coarse_session(session: Session) -> tuple[Session | None, int, str | None]:
    """The landform pass's session: the same problem on a grid ``f`` times
    coarser.

    Parameters
    ----------
    session : Session
        The full-resolution session (its examples already at the run's
        cell size); :func:`coarse_session_for` takes its parts one by one.

    Returns
    -------
    coarse : Session or None
        None when the pass cannot serve: several style regions, the output
        or an example too small for coarse patches, or coarse examples
        lacking a feature kind the sketch has.
    factor : int
        The down-sampling (0 when ``coarse`` is None).
    note : str or None
        Why the pass was skipped, for the run's warnings.
    """
    return coarse_session_for(session.params, session.layout, session.shape, session.controls, session.n_plain,
                              session.sketch, session.sketch_maps)


def coarse_session_for(params, layout, shape: tuple[int, int], controls: Controls, n_plain: int, sketch,
                       sketch_maps) -> tuple[Session | None, int, str | None]:
    """:func:`coarse_session` from the parts of a session: for a map no
    session is made for (a tiled run's whole map).

    Parameters
    ----------
    params : SynthesisParams
    layout : StyleLayout
        The examples' layout at the run's cell size.
    shape : (rows, cols)
        The output's size.
    controls : Controls
    n_plain : int
        How many of ``layout.examples`` are plain examples (the rest are
        the styles' own).
    sketch : SketchMap or None
        The painted sketch, any size (scaled to the coarse grid).
    sketch_maps : FeatureMaps
        Its ridge and valley graphs (which feature kinds the pass needs).
    """
    p, lay, c = params, layout, controls
    rows, cols = shape
    if len(lay.members) > 1:
        # Measured on the Middle-earth map, a coarse pass over several
        # styles let regions stray from their own heights (with the range
        # squeeze of the time; the height fit is global too, not per
        # region) and drowned more lowland.
        return None, 0, ("landform pass not used with several style regions: each region is built on its own "
                         "flat level")
    smallest = min(min(ex.heights.shape) for ex in lay.examples)
    f = coarse_factor(p.patch_size, smallest)
    if f is None:
        need = int(np.ceil(MIN_EXAMPLE_PATCHES * coarse_patch(p.patch_size, FACTORS[-1]) * FACTORS[-1]))
        return None, 0, (f"landform pass skipped: an example is only {smallest} cells across at "
                         f"{_cells(lay.cell_size)}; structure larger than a patch needs {need}: a larger example, "
                         "a coarser --cell-size or a smaller patch would help")
    pc = coarse_patch(p.patch_size, f)
    grid = (-(-rows // f), -(-cols // f))
    if min(grid) < pc:
        return None, 0, None  # the whole output is about one landform: nothing to structure
    cell = None if lay.cell_size is None else lay.cell_size * f
    fields = [_coarsened(ex.heights, f, cell, ex.valid) for ex in checked(lay.examples)]
    styles = tuple(replace(s, example=fields[n_plain + i]) for i, s in enumerate(c.styles))
    style_map = None if c.style_map is None else c.style_map[::f, ::f]
    coarse_controls = Controls(styles=styles, style_map=style_map, height_range=c.height_range)
    coarse_params = replace(p, patch_size=pc, overlap=None, cell_size=cell, drainage=False, landform=False,
                            workers=1)
    # The run's worker processes when they are up and warm already (a
    # process that has run before: the app's next run) or the coarse fill
    # is long enough to outlast their start; else this one alone (a fresh
    # process's workers are still importing).  The result does not depend
    # on it.
    if running(p.thread_count) or estimate_fill_count(
            grid, pc, overlap=coarse_params.overlap_cells, n_features=0) >= COARSE_PARALLEL_WINDOWS:
        coarse_params = replace(coarse_params, workers=p.thread_count)
    coarse_sketch = None if sketch is None else sketch.resized(grid)
    from .session import Session  # the pass is a session of its own
    try:
        coarse = Session(fields[:n_plain], coarse_sketch, shape=grid, params=coarse_params, controls=coarse_controls)
    except ParamsError as exc:
        # (Its sizes are the coarse grid's: said so, or a hole DEM's note
        # would name a patch size the run does not have.)
        return None, 0, (f"landform pass skipped: at its scale (the examples down-sampled {f}x, a patch of {pc} "
                         f"coarse cells spanning {pc * f} of the run's cells) {exc}")
    for graph in (sketch_maps.ridges, sketch_maps.valleys):
        have = sum(len(ex.samples[graph.kind]) for ex in coarse.examples)
        if graph.paths and have < MIN_COARSE_SAMPLES:
            # Every stroke would be built from the same one or two
            # landforms, chained patch after patch: a repeated, drifting
            # cross-section rather than structure.
            return None, 0, (f"landform pass skipped: the examples hold only {have} {graph.kind}(s) at the "
                             f"landform scale ({pc * f} cells); a larger or more varied example would give "
                             "structure larger than a patch")
    return coarse, f, None


def landform_from(session: Session, coarse, f: int) -> Landform:
    """The level field of ``session`` from the coarse run's result.

    Parameters
    ----------
    session : Session
        The full-resolution session.
    coarse : SynthesisResult
        What :func:`coarse_session`'s session gave.
    f : int
        Its down-sampling.
    """
    p, lay, c = session.params, session.layout, session.controls
    heights = coarse.heights
    sigma = split_sigma(p.patch_size)
    weight = coherence(coarse.sketch_features, p.patch_size, f)
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="terrasynth-landform") as pool:
        # The weights' up-sampling reads nothing the fit makes: beside it
        # (zoom releases the interpreter lock; 1.8 s of a 4000x4000 run's).
        weight_up = None if weight is None else pool.submit(_upsampled, weight, session.shape)
        if c.height_range is None:  # (a height range maps the result onto itself at the end)
            heights = fitted_to_examples(heights, lay, f, sigma, coarse.sketch_features)
        up = _upsampled(heights, session.shape)
        level = landform_lowpass(up, sigma, None if weight_up is None else weight_up.result())
    return Landform(_settled(session, level, sigma), sigma, coarse, f)


def _settled(session: Session, level: np.ndarray, split: float) -> np.ndarray:
    """``level`` as the run uses it: bent through the pins (in a
    re-synthesis, the previous terrain's level outside the selection, its
    low-pass at ``split``, the examples' landform/detail split, so that
    the detail the patches add is not there twice) and flat under the
    stamps."""
    c, p, lay = session.controls, session.params, session.layout
    if c.selection is not None:
        # A re-synthesis keeps the landforms it does not select: the level
        # follows the previous terrain outside the selection and moves to
        # the new landforms over about a patch inside it.
        previous = ndimage.gaussian_filter(c.previous.astype(np.float64), split, mode="reflect")
        weight = smoothstep(ndimage.distance_transform_edt(c.selection) / max(p.patch_size / 4, 1.0))
        level = (previous + weight * (level - previous)).astype(np.float32)
    else:
        level = steer_level(level, c.pins, p.patch_size)
    return level_under_stamps(level, lay.stamps, p.patch_size)


#: The landform/detail split of a run whose landform pass cannot serve, in
#: split sigmas (:func:`split_sigma`): its examples give their detail above
#: this low-pass, and the drawing's landforms (:func:`drawn_landforms`) the
#: rest.  Three times the pass's split, so that patches keep their
#: examples' landforms up to about one and a half patches (wider ones the
#: drawing places).  On a 187x152 DEM of the Rocky Mountains (12 runs) the
#: relief is 0.84-0.99 of the example's and the power at 16-64 cells
#: 0.81-1.19 of its; at the pass's own split (6 runs), 0.93 and 0.25-0.43.
DRAWN_SPLIT = 3.0

#: What a run's skipped-pass warning adds when the drawing gives the landforms.
DRAWN_NOTE = "; the regional relief follows the drawing alone"

#: Grid cells per fade sigma (twice :data:`TREND_SIGMA` splits) of the grid
#: :func:`drawn_landforms` fits on: the blur of :func:`_stroke_regions`
#: (an eighth of the fade) spans two of its cells, and so does the split's
#: sigma (the fit's finest scale; half as many on the landform pass's
#: coarse grid at 80-cell patches).  At 32 a 32-cell patch's fit ran on the output's own
#: grid: 7.2 s for a 1000x1000 output, 0.47 s at 16.
DRAWN_CELLS_PER_SIGMA = 16


def drawn_split(patch_size: int) -> float:
    """The detail split of a run without the landform pass
    (:data:`DRAWN_SPLIT`), output cells."""
    return DRAWN_SPLIT * split_sigma(patch_size)


def drawn_level(session: Session) -> np.ndarray | None:
    """The level field of the drawing alone, for a run whose landform pass
    cannot serve: :func:`drawn_landforms` brought to the output and
    low-passed as the pass's terrain, bent through the pins and flat under
    the stamps.  The run then copies its examples' detail above
    :func:`drawn_split`.

    Before, patches kept their examples' whole heights and the drawing
    only tilted the ground they stood on: on small examples the strokes
    were lost among the patches' own landforms (a 187x152 DEM of the Rocky
    Mountains, four seeds: 17-21 % of the Y-junction's ridge cells below
    the output's median; now none) and, with chained copies of a
    volcano's flanks, a valley sat at the median height (St. Helens at
    80-cell patches: the S-valley at the 0.44 height percentile; now
    0.13-0.16).

    Returns
    -------
    ndarray of float32, shape ``session.shape``, or None
        None where :func:`drawn_landforms` is.
    """
    drawn = drawn_landforms(session.sketch, session.shape, session.layout, session.params.patch_size)
    if drawn is None:
        return None
    level = landform_lowpass(_upsampled(drawn[0], session.shape), split_sigma(session.params.patch_size))
    return _settled(session, level.astype(np.float32), drawn_split(session.params.patch_size))


def drawn_landforms(sketch, shape: tuple[int, int], layout, patch_size: int) -> tuple[np.ndarray, int] | None:
    """The drawing's landforms on a coarse grid: a flat level raised about
    the sketch's ridges and lowered about its valleys, fitted to the
    examples' heights as the landform pass fits its coarse terrain
    (:func:`fitted_to_examples`).

    Parameters
    ----------
    sketch : SketchMap or None
        The painted sketch, any size (scaled to the grid).
    shape : (rows, cols)
        The output's size; the grid spans it.
    layout : StyleLayout
        Before the split (its detail the examples' whole heights).
    patch_size : int

    Returns
    -------
    heights : ndarray of float32, shape (ceil(rows / f), ceil(cols / f))
        Metres.
    f : int
        The grid's down-sampling.
    None without strokes, or with several style groups (each stands on
    its own flat level, as with the landform pass).
    """
    if sketch is None or not sketch.has_strokes or len(layout.members) > 1:
        return None
    rows, cols = shape
    sigma = split_sigma(patch_size)
    f = max(1, int(2 * TREND_SIGMA * sigma // DRAWN_CELLS_PER_SIGMA))
    grid = (-(-rows // f), -(-cols // f))
    strokes = sketch_features(sketch.resized(grid))
    if not (strokes.ridges.paths or strokes.valleys.paths):
        return None
    flat = np.full(grid, float(np.median(layout.level)), np.float32)
    # (Fitted with the detail the run will add: above the wider split.)
    return fitted_to_examples(flat, layout, f, sigma, strokes, detail_sigma=drawn_split(patch_size)), f


def level_under_stamps(level: np.ndarray, stamps, patch_size: int) -> np.ndarray:
    """The level field made flat under each stamp's core.

    A stamp is a landmark the artist placed as it is: it stands on the
    landform's mean height there instead of being tilted by it; the level
    returns to the landform around it, smoothly (no step where the core
    ends), over half a patch or, where the landform lies far above or
    below the stamp, as far as keeps the ramp no steeper than the
    landform's own steep slopes (its 99th percentile), up to two patches.
    Within a patch of the stamp, the steepest slope was 1.7 to 7.0 times
    the steepest beyond two patches (four seeds) when the level eased over
    half a patch alone: a moat or a wall around the stamp; 0.7 to 2.3
    times now (the cap and the landform's own slopes there).

    Parameters
    ----------
    level : ndarray of float32, shape (rows, cols)
    stamps : sequence of RenderedStamp
    patch_size : int

    Returns
    -------
    ndarray of float32, shape (rows, cols)
    """
    if not stamps:
        return level
    # The landform's steep slopes, read before any stamp flattens it.
    steep = float(np.percentile(np.hypot(*surface_gradient(level)[:2]), 99))
    for st in stamps:
        r0, r1, c0, c1 = st.bbox
        core = np.zeros(level.shape, bool)
        core[r0:r1, c0:c1] = st.core
        if not core.any():
            continue
        mean = float(level[core].mean())
        dist = ndimage.distance_transform_edt(~core)
        reach = max(patch_size / 2, 1.0)
        for _ in range(2):  # the rise over a wider ring can be larger: look once more
            rise = float(np.abs(level[dist <= reach] - mean).max())
            # smoothstep's steepest slope is 1.5 / reach of the rise.
            reach = float(np.clip(1.5 * rise / steep if steep > 0 else reach, patch_size / 2, 2 * patch_size))
        # 1 on the core, easing to 0 over ``reach`` around it.
        weight = 1.0 - smoothstep(dist / max(reach, 1.0))
        level = (level + weight * (mean - level)).astype(np.float32)
    return level


def fitted_to_examples(heights: np.ndarray, layout, f: int, sigma: float,
                    strokes: FeatureMaps | None = None, detail_sigma: float | None = None) -> np.ndarray:
    """The coarse terrain with the examples' heights: its regional relief
    fitted so that, with the examples' detail on it, its heights take the
    examples' distribution.

    Chained patches carry the coarse terrain up or down a little at each
    step (a ridge that climbs in its example climbs again in the next
    patch), and a coarse output smaller than its example holds only part of
    the example's range of landforms: left alone, the terrain drifted out
    of the examples' heights (Gabon's plateau sank 230 m, St. Helens rose
    380 m) and spanned 0.6-0.8 of their relief (p0.5 to p99.5).

    The fit moves only the largest scales: the change a monotone map of
    heights (:func:`fitted_heights`) asks for is low-passed to wavelengths
    beyond a few patches (:data:`TREND_SIGMA`), so the landforms' own
    shapes and the spectrum up to them stay as synthesized; low-passed, the
    change falls short of the map, so :data:`FIT_ROUNDS` rounds close in.
    What is fitted is the level (the terrain's :func:`landform_lowpass`)
    plus a fixed draw of the examples' detail, what the full-resolution
    pass will add to it, against the examples' heights as ``layout`` places
    them (its group's base height plus its heights about their median).
    (The pass runs with one style group; were there several, each would
    weigh as the share of the output it covers, its examples alike.)

    Parameters
    ----------
    heights : ndarray of float32, shape (h, w)
        The coarse terrain, metres.
    layout : StyleLayout
        Before the split: its detail is each example's heights about its
        median, its level the groups' base heights.
    f : int
        The coarse pass's down-sampling.
    sigma : float
        The split's standard deviation (:func:`split_sigma`), output cells.
    strokes : FeatureMaps, optional
        The sketch's features on the coarse grid: the regions about its
        ridges are raised and those about its valleys lowered
        (:data:`UPLIFT`) before the fit, so that the regional relief
        follows the drawing, and each round holds the ridges high and the
        open valleys low along their whole length (:class:`_StrokeSides`).
    detail_sigma : float, optional
        The split above which the run takes the examples' detail, output
        cells: ``sigma`` unless given (:func:`drawn_landforms` gives its
        wider one).

    Returns
    -------
    ndarray of float32, shape (h, w)
    """
    detail_sigma = (sigma if detail_sigma is None else detail_sigma) / f
    sigma = sigma / f
    groups, cover = np.unique(layout.group_map, return_counts=True)
    # A library's cells are read one in ``step`` (evenly), so the fit's
    # arrays stay bounded however many examples there are.
    shapes = [(d.shape[0] // f, d.shape[1] // f) for d in layout.detail]
    total = sum(s[0] * s[1] if ex.valid is None else int(_valid_blocks(ex.valid, f, s).sum())
                for ex, s in zip(layout.examples, shapes))
    step = max(1, -(-total // FIT_EXAMPLE_CELLS))
    values, details, weights = [], [], []
    lowest, highest = np.inf, -np.inf  # the examples' landforms
    for g, n in zip(groups, cover):
        base = float(np.median(layout.level[layout.group_map == g]))
        members = layout.members[int(g)]
        for i in checked(members):
            coarse = _coarsened(layout.detail[i], f, None).heights.astype(np.float64)
            # (Only the example's valid blocks: its filled voids are no landform.)
            valid = _valid_blocks(layout.examples[i].valid, f, coarse.shape)
            valid = np.ones(coarse.size, bool) if valid is None else valid.ravel()
            # (Compact copies: a strided view would keep the example's
            # every cell alive, and the fit's arrays would grow with the library.)
            values.append(np.ascontiguousarray((coarse + base).ravel()[valid][::step]))
            landform = (landform_lowpass(coarse, sigma) + base).ravel()[valid]
            lowest, highest = min(lowest, float(landform.min())), max(highest, float(landform.max()))
            details.append(np.ascontiguousarray(
                (coarse - ndimage.gaussian_filter(coarse, detail_sigma, mode="reflect")).ravel()[valid][::step]))
            weights.append(np.full(len(values[-1]), n / (len(members) * len(values[-1]))))
    values, details, weights = np.concatenate(values), np.concatenate(details), np.concatenate(weights)
    target = _weighted_quantiles(values, weights, FIT_QUANTILES)
    # The quantiles are read on at most FIT_SAMPLES cells, evenly spread
    # (a world-size coarse grid would hold gigabytes of draws), each with
    # the detail it will carry: a fixed draw (the same bytes every run)
    # from the examples' own.
    cells = np.linspace(0, heights.size - 1, min(heights.size, FIT_SAMPLES)).astype(np.int64)
    detail = details[np.random.default_rng(0).choice(len(details), size=len(cells), p=weights / weights.sum())]
    h = np.asarray(heights, dtype=np.float64)
    sides = None
    if strokes is not None:
        near = _StrokeDistances(strokes, h.shape)
        spread = float(target[3] - target[1])  # (the interquartile range: FIT_QUANTILES[1] and [3])
        h = h + UPLIFT * spread * _stroke_regions(near, 2 * TREND_SIGMA * sigma)
        sides = _StrokeSides(near, TREND_SIGMA * sigma)
    for _ in range(FIT_ROUNDS):
        if sides is not None:
            # (Before the fit's own step, so each round ends fitted.)
            h = h + FIT_STEP * sides.correction(landform_lowpass(h, sigma).astype(np.float64))
        low = landform_lowpass(h, sigma).astype(np.float64)
        change = fitted_heights(low, np.quantile(low.ravel()[cells] + detail, FIT_QUANTILES), target) - low
        h = h + FIT_STEP * ndimage.gaussian_filter(change, TREND_SIGMA * sigma, mode="reflect")
    # The level is a landform: it stays within the heights of the examples'
    # own landforms (the same low-pass of them), eased in by the finish's
    # knee.  The fit matches the distribution, not its ends: on the
    # plateau, the lowered region about a valley sank 84 m below the
    # example's lowest landform, and the detail on it below the examples'
    # range, where the finish's knee flattened a 40-70 m deep valley to a
    # plain at sea level.
    low = landform_lowpass(h, sigma).astype(np.float64)
    h = h + (within_examples_range(low, lowest, highest) - low)
    return h.astype(np.float32)


#: Standard deviation of the low-pass of the fit's change, in split sigmas
#: (:data:`SPLIT_SIGMA`): 0.8 patch sizes, half amplitude at wavelengths of
#: about 4.3 patches (340 cells for 80-cell patches), a ten-thousandth of
#: the power at 1.6 patches (0.6 patch sizes took the 64-128-cell band of
#: 30 runs from 1.02 to 1.39 of the examples' power, this to 1.24).
TREND_SIGMA = 4.0

#: Regional rise about the sketch's ridges (fall about its valleys) before
#: the fit, in interquartile ranges of the examples' heights where a
#: stroke runs (:func:`_stroke_regions` is +-1 there).  Fitted alone, the
#: regional relief followed the coarse terrain wherever it stood high, not
#: the drawing.  On 30 runs (seeds 0-1, BFS), with valleys signed as
#: valleys: 0.2 put valley strokes in the bottom quarter of heights in 12
#: of 20 runs (from 9) and ridges in the top quarter in 28 of 30 (from
#: 27); 0.3 moved them little further (0.225 mean valley percentile
#: against 0.256) but raised the 64-128-cell power to 1.47 of the
#: examples' (1.33 at 0.2; the drawing's own relief at that scale).
UPLIFT = 0.2


class _StrokeDistances:
    """The sketch's ridge and valley cells on a grid, and every cell's
    distance to each kind (cells; a kind with no strokes lies farther
    than any cell).

    Parameters
    ----------
    strokes : FeatureMaps
    shape : (h, w)

    Attributes
    ----------
    ridges, valleys : ndarray of bool, shape ``shape``
    to_ridge, to_valley : ndarray of float64, shape ``shape``
    """

    def __init__(self, strokes: FeatureMaps, shape: tuple[int, int]):
        far = float(shape[0] + shape[1])
        self.ridges, self.valleys = (graph_mask(g) if g.paths else np.zeros(shape, bool)
                                     for g in (strokes.ridges, strokes.valleys))
        self.to_ridge, self.to_valley = (ndimage.distance_transform_edt(~m) if m.any() else np.full(shape, far)
                                         for m in (self.ridges, self.valleys))

    def ridge_side(self) -> np.ndarray:
        """1 on the ridges, 0 on the valleys, between them the share of
        the way from the nearest valley to the nearest ridge,
        ``d_valley / (d_valley + d_ridge)``, through a smoothstep (flat
        along each stroke, no crease)."""
        return smoothstep(self.to_valley / np.maximum(self.to_valley + self.to_ridge, 1e-9))


def _stroke_regions(near: _StrokeDistances, sigma: float) -> np.ndarray:
    """+1 on the sketch's ridges, -1 on its valleys, passing between them
    by :meth:`_StrokeDistances.ridge_side` and easing to 0 over ``sigma``
    cells away from both (twice the fit's regional scale); zeros without
    strokes.

    A valley between two ridges is the low of its region whatever their
    spacing.  (A sum of blurred ridge and valley masks, as before, let two
    ridges a regional scale apart outweigh the valley between them: the
    S-valley's valley cells sat at +0.45 of the ridges' rise, raised, not
    lowered.)  A blur at the level split's own scale (an eighth of
    ``sigma``) rounds the crease midway between them.

    Returns
    -------
    ndarray of float64, shape of the grid
        Between -1 and 1.
    """
    if not (near.ridges.any() or near.valleys.any()):
        return np.zeros(near.ridges.shape)
    side = 2.0 * near.ridge_side() - 1.0
    field = side * np.exp(-0.5 * (np.minimum(near.to_ridge, near.to_valley) / sigma) ** 2)
    return np.clip(ndimage.gaussian_filter(field, sigma / 8, mode="reflect"), -1.0, 1.0)


#: Height quantiles of the level (the landform low-pass) between which the
#: lowest stretches of a painted ridge are brought (:class:`_StrokeSides`);
#: a painted valley's highest stretches go between ``1 -`` them.
STROKE_SIDE = (0.55, 0.65)


class _StrokeSides:
    """Holds the drawing's ridges high and its valleys low along their
    whole length.

    The fit and :data:`UPLIFT` move the regions about the strokes as a
    whole, so a ridge drawn across the coarse terrain's deep valley stayed
    a crest in a lowland there (on the Himalaya's ring, a quarter of the
    ring's cells below the map's median level; an artist reads a ridge
    that runs through lowland as no ridge).  Each round of the fit, the
    level along the ridges below the :data:`STROKE_SIDE` quantiles is
    mapped into them, in order (:func:`_lifted`: the lowest stretch to the
    lower quantile, the rest in line up to the upper one; stretches above
    it are left as they are), and the level along the open valleys
    (:func:`_open_valleys`) above the ``1 -`` quantiles alike.  In order,
    a valley that descends still descends: held at one bound, its floor
    went flat and its streams wandered.  The change is averaged along the
    stroke over ``reach`` (a smooth rise, not a wall) and fades across it
    as a Gaussian of standard deviation ``reach``, each kind only on its
    own side of the way between a ridge and a valley (any valley, open or
    walled in: a ring's rise does not spill into the valleys it
    encloses).

    The quantiles are the level's own, read again each round: where
    strokes cover most of the map they move with it, and the fit's step
    that follows each round pulls the distribution back to the examples'.

    Parameters
    ----------
    near : _StrokeDistances
        The sketch's strokes on the coarse grid.
    reach : float
        Coarse cells: the fit's regional scale.
    """

    def __init__(self, near: _StrokeDistances, reach: float):
        self.reach = reach
        self.masks = (near.ridges, _open_valleys(near.valleys, near.ridges))
        own = near.ridge_side()
        self.weights = (own * np.exp(-0.5 * (near.to_ridge / reach) ** 2),
                        (1.0 - own) * np.exp(-0.5 * (near.to_valley / reach) ** 2))
        self.along = tuple(ndimage.gaussian_filter(m.astype(np.float64), reach, mode="constant")
                           for m in self.masks)

    def correction(self, low: np.ndarray) -> np.ndarray:
        """The change that brings the strokes to their side.

        Parameters
        ----------
        low : ndarray of float64, shape of the grid
            The level (:func:`landform_lowpass` of the coarse terrain),
            metres.

        Returns
        -------
        ndarray of float64, shape of the grid
            Metres to add; 0 where no stroke needs moving.
        """
        lo, hi = STROKE_SIDE
        bounds = np.quantile(low, [lo, hi, 1.0 - lo, 1.0 - hi])
        out = np.zeros_like(low)
        # (A valley is a ridge of the level upside down.)
        for sign, mask, along, weight, (floor, top) in zip((1.0, -1.0), self.masks, self.along, self.weights,
                                                           (bounds[:2], -bounds[2:])):
            if not mask.any():
                continue
            values = sign * low[mask]
            need = np.zeros_like(low)
            need[mask] = _lifted(values, floor, top) - values
            mean = ndimage.gaussian_filter(need, self.reach, mode="constant") / np.maximum(along, 1e-12)
            out += sign * weight * mean
        return out


def _open_valleys(valleys: np.ndarray, ridges: np.ndarray) -> np.ndarray:
    """The connected parts (8-neighbours) of ``valleys`` not walled in by
    ``ridges``: those with a cell from which the grid's border can be
    reached without crossing a ridge.

    A valley inside a ring of ridges can drain only through a gap the
    valleys' breach cuts in the ring (:mod:`..controls.drainage`);
    lowered to the map's low quantiles, it became the lowest ground
    around, a basin with nowhere lower to cut to, and its streams pooled
    (Big Tujunga's ring and cross: valley drainage 0.95 -> 0.72).  A
    valley cell next to a ridge counts as walled in (the ridge is grown
    by a cell); a valley that leaves the ring is open along its whole
    length.
    """
    labels, n = ndimage.label(valleys, structure=np.ones((3, 3), bool))
    if n == 0:
        return valleys
    # (Grown by a cell, a ridge drawn with diagonal steps leaves no gap.)
    regions, _ = ndimage.label(~ndimage.binary_dilation(ridges, structure=np.ones((3, 3), bool)))
    edge = np.unique(np.concatenate([regions[0], regions[-1], regions[:, 0], regions[:, -1]]))
    outside = np.isin(regions, edge[edge > 0])
    open_parts = np.unique(labels[outside & valleys])
    return np.isin(labels, open_parts[open_parts > 0])


def _lifted(values: np.ndarray, floor: float, top: float) -> np.ndarray:
    """``values`` below ``top`` mapped linearly, in order, into ``[floor,
    top]`` (the least to ``floor``); unchanged when none is below
    ``floor``."""
    least = float(values.min())
    if least >= floor or top <= floor:
        # (Tied quantiles, a level flat over much of the map: mapping
        # into them would flatten the stroke.)
        return values
    below = values < top
    out = values.copy()
    out[below] = floor + (values[below] - least) * ((top - floor) / (top - least))
    return out


#: Rounds of the fit.
FIT_ROUNDS = 6

#: Share of the change taken per round.
FIT_STEP = 0.5

#: Most cells the fit reads its quantiles on.
FIT_SAMPLES = 1 << 18

#: Most of the examples' coarse cells the fit reads (about 55 bytes each
#: at its peak): a library of 20 DEMs of 1200 x 850 cells holds 2.5
#: million at the usual coarse factor of 4, which took the landform pass's
#: worker 137 MB above its resting memory.  A single such example holds
#: 125,000, all read.
FIT_EXAMPLE_CELLS = 1 << 20

#: Quantiles at which heights are fitted: dense in the tails, where relief
#: is decided.
FIT_QUANTILES = np.array([0.005, 0.25, 0.5, 0.75, 0.995])

#: Most the fit may stretch or squeeze heights between two quantiles: beyond
#: it a landform's shape would change, not only its height.
MAX_GAIN = 2.5


def fitted_heights(heights: np.ndarray, source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """``heights`` through the monotone, smooth map that carries the
    quantiles ``source`` onto ``target`` (both at :data:`FIT_QUANTILES`).

    Monotone, it keeps every ridge a ridge and every valley a valley, and
    their order in height.  Between two quantiles the map's slope is held
    within [1 / :data:`MAX_GAIN`, :data:`MAX_GAIN`], counted out from the
    median; it is a monotone cubic (C1: no crease along a contour) and
    straight beyond the outer quantiles.

    Parameters
    ----------
    heights : ndarray of float, shape (h, w)
        Metres.
    source, target : ndarray of float, shape (len(FIT_QUANTILES),)
        Non-decreasing heights, metres.

    Returns
    -------
    ndarray of float64, shape (h, w)
    """
    src = np.maximum.accumulate(np.asarray(source, dtype=np.float64))
    target = np.maximum.accumulate(np.asarray(target, dtype=np.float64))
    mid = len(FIT_QUANTILES) // 2
    step_src, step_dst = np.diff(src), np.diff(target)
    gain = np.clip(step_dst / np.maximum(step_src, 1e-9), 1.0 / MAX_GAIN, MAX_GAIN)
    dst = np.empty_like(src)
    dst[mid] = target[mid]
    dst[mid + 1:] = target[mid] + np.cumsum(gain[mid:] * step_src[mid:])
    dst[:mid] = target[mid] - np.cumsum((gain[:mid] * step_src[:mid])[::-1])[::-1]
    keep = np.concatenate([[True], np.diff(src) > 1e-6 * max(1.0, float(np.ptp(src)))])
    src, dst = src[keep], dst[keep]
    h = np.asarray(heights, dtype=np.float64)
    if len(src) < 2:  # a flat terrain: moved, not shaped
        return h + (dst[0] - src[0])
    out = interpolate.PchipInterpolator(src, dst, extrapolate=False)(np.clip(h, src[0], src[-1]))
    below, above = h < src[0], h > src[-1]
    out[below] = dst[0] + (h[below] - src[0]) * (dst[1] - dst[0]) / (src[1] - src[0])
    out[above] = dst[-1] + (h[above] - src[-1]) * (dst[-1] - dst[-2]) / (src[-1] - src[-2])
    return out


def _weighted_quantiles(values: np.ndarray, weights: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Quantiles ``q`` of ``values`` whose cells weigh ``weights``."""
    order = np.argsort(values, kind="stable")
    cum = np.cumsum(weights[order])
    cum = (cum - 0.5 * weights[order]) / cum[-1]
    return np.interp(q, cum, values[order])


def detail_above(heights: np.ndarray, sigma: float) -> np.ndarray:
    """An example's detail above its landform: the heights less their
    Gaussian low-pass (transfer ``g(f) = exp(-2 pi^2 sigma^2 f^2)``).

    The plain complement ``1 - g`` is local and exact on planes: a
    regional slope leaves no detail.

    Parameters
    ----------
    heights : ndarray of float32, shape (H, W)
        Example heights (or detail), metres.
    sigma : float
        The split's standard deviation, cells (:func:`split_sigma`).

    Returns
    -------
    ndarray of float32, shape (H, W)
        Zero-mean detail, metres.
    """
    h = heights.astype(np.float64)
    return (h - ndimage.gaussian_filter(h, sigma, mode="reflect")).astype(np.float32)


#: How much of the way from the power-complementary low-pass ``l`` to the
#: amplitude-complementary ``g`` the level goes about the strokes
#: (:func:`landform_lowpass`): 1 would assume the feature patches repeat the
#: coarse pass's landform exactly, 0 that they are unrelated to it.  They
#: are neither (both are a ridge along the same stroke, not the same
#: ridge).  Measured on 30 runs, against 0: the 32-64-cell band within
#: 0.75-1.33x the example's power in 27 runs instead of 20, the 64-128-cell
#: band in 14 instead of 12, ridge cells in the top quarter of heights in 27
#: instead of 29; 1 gave 27 and 17 of 30 but 25 for the ridges, and left the
#: White Mountains' S-valley at 0.67x in the 32-64-cell band.
COHERENT_SHARE = 0.5

#: Reach of the strokes' coherent landforms, in patch sizes: the weight is
#: full within half a patch of a stroke (where its feature patches lie) and
#: eases to 0 over the next half.
COHERENT_REACH = 0.5


def coherence(strokes: FeatureMaps | None, patch_size: int, f: int) -> np.ndarray | None:
    """Where the level and the detail carry the same landform, on the
    coarse grid: :data:`COHERENT_SHARE` within :data:`COHERENT_REACH`
    patches of a stroke, easing to 0 over as much again (the weight
    :func:`landform_lowpass` takes, brought to the output's size).

    Parameters
    ----------
    strokes : FeatureMaps or None
        The sketch's features on the coarse grid.
    patch_size : int
        The full-resolution pass's, cells.
    f : int
        The coarse grid's down-sampling.

    Returns
    -------
    ndarray of float32, shape (h, w), or None
        None without strokes.
    """
    if strokes is None or COHERENT_SHARE <= 0:
        return None
    mask = graph_mask(strokes.ridges) | graph_mask(strokes.valleys)
    if not mask.any():
        return None
    reach = COHERENT_REACH * patch_size / f  # coarse cells
    away = ndimage.distance_transform_edt(~mask)
    return (COHERENT_SHARE * (1.0 - smoothstep((away - reach) / max(reach, 1.0)))).astype(np.float32)


def landform_lowpass(heights: np.ndarray, sigma: float, coherent: np.ndarray | None = None) -> np.ndarray:
    """The coarse terrain's share of the output: low-passed by
    ``l(f) = sqrt(1 - (1 - g(f))**2)``, and toward ``g(f)`` where
    ``coherent`` says so.

    The detail keeps ``(1 - g)**2`` of the examples' power at each
    wavelength and ``l`` keeps the rest, so the two bands, synthesized
    independently, add up to the examples' power everywhere (with ``g`` for
    the level the power would sag to half where the bands cross, just where
    a landform meets a hillside).  ``l`` is smooth at ``f = 0`` and falls
    like a Gaussian of ``sigma / sqrt(2)``: a local filter.

    Along the strokes the two bands are not independent: the coarse pass
    put a ridge on the stroke and the feature patches put one there again,
    aligned, and aligned landforms add in amplitude, ``l + 1 - g`` (1.42 at
    wavelengths of 4 sigma, twice the power), not in power.  There the
    level moves toward ``g``, for which the two add up to the example's
    landform exactly.

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        The coarse terrain at the output's size, metres.
    sigma : float
        The split's standard deviation, cells.
    coherent : ndarray of float, shape (rows, cols), optional
        Per cell, how far to move from ``l`` to ``g`` (0-1; see
        :func:`coherence`).

    Returns
    -------
    ndarray of float32, shape (rows, cols)
    """
    pad = int(np.ceil(4 * sigma))
    h = np.pad(heights.astype(np.float64), pad, mode="reflect")
    fy = np.fft.fftfreq(h.shape[0])[:, None]
    fx = np.fft.rfftfreq(h.shape[1])[None, :]
    g = np.exp(-2 * np.pi**2 * sigma**2 * (fy**2 + fx**2))
    spectrum = np.fft.rfft2(h)
    inner = (slice(pad, pad + heights.shape[0]), slice(pad, pad + heights.shape[1]))
    out = np.fft.irfft2(spectrum * np.sqrt(1.0 - (1.0 - g) ** 2), s=h.shape)[inner]
    if coherent is not None:
        amplitude = np.fft.irfft2(spectrum * g, s=h.shape)[inner]
        out += np.clip(coherent, 0.0, 1.0) * (amplitude - out)
    return out.astype(np.float32)


def _coarsened(heights: np.ndarray, f: int, cell: float | None, valid: np.ndarray | None = None) -> HeightField:
    """Block means of f x f cells (area-correct, no aliasing of the fine
    detail into the coarse grid); a block with a cell outside ``valid``
    (bool, shape of ``heights``; None: all valid) is nodata."""
    h = heights[: heights.shape[0] // f * f, : heights.shape[1] // f * f]
    blocks = h.reshape(h.shape[0] // f, f, h.shape[1] // f, f).astype(np.float64)
    coarse = blocks.mean(axis=(1, 3)).astype(np.float32)
    whole = _valid_blocks(valid, f, coarse.shape)
    metadata = {}
    if whole is not None:
        coarse[~whole] = np.nan
        # (However narrow on the coarse grid, these voids were wide.)
        metadata[WIDE_VOIDS] = True
    return HeightField(coarse, cell_size=None if cell is None else (cell, cell), metadata=metadata)


def _valid_blocks(valid: np.ndarray | None, f: int, shape: tuple[int, int]) -> np.ndarray | None:
    """Which f x f blocks of ``valid`` (bool; None: all valid) are wholly
    valid: bool, ``shape`` (the block grid), or None."""
    if valid is None:
        return None
    v = valid[: shape[0] * f, : shape[1] * f]
    return v.reshape(shape[0], f, shape[1], f).all(axis=(1, 3))


def preview_patch(bbox: tuple[int, int, int, int], heights: np.ndarray, coarse_shape: tuple[int, int],
                  shape: tuple[int, int]) -> tuple[tuple[int, int, int, int], np.ndarray]:
    """A coarse patch as it would look on the output: its window in output
    cells and its heights stretched bilinearly onto it (a preview that the
    full-resolution pass soon replaces).

    Parameters
    ----------
    bbox : (r0, r1, c0, c1)
        The patch's window on the coarse grid.
    heights : ndarray of float32, shape (r1 - r0, c1 - c0)
        Its heights, metres.
    coarse_shape, shape : (rows, cols)
        The coarse grid and the output.

    Returns
    -------
    bbox : (r0, r1, c0, c1)
        The window on the output, clipped to it.
    heights : ndarray of float32
        The window's shape.
    """
    sr, sc = shape[0] / coarse_shape[0], shape[1] / coarse_shape[1]
    r0, r1, c0, c1 = bbox
    out = (int(r0 * sr), min(shape[0], int(np.ceil(r1 * sr))), int(c0 * sc), min(shape[1], int(np.ceil(c1 * sc))))
    # Output cell centres in the patch's own coarse coordinates.
    r = (np.arange(out[0], out[1]) + 0.5) / sr - 0.5 - r0
    c = (np.arange(out[2], out[3]) + 0.5) / sc - 0.5 - c0
    # Bilinear is separable: two small interpolation matrices instead of a
    # coordinate per output cell (a tenth of the time).
    rows = _linear_matrix(r, heights.shape[0])
    cols = _linear_matrix(c, heights.shape[1])
    return out, (rows @ heights.astype(np.float64) @ cols.T).astype(np.float32)


def _linear_matrix(x: np.ndarray, n: int) -> np.ndarray:
    """Linear interpolation at coordinates ``x`` (clamped to the ends, as
    ``map_coordinates``'s "nearest") of ``n`` samples, as a matrix of shape
    (len(x), n)."""
    x = np.clip(x, 0.0, n - 1)
    i0 = np.minimum(np.floor(x).astype(np.int64), max(n - 2, 0))
    frac = x - i0
    m = np.zeros((len(x), n))
    rows = np.arange(len(x))
    m[rows, i0] = 1.0 - frac
    if n > 1:
        m[rows, i0 + 1] += frac
    return m


def _upsampled(coarse: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Cubic interpolation of the coarse grid at the output's cell centres."""
    # The coarse grid spans the whole output (the sketch was scaled onto
    # it), so a coarse cell covers rows / R output rows, not exactly f:
    # zoom's grid mode maps cell centres so.  (Separable, it needs no
    # coordinate arrays: 130 MB at 4000 x 4000 where map_coordinates took
    # 640 MB, for the same values.)
    rows, cols = shape
    return ndimage.zoom(coarse.astype(np.float64), (rows / coarse.shape[0], cols / coarse.shape[1]), order=3,
                        mode="nearest", grid_mode=True)


def _cells(cell_size: float | None) -> str:
    return "the example's own cells" if cell_size is None else f"{cell_size:g} m cells"
