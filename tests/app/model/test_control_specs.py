"""The document model's artist controls without Qt: style regions, water,
pins, stamps, selection, requests and project files."""

import dataclasses
import io
import json
import zipfile

import numpy as np
import pytest

from terrasynth_core.errors import ParamsError, SketchError
from terrasynth_core.synthesis import Pin, SynthesisParams
from terrasynth_core.controls.stamps import render_stamp
from terrasynth_app.model import (Document, ExampleRef, RecoveryStore, Sketch, StampSpec, TerrainResult,
                                  fitting_scale, load_project, save_project)

WHITE = ExampleRef(builtin="white-mountains", crop=(400, 700, 400, 700))
GABON = ExampleRef(builtin="gabon-plateau", crop=(0, 300, 0, 300))
HELENS = ExampleRef(builtin="st-helens")


def _document(shape=(96, 96)):
    sketch = Sketch.blank(shape)
    sketch.draw_polyline([(20, 10), (20, 80)], "ridge", radius=2, hardness=1.0)
    sketch.history.clear()
    return Document(sketch, [WHITE], params=SynthesisParams(patch_size=32, k=3, seed=5))


# -- region layers --------------------------------------------------------------------------
def test_region_brushes_paint_their_own_layer_as_one_undo_step_each():
    sketch = Sketch.blank((40, 40))
    sketch.draw_polyline([(20, 0), (20, 39)], "ridge", radius=2, hardness=1.0)
    ridge = sketch.ridge.copy()
    sketch.draw_polyline([(10, 5), (10, 35)], "style", radius=3, style=7)
    assert sketch.style[10, 5:36].tolist() == [7] * 31
    assert sketch.style[14, 20] == -1 and sketch.style[13, 20] == 7  # the stroked cells: within the radius
    sketch.draw_polyline([(30, 5), (30, 35)], "water", radius=3)
    assert sketch.water[30, 5:36].all() and sketch.water.sum() == (sketch.style == 7).sum()
    np.testing.assert_array_equal(sketch.ridge, ridge)  # region tools leave strokes alone
    sketch.draw_polyline([(30, 20), (30, 35)], "water_erase", radius=3)
    sketch.draw_polyline([(10, 5), (10, 10)], "style_erase", radius=3)
    assert not sketch.water[30, 20:36].any() and sketch.water[30, 5:15].all()
    assert (sketch.style[10, :8] == -1).all() and sketch.style[10, 20] == 7
    for _ in range(2):
        assert sketch.undo()
    assert sketch.water[30, 5:36].all() and sketch.style[10, 5] == 7
    assert sketch.undo() and not sketch.has_water
    assert sketch.undo() and (sketch.style == -1).all()
    np.testing.assert_array_equal(sketch.ridge, ridge)
    sketch.redo()
    assert sketch.style[10, 20] == 7


def test_the_style_brush_needs_a_style_and_layers_are_checked():
    with pytest.raises(ValueError, match="style id"):
        Sketch.blank((10, 10)).begin_stroke("style", 5, 5)
    with pytest.raises(SketchError, match="water layer"):
        Sketch(np.zeros((5, 5), np.uint8), np.zeros((5, 5), np.uint8), water=np.zeros((5, 6), bool))
    with pytest.raises(SketchError, match="style layer holds"):
        Sketch(np.zeros((5, 5), np.uint8), np.zeros((5, 5), np.uint8), style=np.full((5, 5), -3))


def test_a_new_sketch_size_resizes_regions_and_clear_keeps_them():
    sketch = Sketch.blank((40, 60))
    sketch.draw_polyline([(10, 0), (10, 59)], "water", radius=4)
    sketch.draw_polyline([(30, 30), (30, 31)], "style", radius=6, style=2)
    sketch.clear()
    assert sketch.has_water and (sketch.style == 2).any()
    sketch.replace(np.zeros((80, 120), np.uint8), np.zeros((80, 120), np.uint8))
    assert sketch.shape == (80, 120) and sketch.water.shape == (80, 120)
    assert sketch.water[20, :].all() and not sketch.water[60, :].any()
    assert sketch.style[60, 61] == 2
    sketch.undo()
    assert sketch.style.shape == (40, 60) and sketch.water[10].all()


