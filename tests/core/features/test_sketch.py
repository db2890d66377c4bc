"""Sketch maps: reading, writing, resizing and stroke analysis."""

from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage
from skimage.draw import circle_perimeter_aa, line_aa

from terrasynth_core import ParamsError, SketchError
from terrasynth_core.features.sketch import (
    SketchMap,
    SketchParams,
    read_sketch,
    save_sketch,
    sketch_features,
)

SKETCHES = Path(__file__).parents[3] / "resources" / "sketches"
Y_ARMS = [((150, 150), (40, 60)), ((150, 150), (40, 240)), ((150, 150), (280, 150))]


# -- synthetic drawing -------------------------------------------------------
def _segment_coverage(shape, segments, width) -> np.ndarray:
    """1 where a pixel centre lies within width/2 of a segment (a round-capped brush)."""
    rr, cc = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    out = np.zeros(shape)
    for (r0, c0), (r1, c1) in segments:
        d = np.array([r1 - r0, c1 - c0], float)
        t = np.clip(((rr - r0) * d[0] + (cc - c0) * d[1]) / (d @ d), 0, 1)
        dist = np.hypot(rr - r0 - t * d[0], cc - c0 - t * d[1])
        out[dist <= width / 2] = 1.0
    return out


def _ring_coverage(shape, centre, radius, width) -> np.ndarray:
    rr, cc = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    return (np.abs(np.hypot(rr - centre[0], cc - centre[1]) - radius) <= width / 2).astype(float)


def _paint(alpha: np.ndarray, colour=(255, 0, 0)) -> np.ndarray:
    """Blend a stroke of coverage ``alpha`` onto white, like a paint program."""
    rgb = 255.0 * (1 - alpha[..., None]) + np.array(colour, float) * alpha[..., None]
    return np.rint(rgb).astype(np.uint8)


def _draw_y(width: int, shape=(300, 300)) -> np.ndarray:
    """An anti-aliased red Y: line_aa for 1 px, a blurred brush otherwise."""
    if width == 1:
        alpha = np.zeros(shape)
        for (r0, c0), (r1, c1) in Y_ARMS:
            rr, cc, v = line_aa(r0, c0, r1, c1)
            alpha[rr, cc] = np.maximum(alpha[rr, cc], v)
    else:
        alpha = ndimage.gaussian_filter(_segment_coverage(shape, Y_ARMS, width), 1.0)
    return _paint(alpha)


def _draw_ring(width: int, shape=(300, 300), radius=100) -> np.ndarray:
    if width == 1:
        alpha = np.zeros(shape)
        rr, cc, v = circle_perimeter_aa(150, 150, radius)
        alpha[rr, cc] = v
    else:
        alpha = ndimage.gaussian_filter(_ring_coverage(shape, (150, 150), radius, width), 1.0)
    return _paint(alpha)


def _degrees(graph) -> list[int]:
    return sorted(n.degree for n in graph.nodes)


def _check_graph(graph) -> None:
    assert graph.is_acyclic()
    for node in graph.nodes:
        assert node.degree == len(graph.neighbours(node.id))
        assert node.type == ("end" if node.degree == 1 else "branch")


# -- the bundled sketches ----------------------------------------------------
def test_y_junction_sketch():
    maps = sketch_features(read_sketch(SKETCHES / "y_junction_512.png"))
    _check_graph(maps.ridges)
    assert _degrees(maps.ridges) == [1, 1, 1, 3]
    assert len(maps.ridges.paths) == 3
    assert not maps.valleys.paths and not maps.valleys.nodes


def test_ring_cross_sketch():
    sketch = read_sketch(SKETCHES / "ring_cross_512.png")
    maps = sketch_features(sketch)
    ridges, valleys = maps.ridges, maps.valleys
    _check_graph(ridges)
    _check_graph(valleys)
    # The ring is broken into a tree: one open path along almost all of it.
    assert len(ridges.paths) == 1 and _degrees(ridges) == [1, 1]
    rows, cols = np.nonzero(sketch.ridge_mask)
    radius = np.hypot(rows - rows.mean(), cols - cols.mean()).mean()
    assert ridges.paths[0].length >= 0.97 * 2 * np.pi * radius
    # The cross is one degree-4 branch, not two 3-way junctions.
    assert _degrees(valleys) == [1, 1, 1, 1, 4]
    centre = [n for n in valleys.nodes if n.type == "branch"][0]
    assert abs(centre.row - 256) <= 3 and abs(centre.col - 256) <= 3


