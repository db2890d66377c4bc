"""Per-example preparation: valid heights, feature networks, relief scale.

Extracting an example's ridges and valleys is the slowest part of starting a
run, and the same examples are used run after run (the app re-synthesizes
after every edit), so the analysis is memoised per (heights, patch size), in
memory and on disk (:mod:`.cache`).
"""

from __future__ import annotations

import hashlib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..measures import topographic_position_index
from ..errors import ParamsError
from ..features import FeatureMaps, extract_features
from ..features.ppa import spare_core
from ..heightfield import HeightField, whole_windows
from ..memo import Memo, array_key
from . import cache
from ..features.samples import example_samples


@dataclass(frozen=True, eq=False)
class ExampleAnalysis:
    """An example ready for synthesis.

    Parameters
    ----------
    heights : ndarray of float32, shape (H, W)
        Valid heights (nodata cropped or filled).
    features : FeatureMaps
    samples : dict kind -> list of FeatureSample
        Candidate feature patch centres.
    strong_mask : ndarray of bool, shape (H, W)
        Cells on long features, kept out of fill patches.
    relief : float
        Typical height spread within a patch (median local standard
        deviation, metres): the unit costs are measured in.
    note : str or None
        What was done about nodata, for the run's warnings.
    key : str
        What the analysis is of (the heights' digest, their shape, the
        patch size and the valid cells): equal keys, equal analyses.
        Memos of what is made from an analysis key by it, so an analysis
        read again from the disk cache (a new object) still finds them.
    valid : ndarray of bool, shape (H, W), or None
        Where the example has real heights; None: everywhere.  Its voids
        are filled in ``heights`` (filters need a whole grid) but no
        feature sample, fill window or landform is taken over them.
    name : str
        The example's name in messages.
    constant : float or None
        Its one height when every cell has it (a flat DEM), metres; else None.
    """

    heights: np.ndarray
    features: FeatureMaps
    samples: dict
    strong_mask: np.ndarray
    relief: float
    note: str | None
    key: str
    valid: np.ndarray | None = None
    name: str = "example"
    constant: float | None = None

    def valid_values(self, grid: np.ndarray) -> np.ndarray:
        """The cells of ``grid`` (shape (H, W), e.g. the heights) where the
        example is valid, flat: what its statistics are taken over."""
        return grid.ravel() if self.valid is None else grid[self.valid]


def prepare_example(field: HeightField | np.ndarray, patch_size: int, *, name: str = "example") -> ExampleAnalysis:
    """Make an example ready: handle nodata, check its size, analyse it.

    Raises
    ------
    ParamsError
        When the example (after removing nodata) is smaller than a patch,
        or its voids leave no patch-sized window of valid cells.
    """
    if not isinstance(field, HeightField):
        field = HeightField(np.asarray(field, dtype=np.float32), source=name)
    notes, valid = [], None
    if field.nodata_count:
        field, valid, cropped, thin, wide = without_voids(field)
        if cropped:
            notes.append(f"{name}: cropped to its largest valid rectangle {field.shape[0]}x{field.shape[1]} "
                         "(nodata)")
        if thin:
            notes.append(f"{name}: {thin} nodata cells filled from their neighbours")
        if wide:
            notes.append(f"{name}: {wide} nodata cells ({wide / field.heights.size:.0%} of "
                         f"{field.shape[0]}x{field.shape[1]}) filled and kept out of every patch")
    if min(field.shape) < patch_size + 4:
        raise ParamsError(
            f"{name} is {field.shape[0]}x{field.shape[1]} cells (valid part), smaller than a patch of "
            f"{patch_size}x{patch_size}: use a larger example or a smaller patch size"
        )
    if valid is not None and not whole_windows(valid, patch_size + 4).any():
        raise ParamsError(
            f"{name} has no {patch_size + 4}x{patch_size + 4} window without nodata, which a patch of "
            f"{patch_size}x{patch_size} needs: use an example with fewer voids or a smaller patch size"
        )
    heights = np.ascontiguousarray(field.heights, dtype=np.float32)
    what = f"{hashlib.sha1(heights.tobytes()).hexdigest()}-{heights.shape[0]}x{heights.shape[1]}"
    where = "" if valid is None else "-v" + hashlib.sha1(np.packbits(valid).tobytes()).hexdigest()[:16]
    key = f"{what}-p{patch_size}{where}"
    low, high = _SPANS.get(what + where, lambda: np.percentile(heights if valid is None else heights[valid],
                                                               [0.5, 99.5]))
    flat = None
    constant = None if np.ptp(heights) else float(heights.flat[0])
    if constant is not None:
        flat = (f"{name} is flat (every cell {constant:g} m): it has no relief to give, "
                "the terrain will be flat")
    elif high - low < NEARLY_FLAT_M:
        flat = (f"{name} is nearly flat ({high - low:.3g} m between its 0.5th and 99.5th height "
                "percentiles): the strokes will barely show; a steeper example, or a style with a "
                "relief scale (relief=K), would help")
    if flat is not None:
        notes.append(flat)
    note = "; ".join(notes) or None
    features, samples, strong, relief = _CACHE.get(key, lambda: _analyse(heights, patch_size, valid))
    return ExampleAnalysis(heights, features, samples, strong, relief, note, key, valid, name, constant)


