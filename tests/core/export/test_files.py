"""GLB meshes (read back with trimesh), EXR heightmaps through load_dem, node-grid
resampling, and the export/masks/convert commands."""

from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio
import trimesh

from terrasynth_core.cli import main
from terrasynth_core.errors import ParamsError
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import load_dem, save_dem, save_mesh
from terrasynth_core.io.resample import resample_nodes


def _hill(rows=60, cols=80, cell=10.0) -> HeightField:
    y, x = np.mgrid[0:rows, 0:cols].astype(np.float32)
    h = 200 + 150 * np.exp(-((x - cols / 2) ** 2 + (y - rows / 2) ** 2) / 300)
    return HeightField(h.astype(np.float32), cell_size=(cell, cell))


def _only_mesh(path):
    scene = trimesh.load(path)
    (mesh,) = scene.geometry.values()
    return mesh


def test_glb_reads_back_with_trimesh_in_metres_y_up(tmp_path):
    field = _hill()
    save_mesh(field, tmp_path / "t.glb")
    mesh = _only_mesh(tmp_path / "t.glb")
    assert len(mesh.vertices) == 60 * 80 and len(mesh.faces) == 2 * 59 * 79
    (x0, y0, z0), (x1, y1, z1) = mesh.bounds
    assert (x0, x1) == (0, 790) and (z0, z1) == (-590, 0)  # east along X, north along -Z
    assert y0 == pytest.approx(field.min) and y1 == pytest.approx(field.max)
    # Normals point up, and the stored normals are the ones trimesh reads.
    assert np.all(mesh.vertex_normals[:, 1] > 0)
    peak = np.argmax(mesh.vertices[:, 1])
    assert mesh.vertex_normals[peak, 1] == pytest.approx(1.0, abs=1e-3)


def test_glb_texture_is_embedded_and_draped(tmp_path):
    field = _hill()
    texture = np.zeros(field.shape + (3,), np.uint8)
    texture[:, :40] = (255, 0, 0)  # west half red
    save_mesh(field, tmp_path / "t.glb", texture=texture)
    mesh = _only_mesh(tmp_path / "t.glb")
    image = mesh.visual.material.baseColorTexture
    assert image.size == (80, 60)
    uv = mesh.visual.uv
    assert uv.min() > 0 and uv.max() < 1  # through pixel centres
    colours = mesh.visual.to_color().vertex_colors[:, :3]
    west = mesh.vertices[:, 0] / 10 < 40  # columns 0..39
    assert np.all(colours[west] == (255, 0, 0)) and np.all(colours[~west] == (0, 0, 0))


def test_glb_decimation_to_a_target_keeps_the_shape(tmp_path):
    field = _hill(120, 120)
    save_mesh(field, tmp_path / "t.glb", target_triangles=3000)
    mesh = _only_mesh(tmp_path / "t.glb")
    assert len(mesh.faces) <= 3000 * 1.05
    assert mesh.bounds[1][1] == pytest.approx(field.max, abs=2.0)
    assert mesh.bounds[0][0] == 0 and mesh.bounds[1][0] == 1190  # the border is kept


def test_decimation_refuses_a_nonsense_target(tmp_path):
    with pytest.raises(ParamsError, match="target triangle count"):
        save_mesh(_hill(), tmp_path / "t.ply", target_triangles=1)


def test_exr_round_trip_through_load_dem(tmp_path):
    field = _hill()
    heights = field.heights.copy()
    heights[3, 4] = np.nan
    save_dem(HeightField(heights, cell_size=(2.0, 3.0)), tmp_path / "t.exr")
    back = load_dem(tmp_path / "t.exr")
    np.testing.assert_array_equal(back.heights, heights)
    assert back.cell_size == (2.0, 3.0) and back.format == "exr"


def test_resample_nodes_keeps_planes_span_and_metres():
    y, x = np.mgrid[0:51, 0:101].astype(np.float32)
    plane = HeightField(3 * x + 2 * y, cell_size=(10.0, 10.0))
    for shape in [(11, 21), (201, 401), (26, 101)]:
        out = resample_nodes(plane, shape)
        yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
        expected = 3 * xx * 100 / (shape[1] - 1) + 2 * yy * 50 / (shape[0] - 1)
        np.testing.assert_allclose(out.heights, expected, atol=1e-3)
        assert (shape[0] - 1) * out.cell_size[0] == pytest.approx(500.0)
        assert (shape[1] - 1) * out.cell_size[1] == pytest.approx(1000.0)