def test_regions_overlay_colours_styles_and_draws_water_over_them():
    sketch = Sketch(np.zeros((4, 4), np.uint8), np.zeros((4, 4), np.uint8),
                    style=np.array([[0, 0, 3, 3], [0, 0, 3, 3], [9, 9, -1, -1], [-1, -1, -1, -1]]),
                    water=np.eye(4, dtype=bool)[::-1])
    rgba = sketch.regions_rgba({0: (255, 0, 0), 3: (0, 255, 0)})
    assert rgba.dtype == np.uint8 and rgba.shape == (4, 4, 4)
    assert rgba[0, 0].tolist() == [255, 0, 0, 110] and rgba[1, 3].tolist() == [0, 255, 0, 110]
    assert rgba[2, 0, 3] == 0  # id 9 has no style: clear
    assert rgba[3, 0].tolist() == [30, 110, 230, 150] and rgba[0, 3].tolist() == [30, 110, 230, 150]
    assert rgba[3, 3, 3] == 0
    np.testing.assert_array_equal(sketch.regions_rgba({0: (255, 0, 0)}, (0, 2, 1, 3)),
                                  sketch.regions_rgba({0: (255, 0, 0)})[0:2, 1:3])


# -- styles ------------------------------------------------------------------------------------
def test_styles_get_fresh_ids_and_distinct_colours():
    doc = _document()
    events = []
    doc.changed.connect(events.append)
    a = doc.add_style(GABON, relief_scale=0.5)
    b = doc.add_style(HELENS, name="volcano", base=1200)
    assert (a.id, b.id) == (0, 1) and a.color != b.color and b.name == "volcano"
    assert a.name == GABON.label and "styles" in events and doc.dirty
    doc.sketch.draw_polyline([(50, 50), (50, 60)], "style", radius=3, style=b.id)
    doc.remove_style(b.id)
    c = doc.add_style(HELENS)
    assert c.id == 2  # id 1 is still painted somewhere: never reused
    doc.sketch.undo()  # the id-1 strokes are gone, but the id stays burnt
    doc.remove_style(c.id)
    assert doc.add_style(HELENS).id == 3
    assert doc.update_style(a.id, relief_scale=2.0).relief_scale == 2.0
    with pytest.raises(ParamsError, match="relief scale"):
        doc.update_style(a.id, relief_scale=0.0)
    with pytest.raises(ParamsError, match="id"):
        doc.update_style(a.id, id=5)
    with pytest.raises(SketchError, match="#RRGGBB"):
        doc.update_style(a.id, color="orange")


def test_the_request_maps_painted_style_ids_to_core_indices():
    doc = _document()
    unused = doc.add_style(HELENS)
    gabon = doc.add_style(GABON, relief_scale=0.5)
    request = doc.synthesis_request()
    assert request.styles == () and request.style_map is None and request.water is None
    doc.sketch.draw_polyline([(60, 0), (60, 95)], "style", radius=12, style=gabon.id)
    doc.sketch.draw_polyline([(5, 90), (6, 90)], "style", radius=3, style=99)  # a removed style's id
    doc.sketch.draw_polyline([(90, 0), (90, 40)], "water", radius=4)
    doc.set_water_level(400)
    doc.set_height_range((200, 1400))
    doc.add_pin(30, 30, 900)
    request = doc.synthesis_request()
    assert request.styles == (gabon,) and unused not in request.styles
    assert request.style_map.dtype == np.int16
    np.testing.assert_array_equal(request.style_map == 0, doc.sketch.style == gabon.id)
    assert (request.style_map[doc.sketch.style != gabon.id] == -1).all()
    np.testing.assert_array_equal(request.water, doc.sketch.water)
    assert request.water_level == 400 and request.height_range == (200, 1400)
    assert request.pins == (Pin(30, 30, 900.0),)
    controls = request.make_controls()
    assert controls.styles[0].relief_scale == 0.5 and controls.water.level == 400
    session = request.make_session()  # the core accepts it all
    assert session.controls.style_map.shape == (96, 96)


def test_without_examples_styles_must_cover_every_cell():
    doc = _document()
    doc.set_examples([])
    with pytest.raises(ParamsError, match="no example"):
        doc.synthesis_request()
    style = doc.add_style(GABON)
    doc.sketch.replace_regions(style=np.full((96, 96), style.id))
    request = doc.synthesis_request()
    assert (request.style_map == 0).all() and request.examples == ()


def test_water_level_and_height_range_are_checked():
    doc = _document()
    with pytest.raises(ParamsError, match="water level"):
        doc.set_water_level(float("nan"))
    with pytest.raises(ParamsError, match="LO < HI"):
        doc.set_height_range((500, 100))
    assert doc.suggested_water_level() is None  # no terrain yet
    heights = np.add.outer(np.arange(96.0), np.zeros(96)).astype(np.float32)
    doc.set_result(TerrainResult(heights, np.zeros((96, 96)), np.zeros((96, 96), bool)))
    assert doc.suggested_water_level() == pytest.approx(9.0)
    doc.sketch.draw_polyline([(80, 0), (80, 95)], "water", radius=1)
    assert doc.suggested_water_level() == pytest.approx(80)