def test_s_valley_sketch():
    sketch = read_sketch(SKETCHES / "s_valley_1000.png")
    maps = sketch_features(sketch)
    assert len(maps.valleys.paths) == 1 and maps.valleys.count("branch") == 0
    assert maps.valleys.paths[0].length > 1400
    # Both S ridges leave the canvas and come back, so the image holds four
    # red strokes; each must be exactly one path without spurious branches.
    _, n_strokes = ndimage.label(sketch.ridge_mask, structure=np.ones((3, 3)))
    assert n_strokes == 4
    assert len(maps.ridges.paths) == n_strokes and maps.ridges.count("branch") == 0
    assert maps.ridges.is_acyclic()


# -- synthetic strokes -------------------------------------------------------
@pytest.mark.parametrize("width", [1, 3, 10, 20])
def test_y_of_any_stroke_width(width):
    ridges = sketch_features(SketchMap.from_rgb(_draw_y(width))).ridges
    _check_graph(ridges)
    assert _degrees(ridges) == [1, 1, 1, 3]
    branch = [n for n in ridges.nodes if n.type == "branch"][0]
    assert np.hypot(branch.row - 150, branch.col - 150) <= width / 2 + 4
    # Each arm reaches close to where it was drawn to.
    ends = np.array([(n.row, n.col) for n in ridges.nodes if n.type == "end"])
    for _, tip in Y_ARMS:
        assert np.hypot(*(ends - tip).T).min() <= width / 2 + 4


@pytest.mark.parametrize("width", [1, 3, 10, 20])
def test_ring_of_any_stroke_width_becomes_one_path(width):
    ridges = sketch_features(SketchMap.from_rgb(_draw_ring(width))).ridges
    _check_graph(ridges)
    assert len(ridges.paths) == 1 and _degrees(ridges) == [1, 1]
    assert ridges.paths[0].length >= 0.95 * 2 * np.pi * 100
    # The two ends face each other across the break.
    a, b = ridges.nodes
    assert np.hypot(a.row - b.row, a.col - b.col) <= 3


def test_ring_breaks_where_it_is_thinnest():
    coverage = np.maximum(_ring_coverage((300, 300), (150, 150), 100, 4), 0)
    thick = _ring_coverage((300, 300), (150, 150), 100, 12)
    rr, cc = np.mgrid[0:300, 0:300]
    thin_part = (rr > 200) & (np.abs(cc - 150) < 30)  # bottom of the ring stays 4 px
    mask = np.where(thin_part, coverage, thick) > 0.5
    ridges = sketch_features(SketchMap(mask, np.zeros_like(mask))).ridges
    assert _degrees(ridges) == [1, 1]
    for node in ridges.nodes:
        assert node.row > 240 and abs(node.col - 150) < 30


@pytest.mark.parametrize("width", [1, 3, 10, 20])
@pytest.mark.parametrize("gap", [2, 3])
def test_small_gaps_are_closed(width, gap):
    alpha = _segment_coverage((300, 300), Y_ARMS, width)
    alpha[210 : 210 + gap, :] = 0  # across the stem
    # Across the upper left arm, perpendicular to it, 50 px from its tip.
    rr, cc = np.mgrid[0:300, 0:300]
    (r0, c0), (r1, c1) = Y_ARMS[0][1], Y_ARMS[0][0]
    along = ((rr - r0) * (r1 - r0) + (cc - c0) * (c1 - c0)) / np.hypot(r1 - r0, c1 - c0)
    alpha[(along >= 50) & (along < 50 + gap) & (cc < 140)] = 0
    mask = alpha > 0.5
    assert ndimage.label(mask, structure=np.ones((3, 3)))[1] == 3
    ridges = sketch_features(SketchMap(mask, np.zeros_like(mask))).ridges
    assert _degrees(ridges) == [1, 1, 1, 3]


def test_gap_closing_zero_keeps_gaps():
    alpha = _segment_coverage((300, 300), Y_ARMS, 3)
    alpha[210:213, :] = 0
    mask = alpha > 0.5
    ridges = sketch_features(SketchMap(mask, np.zeros_like(mask)), params=SketchParams(gap_closing=0)).ridges
    assert len(ridges.paths) == 4 and ridges.count("branch") == 1


