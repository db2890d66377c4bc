"""The main window: start-up, projects, prompts, recovery, panels, export."""

import numpy as np
import pytest
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QMessageBox

from terrasynth_core.examples import BUILTIN_EXAMPLES
from terrasynth_core.synthesis import SynthesisParams
from terrasynth_app.main import build_parser, main
from terrasynth_app.model import ExampleRef, RecoveryStore, TerrainResult
from terrasynth_app.views.export_dialog import ExportDialog
from terrasynth_app.views.main_window import MainWindow


def _fake_result(shape):
    heights = np.add.outer(np.arange(shape[0]), np.arange(shape[1])).astype(np.float32)
    return TerrainResult(heights, np.zeros(shape, np.int32), np.zeros(shape, bool), cell_size=(30.0, 30.0))


def test_starts_ready_with_the_default_example_and_sketch(qtbot, tmp_path, dialogs):
    win = MainWindow(settings=QSettings(str(tmp_path / "s.ini"), QSettings.IniFormat))
    qtbot.addWidget(win)
    win.show()
    assert win.windowTitle().startswith("TerraSynth")
    assert win.document.examples == [ExampleRef(builtin="white-mountains")]
    assert win.document.sketch.has_strokes and win.actions.synthesize.isEnabled()
    assert not win.actions.cancel.isEnabled()
    panel = win.examples
    assert [ref.builtin for ref in panel.refs()] == [ex.key for ex in BUILTIN_EXAMPLES]
    qtbot.waitUntil(lambda: len(panel.infos) == len(BUILTIN_EXAMPLES), timeout=30_000)
    item = panel.item_for(ExampleRef(builtin="white-mountains"))
    assert "1201 x 1201" in item.text() and not item.icon().isNull()
    assert dialogs.calls == []


def test_params_panel_edits_the_document(qtbot, window):
    panel, doc = window.params, window.document
    assert not panel.patch_size_auto.isChecked() and panel.patch_size.value() == doc.params.patch_size == 32
    panel.patch_size_auto.setChecked(True)
    assert doc.params.patch_size is None and not panel.patch_size.isEnabled()
    assert panel.patch_size.value() == 80  # where the automatic size starts (no terrain yet)
    shape = doc.output_shape
    doc.set_result(TerrainResult(np.zeros(shape, np.float32), np.zeros(shape), np.zeros(shape, bool),
                                 report={"params": {"patch_size": 56}}))
    assert panel.patch_size.value() == 56 and doc.params.patch_size is None  # the size the terrain got
    panel.patch_size_auto.setChecked(False)  # the box's size made explicit
    assert doc.params.patch_size == 56 and panel.patch_size.isEnabled()
    panel.patch_size.setValue(48)
    assert doc.params.patch_size == 48
    panel.blend.setCurrentText("poisson")
    assert doc.params.blend == "poisson"
    old_seed = doc.params.seed
    seeds = {old_seed}
    for _ in range(3):
        window.actions.randomize.trigger()
        seeds.add(doc.params.seed)
    assert len(seeds) > 1
    panel.overlap_auto.setChecked(False)  # the automatic third of the patch, made explicit
    assert doc.params.overlap == 16
    panel.overlap.setValue(30)  # more than half of 48: shown, not applied
    assert "overlap" in panel.error_label.text() and doc.params.overlap == 16
    panel.overlap.setValue(20)
    assert doc.params.overlap == 20 and panel.error_label.text() == ""
    panel.drainage.setChecked(False)
    assert doc.params.drainage is False
    panel.landform.setChecked(False)
    assert doc.params.landform is False
    doc.set_params(SynthesisParams(patch_size=64, k=9))
    assert panel.patch_size.value() == 64 and panel.k.value() == 9 and panel.overlap_auto.isChecked()
    assert not panel.patch_size_auto.isChecked()
    panel.patch_size_auto.setChecked(True)
    assert doc.params.patch_size is None and doc.params.k == 9
    assert panel.drainage.isChecked() and panel.landform.isChecked()
    assert panel.patch_size.toolTip()


def test_cell_size_auto_or_chosen_is_shown_with_the_examples(qtbot, window):
    panel, doc, library = window.params, window.document, window.examples
    assert panel.cell_size.text() == "auto (finest example)" and doc.params.cell_size is None
    white = doc.examples[0]  # a crop of the White Mountains
    qtbot.waitUntil(lambda: white in library.infos, timeout=30_000)
    # The White Mountains' 93 x 66 m cells, squared at the finer side.
    assert "92.7 x 66.1 m, square at 66.1 m" in library.item_for(white).text()
    assert "cells of 66.1 m" in panel.output_label.text()
    panel.cell_size.setValue(90)
    assert doc.params.cell_size == 90.0
    assert "square at 90 m" in library.item_for(white).text() and "cells of 90 m" in panel.output_label.text()
    # Examples not chosen show their own cell only.
    himalaya = ExampleRef(builtin="himalaya")
    qtbot.waitUntil(lambda: himalaya in library.infos, timeout=30_000)
    assert "square" not in library.item_for(himalaya).text()
    panel.cell_size.setValue(0)
    assert doc.params.cell_size is None and "square at 66.1 m" in library.item_for(white).text()


