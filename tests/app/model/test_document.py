"""The document model without Qt: documents, requests, projects, recovery, export."""

import json
import zipfile

import numpy as np
import pytest

from terrasynth_core.errors import DEMFormatError, ParamsError
from terrasynth_core.features import FeatureGraph, FeatureMaps, FeatureNode, FeaturePath
from terrasynth_core.io import load_dem, save_dem
from terrasynth_core.heightfield import HeightField
from terrasynth_core.synthesis import SynthesisParams
from terrasynth_app.model import (Document, ExampleRef, ProjectError, RecoveryStore, Sketch, TerrainResult,
                                  load_project, save_project)
from terrasynth_app.model.dem_features import dem_feature_layers, scaled_graph
from terrasynth_app.model.example_library import ground_cell_text
from terrasynth_app.model.export import export_terrain, resampled_field


# -- document ------------------------------------------------------------------------------------
def _document(shape=(48, 64)):
    sketch = Sketch.blank(shape)
    sketch.draw_polyline([(10, 5), (10, 50)], "ridge", radius=2)
    return Document(sketch, [ExampleRef(builtin="white-mountains", crop=(0, 200, 0, 300))])


def test_document_events_and_dirty_flag(tmp_path):
    doc = _document()
    seen = []
    doc.changed.connect(seen.append)
    assert not doc.dirty
    doc.sketch.draw_polyline([(20, 5), (20, 50)], "valley")
    assert doc.dirty and seen == ["dirty"]
    doc.set_params(SynthesisParams(patch_size=32))
    assert seen[-1] == "params"
    doc.set_params(SynthesisParams(patch_size=32))  # no change, no event
    assert seen.count("params") == 1
    with pytest.raises(ParamsError):
        doc.set_params({"patch_size": 32})
    save_project(doc, tmp_path / "a.tsproj")
    assert not doc.dirty and doc.title == "a.tsproj"
    doc.add_example(ExampleRef(builtin="st-helens"))
    doc.add_example(ExampleRef(builtin="st-helens"))
    assert len(doc.examples) == 2 and doc.dirty


def test_default_document_is_ready_to_synthesize():
    doc = Document.default()
    assert doc.sketch.has_strokes and doc.examples == [ExampleRef(builtin="white-mountains")]
    request = doc.synthesis_request()
    assert request.shape == doc.sketch.shape and request.sketch_map.has_strokes
    assert request.params == SynthesisParams()


def test_request_without_examples_is_refused():
    doc = _document()
    doc.set_examples([])
    with pytest.raises(ParamsError, match="no example"):
        doc.synthesis_request()


def test_request_is_a_snapshot_of_the_sketch():
    doc = _document()
    request = doc.synthesis_request()
    doc.sketch.clear()
    assert request.sketch_map.has_strokes


def test_example_refs_validate_load_crop_and_serialise(tmp_path):
    with pytest.raises(DEMFormatError, match="either"):
        ExampleRef()
    with pytest.raises(DEMFormatError, match="white-mountains"):
        ExampleRef(builtin="atlantis")
    with pytest.raises(DEMFormatError, match="crop"):
        ExampleRef(builtin="himalaya", crop=(10, 5, 0, 4))
    ref = ExampleRef(builtin="white-mountains", crop=(100, 260, 200, 400))
    field = ref.load()
    assert field.shape == (160, 200) and field.heights.dtype == np.float32
    assert ExampleRef.from_dict(json.loads(json.dumps(ref.to_dict()))) == ref
    with pytest.raises(DEMFormatError, match="outside"):
        ExampleRef(builtin="st-helens", crop=(0, 5000, 0, 10)).load()
    with pytest.raises(DEMFormatError, match="missing.tif"):
        ExampleRef(path=str(tmp_path / "missing.tif")).load()


# -- projects ---------------------------------------------------------------------------------------
def _result(shape=(48, 64)):
    rng = np.random.default_rng(1)
    heights = rng.normal(500, 50, shape).astype(np.float32)
    patch_id = np.arange(shape[0] * shape[1], dtype=np.int32).reshape(shape) % 7
    seams = rng.random(shape) > 0.9
    ridge = FeatureGraph("ridge", shape, (FeatureNode(0, 10.0, 5.0, "end", 1), FeatureNode(1, 10.0, 50.0, "end", 1)),
                         (FeaturePath(0, 1, np.array([[10.0, 5.0], [10.0, 50.0]])),))
    valley = FeatureGraph("valley", shape, (), ())
    return TerrainResult(heights, patch_id, seams, FeatureMaps(ridge, valley), (30.0, 30.0),
                         {"warnings": ["a warning"], "total_seconds": 1.5})