# -- pins and stamps ------------------------------------------------------------------------------
def test_pins_one_per_cell_inside_the_output():
    doc = _document()
    doc.add_pin(10, 10, 500)
    doc.add_pin(40, 50, 800)
    doc.add_pin(10, 10, 650)  # the same cell: replaced
    assert [(p.row, p.col, p.height) for p in doc.pins] == [(40, 50, 800), (10, 10, 650)]
    doc.update_pin(0, 820)
    assert doc.pins[0].height == 820
    doc.remove_pin(1)
    assert doc.pins == [Pin(40, 50, 820.0)]
    with pytest.raises(ParamsError, match="outside the 96x96"):
        doc.add_pin(96, 0, 100)


@pytest.mark.parametrize("cell, scale", [(None, 0.25), (90.0, 0.75)])
@pytest.mark.parametrize("rotation", [0.0, 30.0, 90.0])
def test_stamp_footprint_outlines_the_cells_the_core_stamps(rotation, cell, scale):
    field = HELENS.load()
    spec = StampSpec(HELENS, (100.0, 120.0), field.shape, rotation=rotation, scale=scale)
    corners = spec.footprint(cell)  # at 90 m, the 30 m DEM at its true size: a third
    assert corners.shape == (5, 2) and np.array_equal(corners[0], corners[-1])
    rendered = render_stamp(spec.to_core(), (240, 260), 32, cell_size=cell)
    r0, r1, c0, c1 = rendered.bbox
    rows, cols = np.nonzero(rendered.valid)
    # Every stamped cell lies within the outline's bounds (one cell of slack for the grid).
    assert corners[:, 0].min() - 1 <= rows.min() + r0 and rows.max() + r0 <= corners[:, 0].max() + 1
    assert corners[:, 1].min() - 1 <= cols.min() + c0 and cols.max() + c0 <= corners[:, 1].max() + 1
    # ... and fill them: the bounds are tight (resampling drops a partial cell at each edge).
    assert rows.max() - rows.min() >= np.ptp(corners[:, 0]) - (3 if cell is None else 5)
    if rotation == 30.0:
        # The core's topmost stamped cells sit at the outline's topmost corner,
        # which a counter-clockwise turn on screen moves right of the centre
        # (it was the top-right corner).
        top = corners[np.argmin(corners[:4, 0])]
        assert abs(cols[rows == rows.min()].mean() + c0 - top[1]) < 2 and top[1] > 120


def test_stamps_are_edited_in_place_and_checked():
    doc = _document()
    doc.add_stamp(StampSpec(HELENS, (48, 48), (460, 317), scale=fitting_scale((460, 317), (96, 96))))
    assert doc.stamps[0].scale == pytest.approx(0.08)
    doc.update_stamp(0, rotation=45, scale=0.1)
    assert (doc.stamps[0].rotation, doc.stamps[0].scale) == (45.0, 0.1)
    with pytest.raises(ParamsError, match="scale"):
        doc.update_stamp(0, scale=50)
    with pytest.raises(ParamsError, match="outside"):
        doc.add_stamp(StampSpec(HELENS, (-5, 48), (460, 317)))
    doc.remove_stamp(0)
    assert doc.stamps == []


# -- selection and re-synthesis -------------------------------------------------------------------
def test_selection_is_transient_and_cleared_by_a_new_size():
    doc = _document()
    events = []
    doc.changed.connect(events.append)
    doc.select_rect(10, 30, 20, 50)
    doc.select_rect(60, 200, 60, 200, add=True)
    sel = doc.selection
    assert sel.sum() == 20 * 30 + 36 * 36 and not sel.flags.writeable
    doc.paint_selection((80, 5), (80, 20), radius=2, add=True)
    assert doc.selection[80, 5:21].all()
    doc.paint_selection((80, 5), (80, 20), radius=2, add=False)
    assert not doc.selection[78:83, 3:23].any()
    assert events == ["selection"] * 4 and not doc.dirty  # selecting is not an edit
    doc.clear_selection()
    assert doc.selection is None
    doc.select_rect(0, 10, 0, 10)
    doc.sketch.replace(np.zeros((50, 50), np.uint8), np.zeros((50, 50), np.uint8))
    assert doc.selection is None