def test_checking_examples_chooses_them(qtbot, window):
    panel, doc = window.examples, window.document
    item = panel.item_for(ExampleRef(builtin="st-helens"))
    item.setCheckState(item.checkState().Checked)
    assert ExampleRef(builtin="st-helens") in doc.examples
    item.setCheckState(item.checkState().Unchecked)
    assert ExampleRef(builtin="st-helens") not in doc.examples


def test_adding_a_corrupt_dem_shows_an_error_and_adds_nothing(qtbot, window, dialogs, tmp_path):
    bad = tmp_path / "bad.tif"
    bad.write_bytes(b"II*\x00garbage")
    before = window.examples.list.count()
    with qtbot.waitSignal(window.examples.load_failed, timeout=10_000):
        window.examples.add_file(str(bad))
    assert window.examples.list.count() == before
    assert len(dialogs.messages("critical")) == 1 and "bad.tif" in dialogs.messages("critical")[0]
    assert "bad.tif" in window.statusBar().currentMessage()


def test_adding_a_good_dem_file(qtbot, window, tmp_path):
    from terrasynth_core.heightfield import HeightField
    from terrasynth_core.io import save_dem

    path = tmp_path / "hills.asc"
    save_dem(HeightField(np.random.default_rng(0).normal(300, 20, (90, 120)).astype(np.float32),
                         cell_size=(10.0, 10.0)), path)
    # Wait for this file's information: a built-in's may land first.
    mine = ExampleRef(path=str(path))
    with qtbot.waitSignal(window.examples.info_loaded, timeout=10_000,
                          check_params_cb=lambda info: info.ref == mine):
        window.examples.add_file(str(path))
    assert mine in window.document.examples
    # Its ground cell (dy x dx), and the square cell size the run resamples it to (the finest).
    assert "90 x 120, 10 x 10 m, square at 10 m" in window.examples.item_for(ExampleRef(path=str(path))).text()


def test_save_and_reopen_a_project_unchanged(qtbot, window, tmp_path):
    doc = window.document
    with qtbot.waitSignal(window.synthesis.finished, timeout=90_000):
        window.synthesize()
    doc.sketch.draw_polyline([(150, 10), (150, 150)], "valley", radius=2)
    path = tmp_path / "mine.tsproj"
    assert window.file_controller.save_to(path)
    assert not doc.dirty and window.windowTitle() == "TerraSynth - mine.tsproj[*]"
    saved = (doc.sketch.ridge.copy(), doc.sketch.valley.copy(), doc.result.heights.copy(), doc.params,
             doc.examples)
    window.files.new_project()  # nothing unsaved: no question
    assert doc.result is None and doc.sketch.shape != (160, 160)
    assert window.files.open_project(str(path))
    np.testing.assert_array_equal(doc.sketch.ridge, saved[0])
    np.testing.assert_array_equal(doc.sketch.valley, saved[1])
    np.testing.assert_array_equal(doc.result.heights, saved[2])
    assert (doc.params, doc.examples) == saved[3:] and not doc.dirty
    np.testing.assert_array_equal(window.heightmap.heights, saved[2])
    assert window.file_controller.recent_files()[0] == str(path.resolve())


def test_unsaved_changes_prompt_on_close(qtbot, window, dialogs):
    window.document.sketch.clear()
    assert window.document.dirty
    dialogs.answers = [QMessageBox.Cancel]
    assert not window.close()
    assert window.isVisible() and dialogs.messages("question")
    dialogs.answers = [QMessageBox.Discard]
    assert window.close()


def test_opening_a_bad_project_reports_it(qtbot, window, dialogs, tmp_path):
    bad = tmp_path / "bad.tsproj"
    bad.write_text("no zip")
    ridge = window.document.sketch.ridge.copy()
    assert not window.files.open_project(str(bad))
    assert "bad.tsproj" in dialogs.messages("critical")[0]
    np.testing.assert_array_equal(window.document.sketch.ridge, ridge)