@pytest.mark.parametrize("width", [1, 5, 15])
def test_strokes_running_off_the_border(width):
    arms = [((100, 150), (-20, 60)), ((100, 150), (-20, 240)), ((100, 150), (220, 150))]
    mask = _segment_coverage((200, 300), arms, width) > 0.5
    ridges = sketch_features(SketchMap(mask, np.zeros_like(mask))).ridges
    assert _degrees(ridges) == [1, 1, 1, 3]
    ends = [n for n in ridges.nodes if n.type == "end"]
    assert sum(n.row <= 1.0 for n in ends) == 2 and sum(n.row >= 198.0 for n in ends) == 1


@pytest.mark.parametrize("width", [1, 4, 12])
def test_stroke_along_the_border_is_kept(width):
    mask = np.zeros((100, 200), dtype=bool)
    mask[:width, 20:180] = True
    ridges = sketch_features(SketchMap(mask, np.zeros_like(mask))).ridges
    assert len(ridges.paths) == 1 and _degrees(ridges) == [1, 1]
    assert ridges.paths[0].length >= 160 - width - 4
    assert np.abs(ridges.paths[0].points[:, 0] - (width - 1) / 2).max() <= 1.5


@pytest.mark.parametrize("width", [3, 9, 16])
def test_thick_cross_is_one_degree_four_branch(width):
    arms = [((150, 60), (150, 240)), ((60, 152), (240, 152))]
    mask = _segment_coverage((300, 300), arms, width) > 0.5
    valleys = sketch_features(SketchMap(np.zeros_like(mask), mask)).valleys
    assert _degrees(valleys) == [1, 1, 1, 1, 4]


def test_specks_are_dropped_and_empty_sketch_gives_empty_graphs():
    mask = np.zeros((100, 100), dtype=bool)
    mask[50:53, 50:53] = True
    maps = sketch_features(SketchMap(mask, np.zeros_like(mask)))
    assert not maps.ridges.paths and not maps.ridges.nodes
    empty = SketchMap.empty((40, 60))
    assert not empty.has_strokes and empty.shape == (40, 60)
    maps = sketch_features(empty)
    assert maps.ridges.shape == (40, 60) and not maps.valleys.paths


# -- colours, files ----------------------------------------------------------
def test_from_rgb_thresholds():
    rgb = np.array(
        [[[255, 0, 0], [128, 127, 127], [127, 0, 0], [200, 128, 0]],
         [[0, 0, 255], [127, 127, 128], [0, 0, 127], [255, 255, 255]]],
        dtype=np.uint8,
    )
    sketch = SketchMap.from_rgb(rgb)
    np.testing.assert_array_equal(sketch.ridge_mask, [[1, 1, 0, 0], [0, 0, 0, 0]])
    np.testing.assert_array_equal(sketch.valley_mask, [[0, 0, 0, 0], [1, 1, 0, 0]])
    rgba = np.dstack([rgb, np.array([[255, 0, 255, 255], [127, 255, 255, 255]], np.uint8)])
    sketch = SketchMap.from_rgb(rgba)
    np.testing.assert_array_equal(sketch.ridge_mask, [[1, 0, 0, 0], [0, 0, 0, 0]])
    np.testing.assert_array_equal(sketch.valley_mask, [[0, 0, 0, 0], [0, 1, 0, 0]])
    with pytest.raises(SketchError, match="uint8"):
        SketchMap.from_rgb(rgb.astype(float))


def test_sketchmap_validation():
    a = np.zeros((10, 10), bool)
    with pytest.raises(SketchError, match="both"):
        SketchMap(~a, ~a)
    with pytest.raises(SketchError, match="shape"):
        SketchMap(a, np.zeros((10, 11), bool))
    with pytest.raises(SketchError, match="boolean"):
        SketchMap(a.astype(np.uint8), a)
    ridge = a.copy()
    sketch = SketchMap(ridge, a)
    ridge[0, 0] = True
    assert not sketch.ridge_mask.any()  # a private copy
    with pytest.raises(ValueError):
        sketch.ridge_mask[0, 0] = True