def test_resynthesis_request_needs_a_terrain_and_a_selection():
    doc = _document()
    with pytest.raises(ParamsError, match="synthesize one first"):
        doc.resynthesis_request(seed=9)
    heights = np.random.default_rng(0).normal(500, 50, (96, 96)).astype(np.float32)
    doc.set_result(TerrainResult(heights, np.zeros((96, 96)), np.zeros((96, 96), bool)))
    with pytest.raises(ParamsError, match="nothing is selected"):
        doc.resynthesis_request(seed=9)
    doc.select_rect(30, 60, 30, 60)
    request = doc.resynthesis_request(seed=9)
    assert request.params.seed == 9 and doc.params.seed == 5
    assert request.previous is doc.result.heights and request.selection.sum() == 900
    controls = request.make_controls()
    assert controls.resynthesis
    # An automatic patch size: the one the terrain was made with.
    doc.set_params(dataclasses.replace(doc.params, patch_size=None))
    doc.set_result(TerrainResult(heights, np.zeros((96, 96)), np.zeros((96, 96), bool),
                                 report={"params": {"patch_size": 56}}))
    doc.select_rect(30, 60, 30, 60)
    assert doc.resynthesis_request(seed=9).params.patch_size == 56
    doc.sketch.replace(np.zeros((64, 64), np.uint8), np.zeros((64, 64), np.uint8))
    doc.select_rect(0, 10, 0, 10)
    with pytest.raises(ParamsError, match="synthesize it again"):
        doc.resynthesis_request(seed=9)


# -- files --------------------------------------------------------------------------------------
def _full_document():
    doc = _document()
    style = doc.add_style(GABON, relief_scale=0.6, base=350.0)
    doc.sketch.draw_polyline([(60, 0), (60, 95)], "style", radius=10, style=style.id)
    doc.sketch.draw_polyline([(90, 0), (90, 50)], "water", radius=3)
    doc.set_water_level(250.5)
    doc.set_height_range((100, 1500))
    doc.add_pin(10, 20, 1234.5)
    doc.add_stamp(StampSpec(HELENS, (40.5, 60.0), (460, 317), rotation=15, scale=0.1))
    return doc


def test_project_round_trip_keeps_every_control(tmp_path):
    doc = _full_document()
    heights = np.random.default_rng(1).normal(500, 50, (96, 96)).astype(np.float32)
    report = {"params": {"seed": 5}, "pins": [{"row": 10, "col": 20, "target": 1234.5, "height": 1230.0,
                                                "error": -4.5}]}
    doc.set_result(TerrainResult(heights, np.zeros((96, 96)), np.zeros((96, 96), bool), report=report,
                                 pin_errors=TerrainResult.pin_errors_of(report)))
    path = tmp_path / "all.tsproj"
    save_project(doc, path)
    got = load_project(path)
    np.testing.assert_array_equal(got.sketch.style, doc.sketch.style)
    np.testing.assert_array_equal(got.sketch.water, doc.sketch.water)
    assert got.styles == doc.styles and got.stamps == doc.stamps and got.pins == doc.pins
    assert (got.water_level, got.height_range) == (250.5, (100.0, 1500.0))
    assert got.result.pin_errors == doc.result.pin_errors and got.result.pin_errors[0].error == -4.5
    assert got.result.seed == 5 and got.next_style_id == doc.next_style_id and not got.dirty
    assert got.synthesis_request().styles == doc.synthesis_request().styles


def test_a_version_1_project_still_loads(tmp_path):
    doc = _document()
    path = tmp_path / "new.tsproj"
    save_project(doc, path)
    old = tmp_path / "old.tsproj"
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(old, "w") as dst:
        meta = json.loads(src.read("project.json"))
        meta["version"] = 1
        for key in ("styles", "next_style_id", "water_level", "height_range", "pins", "stamps"):
            del meta[key]
        dst.writestr("project.json", json.dumps(meta))
        for name in ("sketch_ridge.npy", "sketch_valley.npy"):
            dst.writestr(name, src.read(name))
    got = load_project(old)
    np.testing.assert_array_equal(got.sketch.ridge, doc.sketch.ridge)
    assert (got.sketch.style == -1).all() and not got.sketch.has_water
    assert got.styles == [] and got.pins == [] and got.stamps == [] and got.height_range is None


def test_a_damaged_style_entry_is_reported_with_the_file(tmp_path):
    doc = _full_document()
    path = tmp_path / "p.tsproj"
    save_project(doc, path)
    buf = io.BytesIO()
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(buf, "w") as dst:
        for name in src.namelist():
            data = src.read(name)
            if name == "project.json":
                meta = json.loads(data)
                meta["styles"][0]["relief_scale"] = -1
                data = json.dumps(meta)
            dst.writestr(name, data)
    path.write_bytes(buf.getvalue())
    with pytest.raises(Exception, match="p.tsproj.*relief scale"):
        load_project(path)


def test_recovery_keeps_the_controls(tmp_path):
    doc = _full_document()
    store = RecoveryStore(tmp_path / "rec")
    store.save(doc)
    got = store.load()
    assert got.dirty and got.styles == doc.styles and got.stamps == doc.stamps and got.pins == doc.pins
    np.testing.assert_array_equal(got.sketch.water, doc.sketch.water)