def test_opening_a_bit_rotted_project_keeps_the_open_document(qtbot, window, dialogs, tmp_path, bit_rot):
    """Issue 13, finding 3: bit-rot inside a .tsproj raised zlib.error past the Open action."""
    from terrasynth_app.model import save_project

    path = save_project(window.document.snapshot(), tmp_path / "rot.tsproj", mark_saved=False)
    bit_rot(path)
    ridge, title = window.document.sketch.ridge.copy(), window.windowTitle()
    assert not window.files.open_project(str(path))
    [message] = dialogs.messages("critical")
    assert "rot.tsproj" in message and "damaged" in message
    np.testing.assert_array_equal(window.document.sketch.ridge, ridge)
    assert window.windowTitle() == title and window.document.path != path


def test_autosave_and_recovery_on_the_next_start(qtbot, window, dialogs, tmp_path):
    doc = window.document
    doc.sketch.draw_polyline([(5, 5), (5, 150)], "valley", radius=2)
    doc.set_result(_fake_result(doc.sketch.shape))
    store = window.autosave.recovery
    qtbot.waitUntil(lambda: (window.autosave.autosave() or True) and store.exists(), timeout=10_000)
    recovered_window = MainWindow(settings=QSettings(str(tmp_path / "s2.ini"), QSettings.IniFormat),
                                  recovery=RecoveryStore(store.directory))
    qtbot.addWidget(recovered_window)
    dialogs.answers = [QMessageBox.Yes]
    assert recovered_window.files.offer_recovery()
    got = recovered_window.document
    np.testing.assert_array_equal(got.sketch.valley, doc.sketch.valley)
    np.testing.assert_array_equal(got.result.heights, doc.result.heights)
    assert got.dirty and recovered_window.isWindowModified()
    # A clean exit removes the recovery file.
    dialogs.answers = [QMessageBox.Discard]
    recovered_window.close()
    assert not store.exists()


def test_export_dialog_offers_every_format_with_mesh_options(qtbot):
    from terrasynth_core.io import MESH_EXTENSIONS, WRITE_EXTENSIONS

    dialog = ExportDialog((200, 300), directory="/tmp")
    qtbot.addWidget(dialog)
    offered = [dialog.format.itemData(i) for i in range(dialog.format.count())]
    assert offered == list(WRITE_EXTENSIONS) + list(MESH_EXTENSIONS)
    dialog.format.setCurrentIndex(offered.index(".stl"))
    assert dialog.path.text().endswith(".stl") and dialog.vertical_scale.isEnabled()
    dialog.format.setCurrentIndex(offered.index(".asc"))
    assert not dialog.step.isEnabled()
    dialog.rows.setValue(100)
    assert dialog.options()["size"] == (100, 300)


def test_export_writes_the_result_in_the_background(qtbot, window, tmp_path, monkeypatch):
    from terrasynth_core.io import load_dem

    window.document.set_result(_fake_result((160, 160)))
    target = tmp_path / "out.tif"

    def accept(dialog):
        dialog.path.setText(str(target))
        dialog.rows.setValue(80)
        dialog.cols.setValue(80)
        return True

    monkeypatch.setattr(ExportDialog, "exec", accept)
    with qtbot.waitSignal(window.export_finished, timeout=10_000):
        window.export_terrain()
    assert load_dem(target).shape == (80, 80)


def test_3d_view_without_opengl_shows_a_message(qtbot, window):
    window.result_tabs.setCurrentWidget(window.view3d)
    assert not window.view3d.available
    assert "3D view" in window.view3d.message.text() and window.view3d.message.isVisible()


def test_command_line_help_and_missing_display(capsys, monkeypatch):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0 and "terrasynth" in capsys.readouterr().out
    assert build_parser().parse_args(["x.tsproj"]).file.name == "x.tsproj"
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    assert main([]) == 1
    assert "no display" in capsys.readouterr().err



def test_sketch_png_round_trip_and_new_sketch(qtbot, window, tmp_path, monkeypatch):
    from terrasynth_app.views.dialogs import NewSketchDialog

    sketch = window.document.sketch
    path = tmp_path / "s.png"
    window.files.save_sketch(str(path))
    before = sketch.to_sketch_map()

    def choose_size(dialog):
        dialog.rows.setValue(64)
        dialog.cols.setValue(96)
        return True

    monkeypatch.setattr(NewSketchDialog, "exec", choose_size)
    window.files.new_sketch()
    assert sketch.shape == (64, 96) and not sketch.has_strokes
    assert window.params.output_label.text().startswith("64 x 96")
    window.files.open_sketch(str(path))
    np.testing.assert_array_equal(sketch.to_sketch_map().ridge_mask, before.ridge_mask)
    sketch.undo()  # opening is one undo step
    assert sketch.shape == (64, 96)


def test_import_dem_features_as_sketch(qtbot, window):
    from terrasynth_core.examples import builtin_example

    sketch = window.document.sketch
    sketch.clear()
    changes = []
    sketch.changed.connect(changes.append)
    window.files.import_dem_features(str(builtin_example("st-helens").path))
    qtbot.waitUntil(lambda: None in changes, timeout=60_000)
    assert sketch.shape == (160, 160) and sketch.has_strokes
    assert sketch.to_sketch_map().valley_mask.any()
    sketch.undo()
    assert not sketch.has_strokes