#: An example whose heights span less than this (metres, between their
#: 0.5th and 99.5th percentiles) is said to be nearly flat.
NEARLY_FLAT_M = 10.0

#: A sample centre keeps this many patch radii from the example's edges
#: (and voids): room for the patch and a little warp.
SAMPLE_MARGIN = 1.1

#: Example feature samples weaker than this quantile of their kind are dropped...
STRONG_QUANTILE = 0.5
#: ...unless they stand out by at least this many standard deviations of TPI.
MIN_STRENGTH = 1.0

# In memory too: the app re-synthesizes after every edit.
_CACHE = cache.Memo(8, cache.load, lambda key, value: cache.save(key, *value))


#: Voids no more than this many cells from a valid one (up to about twice as
#: wide: interlaced rows, SRTM's pinholes) are filled and used as terrain.
THIN_VOID = 2

#: Fields whose every void is wide (a coarse pass's blocks over an
#: example's wide voids) say so in their metadata under this key.
WIDE_VOIDS = "voids_are_wide"

# By the field's bytes: a session is made for every run and live stroke,
# and trimming and filling a large example's voids takes seconds.
_VOIDS = Memo(8)
# Each example's height span (0.5th to 99.5th percentile), by what its key
# says of its heights and valid cells.
_SPANS = Memo(16)


def without_voids(field: HeightField) -> tuple:
    """``field`` trimmed (:meth:`~HeightField.trim_nodata`) and filled.

    Returns
    -------
    field : HeightField
        No NaN; read-only heights.
    valid : ndarray of bool, shape of ``field``, or None
        False on its wide voids (None: there are none).
    cropped : bool
        Cut to its largest valid rectangle.
    thin, wide : int
        Void cells filled and used as terrain; filled and kept out.
    """
    every_wide = bool(field.metadata.get(WIDE_VOIDS))

    def make() -> tuple:
        trimmed = field.trim_nodata()
        void = trimmed.nodata
        if not void.any():
            return trimmed, None, True, 0, 0
        # Cropping would lose real terrain: the voids are filled so that
        # filters see a whole grid; thin ones are terrain again, and no
        # patch is taken over the others.
        wide = void if every_wide else _wide_voids(void)
        n_wide = int(wide.sum())
        valid = None
        if n_wide:
            valid = ~wide
            valid.flags.writeable = False
        return trimmed.fill_nodata(), valid, False, int(void.sum()) - n_wide, n_wide

    return _VOIDS.get((array_key(field.heights), every_wide), make)


def _wide_voids(void: np.ndarray) -> np.ndarray:
    """The cells of ``void`` (bool, (H, W)) in a connected void that reaches
    more than :data:`THIN_VOID` cells from valid ground: a component with a
    cell whose disc of that radius is all void (outside the grid counts as
    void)."""
    span = np.arange(-THIN_VOID, THIN_VOID + 1) ** 2
    deep = ndimage.binary_erosion(void, structure=np.add.outer(span, span) <= THIN_VOID**2, border_value=1)
    if not deep.any():
        return np.zeros(void.shape, bool)
    labels, _ = ndimage.label(void)
    return np.isin(labels, np.unique(labels[deep]))