def test_project_round_trip_keeps_everything(tmp_path):
    dem = tmp_path / "mine.npy"
    save_dem(HeightField(np.random.default_rng(0).normal(100, 5, (80, 90)).astype(np.float32)), dem)
    doc = _document()
    doc.add_example(ExampleRef(path=str(dem)))
    doc.set_params(SynthesisParams(patch_size=40, seed=17, blend="poisson", overlap=12, cell_size=45.0))
    doc.set_result(_result())
    path = save_project(doc, tmp_path / "p.tsproj")
    assert not doc.dirty and doc.path == path
    with zipfile.ZipFile(path) as zf:
        assert {"project.json", "sketch_ridge.npy", "result_heights.npy"} <= set(zf.namelist())
    back = load_project(path)
    assert not back.dirty
    np.testing.assert_array_equal(back.sketch.ridge, doc.sketch.ridge)
    np.testing.assert_array_equal(back.sketch.valley, doc.sketch.valley)
    assert back.examples == doc.examples and back.params == doc.params
    np.testing.assert_array_equal(back.result.heights, doc.result.heights)
    np.testing.assert_array_equal(back.result.patch_id, doc.result.patch_id)
    np.testing.assert_array_equal(back.result.seam_mask, doc.result.seam_mask)
    assert back.result.cell_size == (30.0, 30.0) and back.result.warnings == ["a warning"]
    assert back.result.sketch_features.ridges.to_dict() == doc.result.sketch_features.ridges.to_dict()


def test_a_project_from_before_cell_sizes_opens_with_the_automatic_one(tmp_path):
    path = save_project(_document(), tmp_path / "p.tsproj")
    with zipfile.ZipFile(path) as zf:
        files = {name: zf.read(name) for name in zf.namelist()}
    meta = json.loads(files["project.json"])
    del meta["params"]["cell_size"]
    files["project.json"] = json.dumps(meta).encode()
    with zipfile.ZipFile(path, "w") as zf:
        for name, data in files.items():
            zf.writestr(name, data)
    assert load_project(path).params.cell_size is None


def test_the_run_cell_size_shown_is_the_finest_loaded_or_the_chosen_one(tmp_path):
    fine, coarse = tmp_path / "fine.npy", tmp_path / "coarse.npy"
    save_dem(HeightField(np.ones((40, 40), np.float32), cell_size=(30.0, 20.0)), fine)
    save_dem(HeightField(np.ones((40, 40), np.float32), cell_size=(90.0, 90.0)), coarse)
    doc = Document(Sketch.blank((64, 64)), [ExampleRef(path=str(coarse))])
    assert doc.cell_size() is None  # nothing loaded yet: not read on the GUI thread
    doc.examples[0].load()
    assert doc.cell_size() == 90.0
    doc.add_style(ExampleRef(path=str(fine)))
    doc.styles[0].example.load()
    assert doc.cell_size() == 20.0
    doc.set_params(SynthesisParams(cell_size=50))
    assert doc.cell_size() == 50.0
    assert ground_cell_text((30.0, 20.0), 20.0) == "30 x 20 m, square at 20 m"
    assert ground_cell_text(None) == "cell size unknown"


def test_project_finds_moved_dems_by_relative_path(tmp_path):
    (tmp_path / "a").mkdir()
    dem = tmp_path / "a" / "dem.npy"
    save_dem(HeightField(np.ones((40, 40), np.float32)), dem)
    doc = _document()
    doc.set_examples([ExampleRef(path=str(dem))])
    save_project(doc, tmp_path / "a" / "p.tsproj")
    moved = tmp_path / "b"
    (tmp_path / "a").rename(moved)
    back = load_project(moved / "p.tsproj")
    assert back.examples[0].path == str(moved / "dem.npy")


def test_damaged_or_foreign_project_files_raise_one_clear_error(tmp_path):
    junk = tmp_path / "junk.tsproj"
    junk.write_bytes(b"not a zip at all")
    with pytest.raises(ProjectError, match="junk.tsproj"):
        load_project(junk)
    other = tmp_path / "other.tsproj"
    with zipfile.ZipFile(other, "w") as zf:
        zf.writestr("project.json", json.dumps({"format": "something-else"}))
    with pytest.raises(ProjectError, match="not a TerraSynth project"):
        load_project(other)
    with pytest.raises(ProjectError, match="does not exist"):
        load_project(tmp_path / "none.tsproj")