def test_export_for_unreal_writes_the_preset_and_says_its_scale(qtbot, window, tmp_path, monkeypatch):
    import json

    from terrasynth_app.views.export_dialog import EXPORT_FOR, PresetExportDialog

    assert list(EXPORT_FOR) == ["unreal", "unity", "godot", "blender", "houdini", "masks"]
    menu_titles = [a.text() for a in window.actions.export_for.values()]
    assert menu_titles[0] == "Unreal Engine (Landscape)…"
    window.document.set_result(_fake_result((160, 160)))
    seen = {}

    def accept(dialog):
        seen["sizes"] = [dialog.size.itemData(i) for i in range(dialog.size.count())]
        seen["default"] = dialog.size.currentData()
        dialog.folder.setText(str(tmp_path / "ue"))
        dialog.size.setCurrentIndex(dialog.size.findData(127))
        dialog.tiles.setValue(2)
        return True

    monkeypatch.setattr(PresetExportDialog, "exec", accept)
    with qtbot.waitSignal(window.export_finished, timeout=10_000) as blocker:
        window.actions.export_for["unreal"].trigger()
    assert seen["sizes"][:3] == [127, 253, 505] and seen["default"] == 253  # keeps all 160 samples
    assert blocker.args[0].startswith("Unreal: Scale X")
    settings = json.loads((tmp_path / "ue" / "terrain.unreal.json").read_text())
    assert settings["tiles"] == 2 and settings["shape"] == [253, 253]
    assert window.statusBar().currentMessage().startswith("Unreal: Scale X")


def test_export_for_masks_uses_the_painted_water(qtbot, window, tmp_path, monkeypatch):
    from PIL import Image

    from terrasynth_app.views.export_dialog import PresetExportDialog

    window.document.set_result(_fake_result((160, 160)))
    sketch = window.document.sketch
    water = np.zeros(sketch.shape, bool)
    water[: sketch.shape[0] // 2] = True  # the northern half, on the sketch's grid
    sketch.replace_regions(water=water)

    def accept(dialog):
        dialog.folder.setText(str(tmp_path / "masks"))
        dialog.mask_format.setCurrentIndex(dialog.mask_format.findData("png8"))
        return True

    monkeypatch.setattr(PresetExportDialog, "exec", accept)
    with qtbot.waitSignal(window.export_finished, timeout=20_000) as blocker:
        window.actions.export_for["masks"].trigger()
    assert blocker.args[0].startswith("8 masks in")  # the seven from heights, and the painted water
    with Image.open(tmp_path / "masks" / "terrain_water.png") as image:
        got = np.asarray(image)
    assert got.shape == (160, 160) and np.all(got[:80] == 255) and np.all(got[80:] == 0)
    with Image.open(tmp_path / "masks" / "terrain_height_bands.png") as image:
        assert image.mode == "RGBA" and image.size == (160, 160)


def test_export_a_textured_simplified_glb(qtbot, window, tmp_path, monkeypatch):
    import trimesh

    window.document.set_result(_fake_result((100, 100)))
    target = tmp_path / "terrain.glb"

    def accept(dialog):
        dialog.format.setCurrentIndex(dialog.format.findData(".glb"))
        assert dialog.texture.isEnabled() and dialog.triangles.isEnabled()
        dialog.path.setText(str(target))
        dialog.texture.setChecked(True)
        dialog.triangles.setValue(2000)
        return True

    monkeypatch.setattr(ExportDialog, "exec", accept)
    with qtbot.waitSignal(window.export_finished, timeout=20_000):
        window.export_terrain()
    (mesh,) = trimesh.load(target).geometry.values()
    assert len(mesh.faces) <= 2100
    assert mesh.visual.material.baseColorTexture.size == (100, 100)


def test_mask_preview_over_the_2d_view(qtbot, window):
    overlay = window.heightmap.mask_overlay
    window.document.set_result(_fake_result((120, 90)))
    qtbot.waitUntil(lambda: window.heightmap._result is not None)
    with qtbot.waitSignal(overlay.mask_shown, timeout=20_000, check_params_cb=lambda name: name == "height_bands"):
        overlay.combo.setCurrentIndex(overlay.combo.findData("height_bands"))
    assert overlay.image.isVisible() and overlay.image.image.shape == (120, 90, 3)
    # A new run hides it; no mask chosen shows none.
    with qtbot.waitSignal(overlay.mask_shown, timeout=5_000, check_params_cb=lambda name: name == ""):
        overlay.combo.setCurrentIndex(0)
    assert not overlay.image.isVisible()
