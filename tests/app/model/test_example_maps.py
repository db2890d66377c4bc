"""The built-in Middle-earth map as a document, and style-region and
water-mask PNGs imported into a document's layers (model and GUI)."""

import json

import numpy as np
import pytest
from PIL import Image
from PySide6.QtWidgets import QMessageBox

from terrasynth_core.errors import ParamsError, SketchError
from terrasynth_core.examples import resource_path
from terrasynth_core.presets import load_preset
from terrasynth_app.model import (Document, ExampleRef, Sketch, example_map_document, load_project, save_project,
                                  style_layer_from_png, water_layer_from_png)

GABON = ExampleRef(builtin="gabon-plateau", crop=(0, 300, 0, 300))


@pytest.fixture(scope="module")
def preset():
    return load_preset("middle-earth")


@pytest.fixture(scope="module")
def middle_earth():
    """The map's JSON, as written."""
    return json.loads(resource_path("sketches", "middle_earth.json").read_text(encoding="utf-8"))


def _write_rgb(path, rgb):
    Image.fromarray(np.asarray(rgb, np.uint8)).save(path)
    return path


def _two_style_document(shape=(160, 160)):
    doc = Document(Sketch.blank(shape), [GABON])
    first = doc.add_style(GABON, color="#ff8000")
    second = doc.add_style(ExampleRef(builtin="white-mountains"), color="#008040")
    return doc, first, second


