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

import dataclasses
import hashlib
from typing import Callable, Iterator, Sequence

import numpy as np
import scipy

from ..controls.layout import Grounded, anchors, automatic_patch_size, build_layout, grounded_examples
from ..controls.options import Controls, check_heights
from ..errors import ParamsError
from ..exemplars.patch_size import PATCH_SIZES
from ..exemplars import cache, mapped_pages
from ..features import FeatureMaps
from ..features.sketch import SketchMap, sketch_features
from ..heightfield import MOST_GRID_CELLS, HeightField
from ..io.resample import output_georeference
from ..memo import Memo, array_key
from .events import drive
from .landform import coarse_session, detail_above
from .params import SynthesisParams
from .pipeline import RunState, run_pipeline
from .result import SynthesisResult

__all__ = ["Session"]

#: Largest change of aspect ratio a sketch is stretched by without a note
#: (the style map and water mask are refused beyond it, as painted for the
#: output; a sketch is a drawing, so it is stretched, but said).
STRETCH_TOLERANCE = 0.02

#: Detail bands kept between sessions (:func:`_memo_detail_above`).
_DETAIL_BANDS = Memo(4)

#: What the stored detail bands are made by: the filter's code and scipy's version.
_BAND_CODE = hashlib.blake2b(repr((detail_above.__code__.co_code, detail_above.__code__.co_consts,
                                   detail_above.__code__.co_names, scipy.__version__)).encode(),
                             digest_size=8).hexdigest()


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
    level : ndarray of float, shape ``shape``, optional
        A level field made elsewhere, metres: the large-scale elevation the
        detail sits on, instead of the session's own (its style bases, pins
        and landform pass).  A tiled run gives each tile its window of the
        whole map's.  Needs ``params.landform`` False (the level replaces
        the pass).
    level_split : float, optional
        With ``level``: the standard deviation (cells) of the
        landform/detail split it was made with; the examples then give only
        their detail above it (as after the session's own landform pass).
        None: their whole detail.
    band : ndarray of bool, shape ``shape``, optional
        With a re-synthesis: selected cells whose ``previous`` heights count
        as terrain already there (patches are matched to them and the graph
        cuts weigh them as any filled cell) but may be replaced, so seams can
        run through them (a tile's band along its finished neighbours).
    """

    def __init__(self, examples: Sequence[HeightField | np.ndarray], sketch: SketchMap | None = None, *,
                 shape: tuple[int, int] | None = None, params: SynthesisParams = SynthesisParams(),
                 controls: Controls | None = None, level: np.ndarray | None = None,
                 level_split: float | None = None, band: np.ndarray | None = None):
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
        if rows * cols > MOST_GRID_CELLS:
            raise ParamsError(f"output {rows}x{cols} exceeds {MOST_GRID_CELLS // 1_000_000} million cells")
        # (Checked before the examples are read and an automatic patch size
        # is chosen from them.)
        checked = controls.checked((rows, cols), len(examples))
        check_heights(examples, checked)
        grounded = grounded_examples(examples, checked, params.cell_size)
        automatic = params.patch_size is None
        params, size_notes = with_patch_size(params, grounded, sketch, (rows, cols))
        if min(rows, cols) < params.patch_size:
            raise ParamsError(
                f"output {rows}x{cols} is smaller than a patch ({params.patch_size}): "
                "make the output larger or the patch smaller"
            )
        stretch_notes = []
        if sketch is not None and sketch.shape != (rows, cols):
            sr, sc = sketch.shape
            if abs((sr / sc) / (rows / cols) - 1) > STRETCH_TOLERANCE:
                stretch_notes.append(f"the sketch ({sr}x{sc}) is stretched to the output's {rows}x{cols}, another "
                                     "aspect ratio, so its strokes are distorted; give an output size with the "
                                     "sketch's proportions to keep them")
            sketch = sketch.resized((rows, cols))
        self.shape = (rows, cols)
        self.sketch = sketch
        self.params = params
        self.controls = checked
        self.layout = build_layout(examples, self.controls, self.shape, params.patch_size,
                                   cell_size=params.cell_size, grounded=grounded)
        #: The run's square cell size in metres (None: unknown).
        self.cell_size = self.layout.cell_size
        #: Where the output goes on the map: a local Transverse Mercator
        #: near the first georeferenced example (None without a cell size).
        self.georef = None if self.cell_size is None else output_georeference(
            [*examples, *(s.example for s in self.controls.styles)], self.shape, self.cell_size)
        self.examples = self.layout.examples
        #: How many of the layout's examples are plain ones (the rest are styles').
        self.n_plain = len(examples)
        self._detail_above: dict[float, list] = {}
        self._coarse = None
        self.warnings: list[str] = [*stretch_notes, *size_notes, *self.layout.notes]
        self.sketch_maps = self._sketch_maps()
        self._check_features(automatic)
        #: Cells of the selection kept as terrain that may be replaced (see ``band``).
        self.band = self._given_level_and_band(level, level_split, band)

    def _given_level_and_band(self, level, level_split, band) -> np.ndarray | None:
        """Take a given level field into the layout; the band, checked."""
        if level is not None:
            level = np.asarray(level, dtype=np.float32)
            if level.shape != self.shape or not np.isfinite(level).all():
                raise ParamsError(f"the given level field is {level.shape}, expected finite heights of the "
                                  f"output's {self.shape[0]}x{self.shape[1]}")
            if self.params.landform:
                raise ParamsError("a given level field replaces the landform pass: set landform=False")
            detail, anchor = self.layout.detail, self.layout.anchor
            if level_split is not None:
                detail, anchor = self.detail_above(float(level_split))
            self.layout = dataclasses.replace(self.layout, level=level, detail=detail, anchor=anchor)
        elif level_split is not None:
            raise ParamsError("level_split is the split of a given level field: give the level too")
        if band is None:
            return None
        band = np.asarray(band, dtype=bool)
        if band.shape != self.shape:
            raise ParamsError(f"the band is {band.shape}, the output {self.shape[0]}x{self.shape[1]}")
        if self.controls.selection is None or (band & ~self.controls.selection).any():
            raise ParamsError("the band must lie in the selection of a re-synthesis (previous terrain that may "
                              "be replaced)")
        return band

    # -- validation -----------------------------------------------------------
    def _sketch_maps(self) -> FeatureMaps:
        if self.sketch is None or not self.sketch.has_strokes:
            self.warnings.append("the sketch has no strokes: non-feature synthesis only")
            blank = SketchMap(np.zeros(self.shape, bool), np.zeros(self.shape, bool))
            return sketch_features(blank)
        maps = sketch_features(self.sketch)
        if not maps.ridges.paths and not maps.valleys.paths:
            painted = 100 * float((self.sketch.ridge_mask | self.sketch.valley_mask).mean())
            self.warnings.append(
                f"the sketch's strokes ({painted:.0f} % of it painted) give no ridge or valley line: "
                "draw lines, not filled areas; non-feature synthesis only"
            )
        return maps

    def _check_features(self, automatic: bool) -> None:
        """Every feature kind the sketch draws is in some example
        (``automatic``: the patch size was chosen from every automatic
        size, so a smaller one is no hint to give)."""
        for graph in (self.sketch_maps.ridges, self.sketch_maps.valleys):
            if not graph.paths:
                continue
            have = sum(len(ex.samples[graph.kind]) for ex in self.examples)
            if have == 0 and all(ex.constant is not None for ex in self.examples):
                flat = "; ".join(f"{ex.name}: all at {ex.constant:g} m" for ex in self.examples)
                raise ParamsError(
                    f"the sketch has {graph.kind}s but every example is flat ({flat}): a flat DEM has no "
                    f"{graph.kind}s to give; choose an example with relief"
                )
            if have == 0:
                size = (f"a patch of any automatic size (down to {PATCH_SIZES[-1]} cells)" if automatic
                        else f"a patch of {self.params.patch_size} cells")
                raise ParamsError(
                    f"the sketch has {graph.kind}s but no example has {graph.kind} features far enough "
                    f"from its border for {size}: choose a larger or more rugged example"
                    + ("" if automatic else ", or a smaller patch size")
                )

    def coarse_pass(self):
        """The landform pass's session, factor and note (memoised: a session
        may run again), see :func:`.landform.coarse_session`."""
        if self._coarse is None:
            self._coarse = coarse_session(self)
        return self._coarse

    def detail_above(self, sigma: float) -> tuple[list[np.ndarray], np.ndarray]:
        """Each example's detail above its low-pass and its shift weight
        (memoised: a session may run again), see :func:`.landform.detail_above`."""
        if sigma not in self._detail_above:
            detail = [_memo_detail_above(d, sigma) for d in mapped_pages.checked(self.layout.detail)]
            self._detail_above[sigma] = detail, anchors(detail, self.layout.relief, self.params.patch_size,
                                                        [ex.valid for ex in self.layout.examples])
        return self._detail_above[sigma]

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
        return drive(self.iter_run(), progress=progress, cancel=cancel)

    def iter_run(self) -> Iterator[object]:
        """Run step by step, yielding events (see :mod:`.events`).

        Closing the generator (or simply not asking for more) cancels the
        run cleanly at the next patch boundary.
        """
        return run_pipeline(RunState.start(self))


def with_patch_size(params: SynthesisParams, grounded: Grounded, sketch: SketchMap | None,
                    shape: tuple[int, int]) -> tuple[SynthesisParams, list[str]]:
    """``params`` with an automatic patch size chosen
    (:func:`~terrasynth_core.controls.layout.automatic_patch_size`), and why,
    for the run's warnings; a size given is kept.

    Parameters
    ----------
    params : SynthesisParams
    grounded : Grounded
        The run's examples at its cell size.
    sketch : SketchMap or None
        Which feature kinds it draws.
    shape : (rows, cols)
        The output: no patch larger than its smaller side (below the
        smallest automatic size, that size: the caller says it is too small).
    """
    if params.patch_size is not None:
        return params, []
    if min(shape) < PATCH_SIZES[-1]:
        return dataclasses.replace(params, patch_size=PATCH_SIZES[-1]), []
    size, notes = automatic_patch_size(grounded, () if sketch is None else sketch.kinds, largest=min(shape))
    if params.overlap is not None and params.overlap > size // 2:
        raise ParamsError(f"parameter overlap={params.overlap}: expected at most {size // 2}, half the automatic "
                          f"patch size these examples need ({size} cells); give a smaller overlap or a patch size")
    return dataclasses.replace(params, patch_size=size), notes


def _memo_detail_above(detail: np.ndarray, sigma: float) -> np.ndarray:
    """:func:`.landform.detail_above`, kept for the last few examples.

    A session is made again after every edit (the app's runs; a crop
    re-synthesis per stroke with its landform pass, :mod:`.local`), and the
    examples' detail band is a Gaussian filter over each whole example
    (about 0.3 s for a 1201x1201 DEM) that no edit of the sketch changes.
    Keyed by the detail's bytes, so an edited example is never served a
    stale band.  Kept in the example-analysis disk cache too, and read back
    from there mapped (:mod:`terrasynth_core.exemplars.cache`): a library
    of many examples is then not held in each process's memory.  The stored
    band's key holds the filter's own code and scipy's version, so a
    changed filter never reads an old band.
    """
    key = (array_key(detail), float(sigma))

    def make() -> np.ndarray:
        stored_key = (f"detail-{key[0][0].hex()}-{detail.shape[0]}x{detail.shape[1]}-s{float(sigma)!r}-"
                      f"{_BAND_CODE}")
        band = cache.kept_array(stored_key, lambda: detail_above(detail, sigma))
        band.flags.writeable = False  # shared by every session that asks
        return band

    return _DETAIL_BANDS.get(key, make)