def test_save_and_read_round_trip(tmp_path):
    original = SketchMap.from_rgb(_draw_y(5))
    original = SketchMap(original.ridge_mask, np.roll(original.ridge_mask, 3, axis=1) & ~original.ridge_mask)
    path = save_sketch(original, tmp_path / "y.png")
    assert [p.name for p in tmp_path.iterdir()] == ["y.png"]  # no temporary left
    back = read_sketch(path)
    np.testing.assert_array_equal(back.ridge_mask, original.ridge_mask)
    np.testing.assert_array_equal(back.valley_mask, original.valley_mask)
    rgb = original.to_rgb()
    assert rgb.dtype == np.uint8 and (rgb[~(original.ridge_mask | original.valley_mask)] == 255).all()
    with pytest.raises(SketchError, match="cannot write sketch .*missing"):
        save_sketch(original, tmp_path / "missing" / "y.png")


def test_read_palette_and_rgba_images(tmp_path):
    rgb = SketchMap.from_rgb(_draw_y(5)).to_rgb()
    Image.fromarray(rgb).convert("P", palette=Image.Palette.ADAPTIVE, colors=4).save(tmp_path / "p.png")
    assert read_sketch(tmp_path / "p.png").ridge_mask.sum() == (rgb == (255, 0, 0)).all(axis=2).sum()
    rgba = np.dstack([rgb, np.full(rgb.shape[:2], 255, np.uint8)])
    rgba[:150, :, 3] = 0  # the upper half is transparent: no preference
    Image.fromarray(rgba).save(tmp_path / "a.png")
    sketch = read_sketch(tmp_path / "a.png")
    assert sketch.ridge_mask.any() and not sketch.ridge_mask[:150].any()


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: None, "does not exist"),
        (lambda p: p.write_text("not an image"), "not a readable image"),
        (lambda p: p.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 40), "not a readable image"),
        (lambda p: Image.fromarray(np.zeros((8, 8), np.uint8)).save(p), "grey-level"),
        (lambda p: Image.fromarray(np.zeros((8, 8), np.uint16)).save(p), "grey-level"),
    ],
)
def test_read_errors_name_the_file(tmp_path, make, message):
    path = tmp_path / "bad_sketch.png"
    make(path)
    with pytest.raises(SketchError, match=message) as info:
        read_sketch(path)
    assert "bad_sketch.png" in str(info.value)


# -- resizing ----------------------------------------------------------------
def test_thin_strokes_survive_downscaling():
    alpha = _segment_coverage((1000, 1000), [((100, 100), (900, 850))], 1)
    sketch = SketchMap(alpha > 0.5, np.zeros((1000, 1000), bool))
    small = sketch.resized((100, 100))
    assert small.shape == (100, 100)
    assert ndimage.label(small.ridge_mask, structure=np.ones((3, 3)))[1] == 1
    assert small.ridge_mask.sum() >= 75
    assert len(sketch_features(small).ridges.paths) == 1


def test_resizing_keeps_masks_disjoint_and_upscales():
    ridge = np.zeros((20, 20), bool)
    ridge[:, 9] = True
    valley = np.zeros((20, 20), bool)
    valley[:, 10:12] = True
    small = SketchMap(ridge, valley).resized((10, 10))
    assert not (small.ridge_mask & small.valley_mask).any()
    assert small.valley_mask[:, 5].all() and small.ridge_mask[:, 4].all()
    big = SketchMap(ridge, valley).resized((40, 40))
    assert big.ridge_mask[:, 18:20].all() and big.valley_mask[:, 20:24].all()
    assert big.ridge_mask.sum() == 80 and big.valley_mask.sum() == 160
    with pytest.raises(SketchError, match="size"):
        small.resized((0, 10))


# -- parameters --------------------------------------------------------------
@pytest.mark.parametrize(
    ("field", "value"),
    [("gap_closing", -1), ("gap_closing", 2.5), ("prune_length", -3.0), ("prune_iterations", 101),
     ("min_component_length", float("nan")), ("junction_merge_distance", "4"), ("smoothing", -1)],
)
def test_sketch_params_validation(field, value):
    with pytest.raises(ParamsError, match=f"SketchParams.{field}"):
        SketchParams(**{field: value})


def test_sketch_features_rejects_wrong_types():
    with pytest.raises(ParamsError, match="SketchMap"):
        sketch_features(np.zeros((10, 10), bool))
    with pytest.raises(ParamsError, match="SketchParams"):
        sketch_features(SketchMap.empty((10, 10)), params=None)