def _region_png(path, size=80):
    """Left half near the first style's orange, right half exactly the
    second's green, with a grey band of no style's colour across the middle."""
    rgb = np.zeros((size, size, 3), np.uint8)
    rgb[:, : size // 2] = (250, 130, 10)
    rgb[:, size // 2:] = (0, 128, 64)
    rgb[size // 2 - 5: size // 2 + 5] = (128, 128, 128)
    return _write_rgb(path, rgb)


def _water_png(path, size=80):
    """Black water in the bottom quarter on white."""
    rgb = np.full((size, size, 3), 255, np.uint8)
    rgb[3 * size // 4:] = 0
    return _write_rgb(path, rgb)


# -- model ------------------------------------------------------------------------------
def test_middle_earth_document_matches_the_preset(preset, middle_earth):
    doc = example_map_document("middle-earth")
    assert doc.output_shape == preset.shape == tuple(middle_earth["shape"])
    assert doc.examples == [] and not doc.dirty and doc.path is None
    assert [s.id for s in doc.styles] == [0, 1, 2, 3] and doc.next_style_id == 4
    assert [s.color for s in doc.styles] == list(middle_earth["styles"])
    assert [s.name for s in doc.styles] == [middle_earth["style_names"][c] for c in middle_earth["styles"]]
    assert [f"builtin:{s.example.builtin}" for s in doc.styles] == list(middle_earth["styles"].values())
    np.testing.assert_array_equal(doc.sketch.style, preset.controls.style_map)
    np.testing.assert_array_equal(doc.sketch.water, preset.controls.water.mask)
    assert doc.sketch.has_water and doc.water_level == preset.controls.water.level == 60.0
    np.testing.assert_array_equal(doc.sketch.to_sketch_map().ridge_mask, preset.sketch.ridge_mask)
    np.testing.assert_array_equal(doc.sketch.to_sketch_map().valley_mask, preset.sketch.valley_mask)
    (stamp,) = doc.stamps
    (core_stamp,) = preset.controls.stamps
    assert stamp.example == ExampleRef(builtin="st-helens")
    assert stamp.center == core_stamp.center and stamp.scale == core_stamp.scale
    assert stamp.rotation == core_stamp.rotation and stamp.source_shape == core_stamp.field.shape
    assert doc.pins == list(preset.controls.pins) and len(doc.pins) == 3
    assert not doc.sketch.can_undo
    request = doc.synthesis_request()  # every cell is styled: no plain example is needed
    assert len(request.styles) == 4 and request.style_map.min() == 0


def test_middle_earth_project_names_the_builtin_dems(tmp_path, preset):
    path = save_project(example_map_document("middle-earth"), tmp_path / "me.tsproj")
    loaded = load_project(path)
    assert [s.example for s in loaded.styles] == [ExampleRef(builtin=k) for k in
                                                  ("himalaya", "white-mountains", "gabon-plateau", "big-tujunga")]
    assert loaded.stamps[0].example == ExampleRef(builtin="st-helens")
    np.testing.assert_array_equal(loaded.sketch.style, preset.controls.style_map)


def test_unknown_example_map_lists_the_known_ones():
    with pytest.raises(ParamsError, match="middle-earth"):
        example_map_document("mordor")


def test_style_png_maps_colours_to_the_nearest_style_and_resizes(tmp_path):
    doc, first, second = _two_style_document()
    layer = style_layer_from_png(_region_png(tmp_path / "regions.png"), doc.styles, doc.output_shape)
    assert layer.shape == (160, 160) and layer.dtype == np.int16
    assert (layer[:, :70] == first.id).sum() == 140 * 70
    assert (layer[:, 90:] == second.id).sum() == 140 * 70
    assert (layer[70:90] == -1).all()  # grey is near neither colour: plain examples


def test_style_png_needs_styles_and_a_readable_image(tmp_path):
    with pytest.raises(ParamsError, match="no styles"):
        style_layer_from_png(_region_png(tmp_path / "regions.png"), [], (160, 160))
    doc, _, _ = _two_style_document()
    bad = tmp_path / "broken.png"
    bad.write_bytes(b"not a png")
    with pytest.raises(SketchError, match="broken.png"):
        style_layer_from_png(bad, doc.styles, doc.output_shape)


def test_water_png_is_resized_to_the_sketch(tmp_path):
    water = water_layer_from_png(_water_png(tmp_path / "water.png"), (160, 120))
    assert water.shape == (160, 120) and water.dtype == bool
    assert water[120:].all() and not water[:120].any()


# -- GUI ----------------------------------------------------------------------------------
def test_opening_the_example_map_asks_about_changes_then_loads_it(qtbot, window, dialogs, preset):
    doc = window.document
    doc.sketch.draw_polyline([(10, 10), (10, 100)], "ridge")
    assert doc.dirty
    dialogs.answers.append(QMessageBox.Cancel)
    window.actions.example_maps["middle-earth"].trigger()
    assert dialogs.messages("question") and doc.output_shape == (160, 160)  # cancelled: nothing started
    with qtbot.waitSignal(window.example_map_opened, timeout=20_000) as blocker:
        window.actions.example_maps["middle-earth"].trigger()  # Discard this time
    assert blocker.args == ["middle-earth"]
    assert doc.output_shape == (768, 1024) and not doc.dirty and not doc.sketch.can_undo
    assert len(doc.styles) == 4 and doc.sketch.has_water and doc.water_level == 60.0
    assert len(doc.stamps) == 1 and len(doc.pins) == 3
    np.testing.assert_array_equal(doc.sketch.style, preset.controls.style_map)
    assert window.canvas.style_combo.count() == 4
    assert window.styles.list.count() == 4
    assert not window.docks["regions_dock"].visibleRegion().isEmpty()  # raised over the examples
    assert window.docks["examples_dock"].visibleRegion().isEmpty()


def test_importing_region_pngs_is_undoable(qtbot, window, tmp_path):
    doc = window.document
    first = window.styles.add_style(GABON)
    second = window.styles.add_style(ExampleRef(builtin="white-mountains"))
    rgb = np.zeros((80, 80, 3), np.uint8)
    rgb[:, :40] = first.rgb
    rgb[:, 40:] = second.rgb
    window.files.import_style_regions(str(_write_rgb(tmp_path / "regions.png", rgb)))
    assert (doc.sketch.style[:, :80] == first.id).all() and (doc.sketch.style[:, 80:] == second.id).all()
    window.files.import_water_mask(str(_water_png(tmp_path / "water.png")))
    assert doc.sketch.water[120:].all() and not doc.sketch.water[:120].any()
    overlay = window.canvas.controls_overlay
    qtbot.waitUntil(lambda: overlay.regions.image[150, 10, 3] == 150, timeout=2000)  # water drawn
    window.canvas.undo_action.trigger()
    assert not doc.sketch.has_water and (doc.sketch.style[:, 80:] == second.id).all()
    window.canvas.undo_action.trigger()
    assert (doc.sketch.style == -1).all()
    window.canvas.redo_action.trigger()
    assert (doc.sketch.style[:, :80] == first.id).all()


def test_bad_region_pngs_are_reported_and_change_nothing(qtbot, window, dialogs, tmp_path):
    doc = window.document
    regions = _region_png(tmp_path / "regions.png")
    window.files.import_style_regions(str(regions))  # no styles yet
    assert "no styles" in dialogs.messages("critical")[-1]
    bad = tmp_path / "broken.png"
    bad.write_bytes(b"not a png")
    window.files.import_water_mask(str(bad))
    assert "broken.png" in dialogs.messages("critical")[-1]
    window.styles.add_style(GABON)
    window.files.import_style_regions(str(bad))
    assert "broken.png" in dialogs.messages("critical")[-1] and len(dialogs.messages("critical")) == 3
    assert (doc.sketch.style == -1).all() and not doc.sketch.has_water and not doc.sketch.can_undo