def _analyse(heights: np.ndarray, patch_size: int, valid: np.ndarray | None = None) -> tuple:
    """The analysis :data:`_CACHE` stores: ``(features, samples, strong, relief)``.

    With a core to spare (:func:`~terrasynth_core.features.ppa.spare_core`)
    the TPI and the relief, which need no features, are computed on a
    second thread while PPA runs (its ridge and valley threads rarely finish
    together, and the FFTs release the GIL), and the two networks' samples
    are then taken on two threads.  Every part is computed exactly as alone.
    """
    radius = patch_size / 2
    # Sample centres need the same room from every void as from the edges.
    room = None if valid is None else whole_windows(valid, 2 * int(np.ceil(SAMPLE_MARGIN * radius)) + 3)
    if spare_core():
        with ThreadPoolExecutor(max_workers=2, thread_name_prefix="analysis") as pool:
            tpi_and_relief = pool.submit(_tpi_and_relief, heights, radius, patch_size, valid)
            features = extract_features(heights)
            tpi, relief = tpi_and_relief.result()
            pools = list(pool.map(_sample_pool, (features.ridges, features.valleys), (1.0, -1.0),
                                  (tpi, tpi), (radius, radius), (room, room)))
    else:
        features = extract_features(heights)
        tpi, relief = _tpi_and_relief(heights, radius, patch_size, valid)
        pools = [_sample_pool(features.ridges, 1.0, tpi, radius, room),
                 _sample_pool(features.valleys, -1.0, tpi, radius, room)]
    samples = {"ridge": pools[0], "valley": pools[1]}
    strong = np.zeros(heights.shape, dtype=bool)
    for graph in (features.ridges, features.valleys):
        long_paths = tuple(p for p in graph.paths if p.length >= patch_size)
        if long_paths:
            strong |= type(graph)(graph.kind, graph.shape, graph.nodes, long_paths).rasterize()
    strong = ndimage.binary_dilation(strong, iterations=2)
    return features, samples, strong, relief


def _tpi_and_relief(heights: np.ndarray, radius: float, patch_size: int,
                    valid: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """The TPI in standard deviations, shape (H, W) float32, and the relief.

    The TPI tells how far a sample's centre stands above (ridge) or below
    (valley) the patch around it: PPA finds every little spur, but a
    sketched stroke asks for a real ridge or valley.  The relief is the
    median local standard deviation within a patch, in metres.  Both are
    read where the example is ``valid`` (a patch of it, for the relief).
    """
    tpi = topographic_position_index(heights, radius=radius)
    tpi /= float(np.nanstd(tpi if valid is None else tpi[valid])) or 1.0
    mean = ndimage.uniform_filter(heights.astype(np.float64), patch_size)
    mean2 = ndimage.uniform_filter(heights.astype(np.float64) ** 2, patch_size)
    local_std = np.sqrt(np.maximum(mean2 - mean**2, 0.0))
    if valid is not None:
        local_std = local_std[whole_windows(valid, patch_size)]
    return tpi, float(np.median(local_std)) or 1.0


def _sample_pool(graph, sign: float, tpi: np.ndarray, radius: float, room: np.ndarray | None = None) -> list:
    """The candidate samples of one network: centres that leave room for
    the patch (and a little warp, :data:`SAMPLE_MARGIN`) inside the
    example and, where ``room`` (bool, shape of ``tpi``) is given, only
    where it is True (clear of the example's voids), standing out enough
    by TPI (``sign`` +1 for ridges, -1 for valleys)."""
    margin = radius * SAMPLE_MARGIN
    H, W = tpi.shape
    pool = [
        s for s in example_samples(graph, radius, spacing=radius / 2)
        if margin <= s.center[0] <= H - 1 - margin and margin <= s.center[1] <= W - 1 - margin
    ]
    if pool and room is not None:
        pool = [s for s in pool if room[int(round(s.center[0])), int(round(s.center[1]))]]
    if pool:
        rc = np.rint([s.center for s in pool]).astype(int)
        strength = sign * tpi[rc[:, 0], rc[:, 1]]
        keep = strength >= min(np.quantile(strength, STRONG_QUANTILE), MIN_STRENGTH)
        pool = [s for s, k in zip(pool, keep) if k]
    return pool