def test_sketch_in_other_colours_is_refused_but_a_blank_canvas_is_not(tmp_path):
    """The paper's convention (white ridges, black valleys on grey) or any
    other colours: a clear error naming the colours expected."""
    grey = np.full((120, 120, 3), 128, np.uint8)
    grey[60, 10:110] = 255
    grey[10:110, 30] = 0
    Image.fromarray(grey).save(tmp_path / "paper_style.png")
    with pytest.raises(SketchError, match=r"paper_style.png has no red or blue strokes.*paint ridges red"):
        read_sketch(tmp_path / "paper_style.png")
    Image.fromarray(np.full((50, 50, 3), 255, np.uint8)).save(tmp_path / "blank.png")
    assert not read_sketch(tmp_path / "blank.png").has_strokes


@pytest.mark.parametrize("rows", [513, 1025])
def test_a_sketch_read_in_bands_keeps_every_row(tmp_path, rows):
    """Images are classified band by band: a last band of one row is read too."""
    from PIL import Image

    rgb = np.full((rows, 40, 3), 255, np.uint8)
    rgb[-1, 5:30] = (255, 0, 0)  # a ridge on the very last row
    rgb[0, 5:30] = (0, 0, 255)
    Image.fromarray(rgb).save(tmp_path / "tall.png")
    sketch = read_sketch(tmp_path / "tall.png")
    assert sketch.shape == (rows, 40)
    assert sketch.ridge_mask[-1, 5:30].all() and sketch.ridge_mask.sum() == 25
    assert sketch.valley_mask[0, 5:30].all() and sketch.valley_mask.sum() == 25


def _stroke_masks_for_speedups():
    """Masks the sketch analysis's shortcuts must treat as the plain
    filters do: thin and thick strokes, strokes on the border, a filled
    area (far from the background), a single pixel, nothing."""
    rng = np.random.default_rng(3)
    masks = []
    for i in range(8):
        shape = tuple(int(v) for v in rng.integers(40, 220, 2))
        field = ndimage.gaussian_filter(rng.random(shape), rng.uniform(1.0, 5.0))
        masks.append(field > np.quantile(field, rng.uniform(0.7, 0.97)))
    blob = np.zeros((300, 260), bool)
    blob[20:290, 30:250] = True  # pixels up to 110 from the background: the window must grow
    blob[0:3, :] = True
    masks += [blob, np.pad(np.ones((1, 1), bool), 5), np.zeros((50, 60), bool), np.ones((30, 30), bool)]
    return masks


def test_stroke_analysis_shortcuts_equal_the_plain_filters():
    """The gap bridging, thinning and edge distance work on the strokes'
    box or tiles only; they give the whole image's filters' pixels and
    distances exactly."""
    from skimage.morphology import disk, skeletonize

    from terrasynth_core.features import sketch as sk

    for mask in _stroke_masks_for_speedups():
        for gap in (0, 3, 7):
            radius = (gap + 1) // 2
            plain = mask.copy() if radius == 0 else ndimage.binary_dilation(mask, structure=disk(radius))
            np.testing.assert_array_equal(sk._bridge_gaps(mask, gap), plain)
        np.testing.assert_array_equal(sk._skeleton(mask), skeletonize(mask))
        np.testing.assert_array_equal(sk._edge_distance(mask),
                                      ndimage.distance_transform_edt(np.pad(mask, 1))[1:-1, 1:-1])


def test_an_unchanged_colour_is_not_analysed_again(monkeypatch):
    """A stroke changes one colour: the other colour's graph is the one
    made before (the same object, read-only points); the changed colour's
    is made afresh and equals a plain analysis."""
    from terrasynth_core.features import sketch as sk

    monkeypatch.setattr(sk, "_GRAPHS", sk.Memo(8))
    ridge = np.zeros((120, 140), bool)
    ridge[30:34, 10:120] = True
    valley = np.zeros_like(ridge)
    valley[80:84, 20:130] = True
    first = sketch_features(SketchMap(ridge, valley))
    ridge2 = ridge.copy()
    ridge2[34:70, 60:63] = True  # a new ridge stroke, joined to the first
    second = sketch_features(SketchMap(ridge2, valley))
    assert second.valleys is first.valleys and second.ridges is not first.ridges
    assert not second.valleys.paths[0].points.flags.writeable
    plain = sk.stroke_graph(ridge2, kind="ridge")
    assert second.ridges.nodes == plain.nodes
    assert [p.points.tobytes() for p in second.ridges.paths] == [p.points.tobytes() for p in plain.paths]
    assert len(second.ridges.nodes) > len(first.ridges.nodes)
