"""Sketch maps: reading, writing and turning strokes into feature graphs.

A sketch is an RGB(A) image of any size: red strokes (R >= 128, G < 128,
B < 128) ask for ridges, blue strokes (B >= 128, R < 128, G < 128) for
valleys, every other colour (and transparent pixels) means "no preference".
:class:`SketchMap` holds the two stroke masks; :func:`sketch_features` turns
them into the same kind of :class:`FeatureMaps` that PPA extracts from a
DEM, so sketch and example features can be matched (Zhou et al. 2007, §3).

Stroke analysis: bridge small gaps, skeletonize, then the shared pipeline of
:mod:`.network` with the distance to the stroke's edge as link strength, so
a drawn closed loop breaks where the stroke is thinnest, as PPA breaks
polygons at their lowest segment.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError
from scipy import ndimage
from skimage.morphology import disk, skeletonize

from ..errors import ParamsError, SketchError
from ..io._common import atomic_outputs, open_new
from ..memo import Memo, array_key
from .graph import FeatureGraph, FeatureKind, FeatureMaps
from .network import feature_graph_from_mask, mask_box
from .ppa import validate_int, validate_number

#: Stroke colours written by :meth:`SketchMap.to_rgb`.
RIDGE_RGB = (255, 0, 0)
VALLEY_RGB = (0, 0, 255)
BACKGROUND_RGB = (255, 255, 255)

#: Pillow modes that hold colour; everything else (grey levels, 16-bit and
#: float images) cannot carry red or blue strokes.
_COLOUR_MODES = {"RGB", "RGBA", "RGBX", "RGBa", "P", "PA", "CMYK", "YCbCr"}


#: Rows of a sketch image classified at a time by :func:`read_sketch`.
_CLASSIFY_ROWS = 512


@dataclass(frozen=True, eq=False)
class SketchMap:
    """Where the user asks for ridges and valleys.

    Parameters
    ----------
    ridge_mask, valley_mask : ndarray of bool, shape (rows, cols)
        Stroke pixels; a pixel cannot be both.  Stored as read-only copies.
    """

    ridge_mask: np.ndarray
    valley_mask: np.ndarray

    def __post_init__(self):
        masks = []
        for name in ("ridge_mask", "valley_mask"):
            m = np.asarray(getattr(self, name))
            if m.ndim != 2 or min(m.shape) < 2 or m.dtype != bool:
                raise SketchError(
                    f"SketchMap.{name} must be a 2-D boolean array of at least 2x2 pixels, "
                    f"got {m.dtype} array of shape {m.shape}"
                )
            m = m.copy()
            m.flags.writeable = False
            masks.append(m)
        ridge, valley = masks
        if ridge.shape != valley.shape:
            raise SketchError(f"SketchMap masks differ in shape: ridges {ridge.shape}, valleys {valley.shape}")
        overlap = int((ridge & valley).sum())
        if overlap:
            raise SketchError(f"SketchMap has {overlap} pixels marked both ridge and valley")
        object.__setattr__(self, "ridge_mask", ridge)
        object.__setattr__(self, "valley_mask", valley)

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` of the sketch."""
        return self.ridge_mask.shape

    @property
    def has_strokes(self) -> bool:
        """True when any pixel asks for a ridge or a valley."""
        return bool(self.ridge_mask.any() or self.valley_mask.any())

    @property
    def kinds(self) -> tuple[str, ...]:
        """The feature kinds painted: ``"ridge"``, ``"valley"``, both or none."""
        return tuple(kind for kind, mask in (("ridge", self.ridge_mask), ("valley", self.valley_mask)) if mask.any())

    @classmethod
    def empty(cls, shape: tuple[int, int]) -> "SketchMap":
        """A sketch of ``shape`` without strokes."""
        blank = np.zeros(shape, dtype=bool)
        return cls(blank, blank)

    @classmethod
    def from_rgb(cls, rgb: np.ndarray) -> "SketchMap":
        """Classify the pixels of an RGB(A) image.

        Parameters
        ----------
        rgb : ndarray of uint8, shape (rows, cols, 3) or (rows, cols, 4)
            Colours; with 4 channels, pixels with alpha < 128 mean "no
            preference" whatever their colour.

        Returns
        -------
        SketchMap
        """
        a = np.asarray(rgb)
        if a.ndim != 3 or a.shape[2] not in (3, 4) or a.dtype != np.uint8:
            raise SketchError(
                f"sketch image must be a uint8 array of shape (rows, cols, 3 or 4), got {a.dtype} {a.shape}"
            )
        return cls(*_stroke_masks(a))

    def to_rgb(self) -> np.ndarray:
        """The sketch as an image: white background, red ridges, blue valleys.

        Returns
        -------
        ndarray of uint8, shape (rows, cols, 3)
        """
        rgb = np.empty(self.shape + (3,), dtype=np.uint8)
        rgb[:] = BACKGROUND_RGB
        rgb[self.ridge_mask] = RIDGE_RGB
        rgb[self.valley_mask] = VALLEY_RGB
        return rgb

    def resized(self, shape: tuple[int, int]) -> "SketchMap":
        """The sketch scaled to ``shape``.

        Parameters
        ----------
        shape : (rows, cols)

        Returns
        -------
        SketchMap

        Notes
        -----
        A target pixel is a stroke when any part of its footprint in the
        source is: thin strokes survive strong downscaling (at the price of
        up to one pixel of extra width).  Where ridge and valley strokes share
        a footprint, the one covering more of it wins.
        """
        if len(shape) != 2 or not all(isinstance(v, (int, np.integer)) and v >= 2 for v in shape):
            raise SketchError(f"sketch size must be (rows, cols) of at least 2 each, got {shape!r}")
        rows, cols = int(shape[0]), int(shape[1])
        if (rows, cols) == self.shape:
            return self

        def coverage(mask: np.ndarray) -> np.ndarray:
            # 0/1 bytes made float inside Pillow: no float copy of a large
            # sketch on the numpy side.
            image = Image.fromarray(mask.view(np.uint8), mode="L").convert("F")
            return np.asarray(image.resize((cols, rows), Image.Resampling.BOX))

        ridge, valley = coverage(self.ridge_mask), coverage(self.valley_mask)
        eps = 1e-6  # BOX sums in float32; anything above rounding noise counts
        return SketchMap((ridge > eps) & (ridge >= valley), (valley > eps) & (valley > ridge))