def test_a_failed_save_leaves_the_old_file_and_no_temporary(tmp_path, monkeypatch):
    doc = _document()
    path = save_project(doc, tmp_path / "p.tsproj")
    before = path.read_bytes()
    doc.sketch.clear()

    def broken_save(*_args, **_kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(np, "save", broken_save)
    with pytest.raises(ProjectError, match="No space left"):
        save_project(doc, path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["p.tsproj"]
    assert doc.dirty


def test_recovery_store_round_trip(tmp_path):
    store = RecoveryStore(tmp_path / "rec")
    assert not store.exists()
    doc = _document()
    save_project(doc, tmp_path / "orig.tsproj")
    doc.sketch.draw_polyline([(30, 5), (30, 40)], "valley")
    store.save(doc.snapshot())
    assert doc.dirty and doc.path == tmp_path / "orig.tsproj"  # autosave never touches the document
    assert store.exists() and "orig.tsproj" in store.describe()
    recovered = store.load()
    assert recovered.dirty and recovered.path == tmp_path / "orig.tsproj"
    np.testing.assert_array_equal(recovered.sketch.valley, doc.sketch.valley)
    store.discard()
    assert not store.exists()


def test_assign_takes_over_another_document():
    doc = _document()
    doc.sketch.draw_polyline([(30, 5), (30, 40)], "valley")
    other = Document(Sketch.blank((20, 30)), [ExampleRef(builtin="himalaya")], result=_result((20, 30)))
    seen = []
    doc.changed.connect(seen.append)
    sketch = doc.sketch
    doc.assign(other)
    assert doc.sketch is sketch and doc.sketch.shape == (20, 30) and not doc.sketch.can_undo
    assert doc.examples == [ExampleRef(builtin="himalaya")] and doc.result is other.result
    assert {"examples", "params", "result", "dirty"} <= set(seen) and not doc.dirty


# -- export and DEM features ------------------------------------------------------------------------
def test_export_writes_dems_and_meshes_at_a_chosen_size(tmp_path):
    result = _result()
    tif = export_terrain(result, tmp_path / "t.tif")
    back = load_dem(tif)
    np.testing.assert_array_equal(back.heights, result.heights)
    small = export_terrain(result, tmp_path / "s.npy", size=(24, 32))
    field = load_dem(small)
    assert field.shape == (24, 32)
    assert field.cell_size == pytest.approx((30.0 * 47 / 23, 30.0 * 63 / 31))
    obj = export_terrain(result, tmp_path / "m.obj", vertical_scale=2.0, step=2)
    text = obj.read_text()
    assert text.count("\nv ") + text.startswith("v ") == 24 * 32
    with pytest.raises(ParamsError, match="export size"):
        resampled_field(result, (1, 10))


def test_export_places_the_terrain_on_the_map_at_any_size(tmp_path):
    """A run's local projection goes into the exported GeoTIFF; a resized
    export keeps the corner cells' centres where they were."""
    import dataclasses

    import rasterio

    from terrasynth_core.heightfield import GeoReference
    from terrasynth_core.io.resample import local_projection

    wkt = local_projection(rasterio.crs.CRS.from_epsg(4326), -71.5, 44.5).to_wkt()
    result = dataclasses.replace(_result(), georef=GeoReference(-960.0, 720.0, 30.0, 30.0, None, wkt))
    with rasterio.open(export_terrain(result, tmp_path / "t.tif")) as src:
        assert src.crs == rasterio.crs.CRS.from_wkt(wkt) and src.res == (30.0, 30.0)
        assert src.transform.c == -960.0 and src.transform.f == 720.0
    with rasterio.open(export_terrain(result, tmp_path / "s.tif", size=(24, 32))) as src:
        rows, cols = result.shape
        # Centre of the last cell: the same ground point before and after.
        x, y = src.transform @ (32 - 0.5, 24 - 0.5)
        assert x == pytest.approx(-960.0 + (cols - 0.5) * 30.0) and y == pytest.approx(720.0 - (rows - 0.5) * 30.0)


def test_resampling_keeps_corners_and_linear_ramps():
    ramp = np.add.outer(np.arange(48, dtype=np.float32), np.zeros(64, np.float32))
    result = TerrainResult(ramp, np.zeros((48, 64), np.int32), np.zeros((48, 64), bool))
    field = resampled_field(result, (95, 64))
    np.testing.assert_allclose(field.heights[:, 0], np.linspace(0, 47, 95), atol=1e-4)


def test_dem_features_become_sketch_strokes_fitted_to_the_sketch():
    rows, cols = np.mgrid[0:120, 0:160]
    # A ridge running east-west with valleys either side.
    heights = (1000 - 8 * np.abs(rows - 60) + 30 * np.sin(cols / 9.0)).astype(np.float32)
    ridge, valley = dem_feature_layers(HeightField(heights, cell_size=(30.0, 30.0)), (60, 80))
    assert ridge.shape == valley.shape == (60, 80) and ridge.dtype == np.uint8
    assert ridge.any()
    assert not (ridge.astype(bool) & valley.astype(bool)).any()
    graph = FeatureGraph("ridge", (11, 21), (FeatureNode(0, 10.0, 20.0, "end", 1),), ())
    assert scaled_graph(graph, (21, 41)).nodes[0].row == 20.0