def test_resample_nodes_shrinks_without_aliasing():
    checker = np.indices((201, 201)).sum(axis=0) % 2 * 10.0  # the finest pattern a grid holds
    out = resample_nodes(HeightField(checker.astype(np.float32), cell_size=(1.0, 1.0)), (51, 51))
    # A plain subsample would give all 0 or all 10; the area average gives the mean.
    assert np.abs(out.heights[1:-1, 1:-1] - 5.0).max() < 1.0


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_export_on_a_synth_style_output_and_refusal(tmp_path, capsys):
    dem = tmp_path / "terrain.tif"
    save_dem(_hill(127, 127), dem)
    code, out, err = run(capsys, "export", dem, "--preset", "unreal", "--out", tmp_path / "ue")
    assert code == 0, err
    assert out.startswith("Unreal: Scale X 1000.0000 Y 1000.0000 Z ")
    settings = json.loads((tmp_path / "ue" / "terrain.unreal.json").read_text())
    assert settings["size"] == 127
    before = (tmp_path / "ue" / "terrain.png").read_bytes()
    code, out, err = run(capsys, "export", dem, "--preset", "unreal", "--out", tmp_path / "ue")
    assert code == 2 and err.count("\n") == 1 and "exists" in err and "Traceback" not in err
    assert (tmp_path / "ue" / "terrain.png").read_bytes() == before
    code, out, err = run(capsys, "export", dem, "--preset", "unity", "--out", tmp_path / "u", "--size", "100")
    assert code == 2 and "33, 65, 129" in err


def test_cli_masks_and_glb(tmp_path, capsys):
    dem = tmp_path / "terrain.tif"
    save_dem(_hill(), dem)
    code, out, err = run(capsys, "masks", dem, "--out", tmp_path / "m", "--format", "png16", "--size", "40")
    assert code == 0, err
    assert "wrote 7 masks (30 x 40, png16)" in err and "water: left out" in err
    assert (tmp_path / "m" / "terrain_normal.png").is_file()
    code, out, err = run(capsys, "convert", dem, tmp_path / "t.glb", "--texture", "--triangles", "500")
    assert code == 0, err
    mesh = _only_mesh(tmp_path / "t.glb")
    assert len(mesh.faces) <= 525 and mesh.visual.material.baseColorTexture.size == (80, 60)
    code, out, err = run(capsys, "convert", dem, tmp_path / "t.ply", "--texture")
    assert code == 2 and "needs a .glb" in err


def test_geotiff_export_reads_back_with_rasterio(tmp_path):
    field = _hill()
    save_dem(field, tmp_path / "t.tif")
    with rasterio.open(tmp_path / "t.tif") as ds:
        np.testing.assert_array_equal(ds.read(1), field.heights)


def test_a_tilted_plane_still_meets_the_triangle_target(tmp_path):
    # Quadric simplification stalls on exact planes; the grid is thinned instead.
    plane = HeightField(np.add.outer(np.arange(100), np.arange(100)).astype(np.float32), cell_size=(30.0, 30.0))
    save_mesh(plane, tmp_path / "p.glb", target_triangles=2000)
    mesh = _only_mesh(tmp_path / "p.glb")
    assert 1000 < len(mesh.faces) <= 2000
    assert mesh.bounds[1][0] == pytest.approx(99 * 30.0, abs=30 * 8)  # still the whole extent


def test_cli_masks_on_a_presets_grid(tmp_path, capsys):
    dem = tmp_path / "terrain.tif"
    save_dem(_hill(60, 80), dem)
    code, out, err = run(capsys, "masks", dem, "--out", tmp_path / "m", "--preset", "unreal")
    assert code == 0, err
    assert "wrote 7 masks (127 x 127, png8)" in err and "size 127 chosen" in err
    code, out, err = run(capsys, "export", dem, "--preset", "houdini", "--out", tmp_path / "h")
    assert code == 0, err
    assert out.startswith("Houdini (HeightField File): 80 x 60 samples, cell 10.0000 x 10.0000 m")