def resize_nearest(layer: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """A grid resampled by nearest cell, so labels and masks stay labels and masks.

    Parameters
    ----------
    layer : ndarray, shape (rows, cols, ...)
        Any dtype; trailing axes (e.g. RGB) are carried along.
    shape : (rows, cols)
        The new size.

    Returns
    -------
    ndarray, shape (shape[0], shape[1], ...)
        Each cell takes the source cell under its centre; ``layer`` itself
        when it already has ``shape``.
    """
    if layer.shape[:2] == tuple(shape):
        return layer
    rows = np.minimum(((np.arange(shape[0]) + 0.5) * layer.shape[0] / shape[0]).astype(int), layer.shape[0] - 1)
    cols = np.minimum(((np.arange(shape[1]) + 0.5) * layer.shape[1] / shape[1]).astype(int), layer.shape[1] - 1)
    return layer[np.ix_(rows, cols)]


#: Largest painted map (sketch, style regions, water) read, in pixels: the
#: core's output limit.  Larger images are refused before they are decoded.
MAX_IMAGE_PIXELS = 64_000_000


def open_image(path: Path, what: str) -> Image.Image:
    """``Image.open(path)`` with its size checked before any pixel is decoded.

    Raises
    ------
    SketchError
        Naming ``what``, the file and the limit, for an image of more than
        :data:`MAX_IMAGE_PIXELS` pixels (also for those Pillow itself
        refuses as decompression bombs).
    """
    limit = f"at most {MAX_IMAGE_PIXELS} pixels (e.g. 8000x8000) are read: scale it down"
    try:
        with warnings.catch_warnings():
            # Pillow warns from 89 M pixels; the size is checked here instead.
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            image = Image.open(path)
    except Image.DecompressionBombError as exc:
        pixels = re.search(r"\((\d+) pixels\)", str(exc))
        size = f"{pixels.group(1)} pixels" if pixels else "too many pixels"
        raise SketchError(f"{what} {path} has {size}; {limit}") from None
    cols, rows = image.size
    if rows * cols > MAX_IMAGE_PIXELS:
        image.close()
        raise SketchError(f"{what} {path} is {cols}x{rows} pixels; {limit}")
    return image


def _stroke_masks(rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ridge (red) and valley (blue) pixels of uint8 RGB(A) pixels; with
    alpha, pixels under 128 are neither."""
    high = rgb[:, :, :3] >= 128
    r, g, b = high[:, :, 0], high[:, :, 1], high[:, :, 2]
    opaque = rgb[:, :, 3] >= 128 if rgb.shape[2] == 4 else True
    return r & ~g & ~b & opaque, b & ~r & ~g & opaque


def read_sketch(path) -> SketchMap:
    """Read a sketch image file.

    Parameters
    ----------
    path : str or Path
        An RGB, RGBA or palette image (PNG in practice; any format Pillow
        reads in colour works).

    Returns
    -------
    SketchMap

    Raises
    ------
    SketchError
        Missing or unreadable file, not an image, or a grey-level image
        (8- or 16-bit) that cannot hold red and blue strokes.
    """
    path = Path(path)
    try:
        with open_image(path, "sketch") as image:
            image.load()
            mode = image.mode
            if mode not in _COLOUR_MODES:
                raise SketchError(
                    f"sketch {path} is a grey-level image (mode {mode}); expected an RGB, RGBA or "
                    "palette image with red ridge and blue valley strokes"
                )
            has_alpha = mode in ("RGBA", "RGBa", "PA") or (mode == "P" and "transparency" in image.info)
            target = "RGBA" if has_alpha else "RGB"
            cols, rows = image.size
            if min(rows, cols) < 2:
                raise SketchError(f"sketch {path} is only {cols}x{rows} pixels; expected at least 2x2")
            # Band by band: a whole large image as one array (and its
            # conversion) would take several times the image's size.
            ridge = np.empty((rows, cols), bool)
            valley = np.empty((rows, cols), bool)
            for r0 in range(0, rows, _CLASSIFY_ROWS):
                r1 = min(r0 + _CLASSIFY_ROWS, rows)
                ridge[r0:r1], valley[r0:r1] = _stroke_masks(np.asarray(image.crop((0, r0, cols, r1)).convert(target)))
            sketch = SketchMap(ridge, valley)
            if not sketch.has_strokes:
                # Transparent pixels say nothing, whatever colour they keep underneath.
                rgb = np.asarray(image.convert(target))
                # (Masked only with an alpha channel: a boolean index of
                # every pixel took 9 s of an 8000x8000 blank sketch's 16.)
                _refuse_other_colours(rgb[..., :3][rgb[..., 3] >= 128] if rgb.shape[2] == 4 else rgb, path)
    except FileNotFoundError:
        raise SketchError(f"sketch file {path} does not exist") from None
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        if isinstance(exc, SketchError):
            raise
        raise SketchError(f"cannot read sketch {path}: not a readable image ({exc})") from None
    return sketch


def _refuse_other_colours(rgb: np.ndarray, path: Path) -> None:
    """A sketch without red or blue but with drawing in other colours was
    almost surely painted in the wrong colours: say so instead of silently
    synthesizing terrain without features.  A blank (or fully transparent)
    canvas passes."""
    flat = rgb.reshape(-1, 3)
    if not len(flat):
        return
    # The most common colour, counted as 24-bit codes (np.unique over rows
    # sorted every pixel: 31 s for a blank 8000x8000 sketch, against 1 s).
    codes = (flat[:, 0].astype(np.int32) << 16) | (flat[:, 1].astype(np.int32) << 8) | flat[:, 2]
    top = int(np.argmax(np.bincount(codes, minlength=1 << 24)))
    background = np.array([top >> 16, (top >> 8) & 255, top & 255], dtype=np.int16)
    drawn = np.abs(flat.astype(np.int16) - background).max(axis=1) > 32
    share = drawn.mean()
    if share > 0.001:
        example = "#{:02x}{:02x}{:02x}".format(*flat[np.flatnonzero(drawn)[0]])
        raise SketchError(
            f"sketch {path} has no red or blue strokes but {100 * share:.1f} % of its pixels are drawn in "
            f"other colours (e.g. {example}): paint ridges red (R>=128, G<128, B<128) and valleys blue "
            "(B>=128, R<128, G<128)"
        )


def save_sketch(sketch: SketchMap, path) -> Path:
    """Write a sketch as an RGB PNG (white, red ridges, blue valleys).

    Parameters
    ----------
    sketch : SketchMap
    path : str or Path
        Destination.  Written to a temporary file beside it and renamed, so
        an interrupted save never leaves a truncated file.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    SketchError
        The file cannot be written.
    """
    path = Path(path)
    image = Image.fromarray(sketch.to_rgb())
    try:
        with atomic_outputs(path) as (tmp,), open_new(tmp) as f:
            image.save(f, format="PNG")
    except OSError as exc:
        raise SketchError(f"cannot write sketch {path}: {exc.strerror or exc}") from None
    return path


@dataclass(frozen=True)
class SketchParams:
    """Parameters of sketch analysis; validated on construction.

    Lengths are in sketch pixels.  None means "derived from the measured
    stroke width" w (twice the median distance from the skeleton to the
    stroke's edge, minus one), so one set of defaults serves 1 to 20 px
    strokes.

    Parameters
    ----------
    gap_closing : int, default 3
        Gaps up to this many pixels in a stroke are closed (the strokes are
        dilated by a disc of radius ``ceil(gap_closing / 2)`` before
        skeletonizing; strokes closer than that merge); 0 = none, up to 20.
    prune_length : float or None, default None
        Skeleton spurs shorter than this are removed; None = w + 3 (spurs of
        a skeleton come from the stroke's width, not from the drawing).
    prune_iterations : int, default 3
        Rounds of spur removal, 0 to 100.
    min_component_length : float or None, default None
        Strokes whose skeleton is shorter than this are dropped (dots,
        specks); None = max(5, 2 w).
    junction_merge_distance : float or None, default None
        Branch points this close along the skeleton become one node (a
        drawn "+" often skeletonizes into two 3-way junctions); None = w + 2.
    smoothing : int, default 7
        Moving-average window along the paths, in points; 0 or 1 = none.
    """

    gap_closing: int = 3
    prune_length: float | None = None
    prune_iterations: int = 3
    min_component_length: float | None = None
    junction_merge_distance: float | None = None
    smoothing: int = 7

    def __post_init__(self):
        validate_int(self, "gap_closing", 0, 20)
        validate_int(self, "prune_iterations", 0, 100)
        validate_int(self, "smoothing", 0, 1000)
        for name in ("prune_length", "min_component_length", "junction_merge_distance"):
            if getattr(self, name) is not None:
                validate_number(self, name, 0.0, math.inf)


def _stroke_width(distance: np.ndarray, skeleton: np.ndarray) -> float:
    """Typical stroke width in pixels: ``2 * median(distance over the
    skeleton) - 1``, at least 1 (a one-pixel line is 1 from its edge)."""
    if not skeleton.any():
        return 1.0
    return max(1.0, 2.0 * float(np.median(distance[skeleton])) - 1.0)


def _bridge_gaps(mask: np.ndarray, gap: int) -> np.ndarray:
    """Dilate strokes so that gaps up to ``gap`` pixels close.

    A dilation by a disc of radius ``ceil(gap / 2)``, not a closing: the
    erosion of a closing reopens gaps in strokes thinner than the disc
    (a 1 px line with a 2 px break stays broken), while the skeleton of the
    dilated strokes still runs down their middle.
    """
    radius = (gap + 1) // 2
    if radius == 0:
        return mask
    footprint = disk(radius).astype(bool)
    bridged = np.zeros(mask.shape, dtype=bool)
    pixels = np.argwhere(mask)
    if len(pixels) * int(footprint.sum()) > mask.size // 4:
        # Much painted: the filter over the strokes' box and the disc's reach.
        box = mask_box(mask, radius + 1)
        bridged[box] = ndimage.binary_dilation(mask[box], structure=footprint)
        return bridged
    # Strokes cover a few percent of a sketch: the disc's copies of them,
    # the same pixels as the filter (a union of the disc's shifts; the disc
    # is symmetric, and off the image there are no strokes).
    rows, cols = mask.shape
    for dr, dc in np.argwhere(footprint) - radius:
        r, c = pixels[:, 0] + dr, pixels[:, 1] + dc
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        bridged[r[inside], c[inside]] = True
    return bridged


def _skeleton(mask: np.ndarray) -> np.ndarray:
    """``skeletonize(mask)``, thinned on the strokes' bounding box only.

    The same pixels as over the whole image: thinning reads only each
    stroke pixel's 8 neighbours, and the box keeps a ring of background
    around the strokes (or the image's own border where they reach it).
    """
    skeleton = np.zeros(mask.shape, dtype=bool)
    box = mask_box(mask, 1)
    if box is not None:
        skeleton[box] = skeletonize(mask[box].copy())
    return skeleton


#: Side, in pixels, of the tiles :func:`_edge_distance` works in.
_DISTANCE_TILE = 64

#: Background first looked for this many pixels around a tile (a wider
#: stroke widens its own tile's window).
_DISTANCE_MARGIN = 8


def _edge_distance(mask: np.ndarray) -> np.ndarray:
    """Each stroke pixel's distance to the nearest background pixel,
    counting the image's border as background: exactly
    ``distance_transform_edt(np.pad(mask, 1))[1:-1, 1:-1]``, shape of
    ``mask``, float64 (0 off the strokes).

    Computed only in the tiles that hold strokes, each on a window of
    ``m`` more pixels around it.  Any pixel outside that window is at
    least ``m + 1`` away, so where the window's transform gives at most
    ``m + 1`` no farther background can be nearer, and the value is the
    whole image's (the same squared integer offset, so the same float).
    A tile with a pixel farther than that from the window's background is
    done again with ``m`` that distance, which bounds its pixels' true
    distance from above.
    """
    padded = np.pad(mask, 1)
    distance = np.zeros(padded.shape, dtype=np.float64)
    t = _DISTANCE_TILE
    rows, cols = padded.shape
    tr, tc = -(-rows // t), -(-cols // t)
    blocks = np.zeros((tr * t, tc * t), dtype=bool)
    blocks[:rows, :cols] = padded
    for i, j in np.argwhere(blocks.reshape(tr, t, tc, t).any(axis=(1, 3))).tolist():
        r0, r1, c0, c1 = i * t, min((i + 1) * t, rows), j * t, min((j + 1) * t, cols)
        m = _DISTANCE_MARGIN
        while True:
            w0, w1, v0, v1 = max(r0 - m, 0), min(r1 + m, rows), max(c0 - m, 0), min(c1 + m, cols)
            window = padded[w0:w1, v0:v1]
            if window.all():  # no background in sight (the padding guarantees some farther out)
                m *= 2
                continue
            part = ndimage.distance_transform_edt(window)[r0 - w0:r1 - w0, c0 - v0:c1 - v0]
            worst = float(part.max())
            if worst <= m + 1:
                break
            m = int(math.ceil(worst))
        distance[r0:r1, c0:c1] = part
    return distance[1:-1, 1:-1]


def _touches_border(mask: np.ndarray) -> bool:
    return bool(mask[0].any() or mask[-1].any() or mask[:, 0].any() or mask[:, -1].any())


def _crossing_runs(line: np.ndarray, max_run: float) -> np.ndarray:
    """Pixels of a border line that belong to runs no longer than ``max_run``
    (strokes crossing the border, not lying along it)."""
    labels, n = ndimage.label(line)
    if n == 0:
        return line
    run_length = np.bincount(labels.ravel())
    return line & (run_length[labels] <= max_run)


def _skeleton_to_border(mask: np.ndarray, width: float) -> np.ndarray:
    """Skeleton whose lines run out to the border where strokes cross it.

    A skeleton stops about half a stroke width before the end of a stroke,
    and the image border looks like one.  Strokes that cross the border are
    continued straight out (their border pixels repeated outwards) by a bit
    more than half their width before skeletonizing, so their centre lines
    reach the border.  Strokes lying along the border (border runs longer
    than three widths) are not continued: that would push their centre line
    out of the image.
    """
    pad = int(math.ceil(width / 2)) + 1
    max_run = 3.0 * width + 2.0
    rows, cols = mask.shape
    padded = np.zeros((rows + 2 * pad, cols + 2 * pad), dtype=bool)
    padded[pad:-pad, pad:-pad] = mask
    padded[:pad, pad:-pad] = _crossing_runs(mask[0], max_run)
    padded[-pad:, pad:-pad] = _crossing_runs(mask[-1], max_run)
    padded[pad:-pad, :pad] = _crossing_runs(mask[:, 0], max_run)[:, None]
    padded[pad:-pad, -pad:] = _crossing_runs(mask[:, -1], max_run)[:, None]
    return _skeleton(padded)[pad:-pad, pad:-pad]


def stroke_graph(
    mask: np.ndarray, *, kind: FeatureKind, params: SketchParams = SketchParams()
) -> FeatureGraph:
    """Feature graph of one stroke mask.

    Parameters
    ----------
    mask : ndarray of bool, shape (rows, cols)
        Stroke pixels.
    kind : {"ridge", "valley"}
    params : SketchParams

    Returns
    -------
    FeatureGraph
        Acyclic; paths follow the strokes' centre lines.
    """
    shape = mask.shape
    if not mask.any():
        return FeatureGraph(kind, shape, (), ())
    bridged = _bridge_gaps(mask, params.gap_closing)
    skeleton = _skeleton(bridged)
    # Distance to the stroke's edge, counting the image border as an edge so
    # that a stroke cut by the border does not look twice as wide there.
    distance = _edge_distance(bridged)
    width = _stroke_width(distance, skeleton)
    if _touches_border(bridged):
        skeleton = _skeleton_to_border(bridged, width)

    def auto(value, default):
        return default if value is None else value

    return feature_graph_from_mask(
        skeleton,
        distance,
        kind=kind,
        prune_length=auto(params.prune_length, width + 3.0),
        prune_iterations=params.prune_iterations,
        min_component_length=auto(params.min_component_length, max(5.0, 2.0 * width)),
        junction_merge_distance=auto(params.junction_merge_distance, width + 2.0),
        smoothing=params.smoothing,
    )


def sketch_features(sketch: SketchMap, *, params: SketchParams = SketchParams()) -> FeatureMaps:
    """Ridges and valleys asked for by a sketch.

    Parameters
    ----------
    sketch : SketchMap
    params : SketchParams

    Returns
    -------
    FeatureMaps
        One acyclic graph per stroke colour, positions in sketch pixels
        ``(row, col)``; a colour without strokes gives an empty graph.
    """
    if not isinstance(sketch, SketchMap):
        raise ParamsError(f"sketch must be a SketchMap, got {type(sketch).__name__}")
    if not isinstance(params, SketchParams):
        raise ParamsError(f"params must be a SketchParams, got {type(params).__name__}")
    return FeatureMaps(
        ridges=_kept_stroke_graph(sketch.ridge_mask, "ridge", params),
        valleys=_kept_stroke_graph(sketch.valley_mask, "valley", params),
    )


#: Stroke graphs of the masks last analysed (:func:`_kept_stroke_graph`).
_GRAPHS = Memo(8)


def _kept_stroke_graph(mask: np.ndarray, kind: FeatureKind, params: SketchParams) -> FeatureGraph:
    """:func:`stroke_graph`, shared with earlier calls on the same mask.

    A stroke changes one colour of a sketch: the live update after it, the
    run after that and the sketch overlay all analyse the other colour's
    unchanged mask again.  Keyed by the mask's bytes, so an edited mask is
    never served an old graph; the kept graphs' points are read-only.
    """
    def make() -> FeatureGraph:
        graph = stroke_graph(mask, kind=kind, params=params)
        for path in graph.paths:
            path.points.flags.writeable = False
        return graph

    return _GRAPHS.get((array_key(mask), kind, params), make)
