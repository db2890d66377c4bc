"""Engine presets: every heightmap read back by a real reader (Pillow, numpy, OpenEXR),
metres kept within one 16-bit step, tiles that share their edges, files never replaced."""

from __future__ import annotations

import json

import numpy as np
import OpenEXR
import pytest
from PIL import Image

from terrasynth_core.errors import DEMFormatError, ParamsError
from terrasynth_core.export import export_for_engine
from terrasynth_core.export.engines import UNITY_SIZES, UNREAL_SIZES, default_size, PRESETS, unity_heights_m, \
    unreal_heights_m
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import load_dem


def _terrain(side: int, cell: float = 30.0, seed: int = 0) -> HeightField:
    """A smooth random terrain with peaks and valleys, ``side`` x ``side`` square cells."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:side, 0:side] / side
    h = 800 + 600 * np.sin(3 * x + rng.uniform(0, 6)) * np.cos(2 * y) + 150 * np.sin(11 * x * y)
    return HeightField(h.astype(np.float32), cell_size=(cell, cell))


def _png_levels(path) -> np.ndarray:
    with Image.open(path) as image:
        assert image.mode.startswith("I;16")
        return np.asarray(image).astype(np.int64)


def test_unreal_png_reproduces_the_metres_within_one_step(tmp_path):
    field = _terrain(127)
    done = export_for_engine(field, "unreal", tmp_path)
    step = (field.max - field.min) / 65535
    settings = json.loads((tmp_path / "terrain.unreal.json").read_text())
    assert settings == done.settings | {"notes": done.notes}
    assert settings["size"] == 127 and settings["shape"] == [127, 127]
    assert settings["scale_cm"]["x"] == pytest.approx(3000.0) and settings["scale_cm"]["y"] == pytest.approx(3000.0)
    levels = _png_levels(tmp_path / "terrain.png")
    # What Unreal computes from the PNG with the printed Z scale and location.
    assert np.abs(unreal_heights_m(levels, settings) - field.heights).max() <= step
    # And TerraSynth's own reader, through the sidecar.
    assert np.abs(load_dem(tmp_path / "terrain.png").heights - field.heights).max() <= step
    assert "Scale X 3000.0000" in done.summary()


def test_unreal_tiles_share_their_edges_and_one_height_scale(tmp_path):
    field = _terrain(253)
    export_for_engine(field, "unreal", tmp_path, size=127, tiles=2)
    settings = json.loads((tmp_path / "terrain.unreal.json").read_text())
    assert settings["files"] == ["terrain_x0_y0.png", "terrain_x1_y0.png", "terrain_x0_y1.png", "terrain_x1_y1.png"]
    tiles = {(i, j): unreal_heights_m(_png_levels(tmp_path / f"terrain_x{i}_y{j}.png"), settings)
             for i in range(2) for j in range(2)}
    assert all(t.shape == (127, 127) for t in tiles.values())
    np.testing.assert_array_equal(tiles[0, 0][:, -1], tiles[1, 0][:, 0])
    np.testing.assert_array_equal(tiles[0, 0][-1, :], tiles[0, 1][0, :])
    whole = np.block([[tiles[0, 0], tiles[1, 0][:, 1:]], [tiles[0, 1][1:], tiles[1, 1][1:, 1:]]])
    assert np.abs(whole - field.heights).max() <= (field.max - field.min) / 65535


def test_unity_r16_is_little_endian_levels_of_the_terrain_height(tmp_path):
    field = _terrain(129, cell=10.0)
    done = export_for_engine(field, "unity", tmp_path)
    raw = np.fromfile(tmp_path / "terrain.r16", dtype="<u2").reshape(129, 129).astype(np.int64)
    s = done.settings
    assert s["size"] == 129 and s["terrain_size_m"]["width"] == pytest.approx(1280.0)
    assert s["terrain_size_m"]["height"] == pytest.approx(field.max - field.min, rel=1e-6)
    assert s["flip_vertically"] is True
    assert np.abs(unity_heights_m(raw, s) - field.heights).max() <= (field.max - field.min) / 65535
    assert raw.min() == 0 and raw.max() == 65535


def test_unity_tiles_are_placed_on_a_grid_north_up(tmp_path):
    field = _terrain(65)
    done = export_for_engine(field, "unity", tmp_path, size=33, tiles=2)
    positions = {p["file"]: (p["x"], p["z"]) for p in done.settings["tile_positions_m"]}
    width = 32 * 30.0
    assert positions["terrain_x0_y0.r16"] == (0.0, width)   # the northern row of tiles is at +Z
    assert positions["terrain_x1_y1.r16"] == (width, 0.0)


@pytest.mark.parametrize("preset", ["godot", "blender", "houdini"])
def test_exr_presets_keep_float_metres_and_the_cell_size(tmp_path, preset):
    field = _terrain(90, cell=12.5)
    done = export_for_engine(field, preset, tmp_path)
    with OpenEXR.File(str(tmp_path / "terrain.exr")) as exr:
        heights = np.array(exr.channels()["Y"].pixels)
        cell = np.array(exr.header()["terrasynth_cell_size_m"])
        units = exr.header()["terrasynth_units"]
    assert heights.dtype == np.float32
    np.testing.assert_array_equal(heights, field.heights)
    np.testing.assert_allclose(cell, [12.5, 12.5])
    assert units == "metres"
    assert done.settings["cell_size_m"] == [12.5, 12.5]
    assert PRESETS[preset].how_to_import in (tmp_path / f"terrain.{preset}.json").read_text()


def test_exr_size_keeps_square_cells_and_the_extent(tmp_path):
    field = HeightField(_terrain(121).heights[:61], cell_size=(30.0, 30.0))  # 61 x 121 samples
    done = export_for_engine(field, "blender", tmp_path, size=241)
    assert done.settings["shape"] == [121, 241]
    dy, dx = done.settings["cell_size_m"]
    assert dx == pytest.approx(15.0) and dy == pytest.approx(15.0)
    assert done.settings["extent_m"]["east_west"] == pytest.approx(120 * 30.0)


def test_geographic_cells_become_square_before_the_preset(tmp_path, white_mountains):
    done = export_for_engine(white_mountains, "unreal", tmp_path, size=253)
    assert any("resampled to square" in n for n in done.notes)
    assert done.settings["extent_m"]["east_west"] == pytest.approx(399 * 66.09, rel=0.01)
    assert done.settings["extent_m"]["north_south"] == pytest.approx(399 * 92.66, rel=0.01)


def test_nodata_is_filled_and_said(tmp_path):
    heights = _terrain(127).heights.copy()
    heights[40:50, 40:50] = np.nan
    done = export_for_engine(HeightField(heights, cell_size=(5.0, 5.0)), "unreal", tmp_path)
    assert any("100 nodata cells filled" in n for n in done.notes)
    assert not np.isnan(load_dem(tmp_path / "terrain.png").heights).any()


def test_default_sizes_keep_every_sample():
    assert default_size(PRESETS["unreal"], 1000) == 1009
    assert default_size(PRESETS["unreal"], 1009) == 1009
    assert default_size(PRESETS["unreal"], 1010) == 2017
    assert default_size(PRESETS["unreal"], 1000, tiles=2) == 505
    assert default_size(PRESETS["unity"], 20000) == 4097
    assert UNITY_SIZES == (33, 65, 129, 257, 513, 1025, 2049, 4097)
    assert UNREAL_SIZES[0] == 127 and UNREAL_SIZES[-1] == 8129


def test_existing_files_are_never_replaced(tmp_path):
    field = _terrain(127)
    mine = tmp_path / "terrain.json"
    mine.write_text("my notes")
    with pytest.raises(DEMFormatError, match="terrain.json exists"):
        export_for_engine(field, "unreal", tmp_path)
    assert mine.read_text() == "my notes"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["terrain.json"]


@pytest.mark.parametrize("preset, options, message", [
    ("unreal", {"size": 128}, "not one of the unreal heightmap sizes"),
    ("unity", {"size": 100}, "not one of the unity heightmap sizes"),
    ("godot", {"tiles": 2}, "tiles are for unreal and unity"),
    ("cryengine", {}, "unknown preset"),
])
def test_bad_options_are_refused_by_name(tmp_path, preset, options, message):
    with pytest.raises(ParamsError, match=message):
        export_for_engine(_terrain(33), preset, tmp_path, **options)
    assert not any(tmp_path.iterdir())


def _files_equal(a, b) -> bool:
    return [p.name for p in a.files] == [p.name for p in b.files] and all(
        x.read_bytes() == y.read_bytes() for x, y in zip(a.files, b.files))


@pytest.mark.parametrize("preset, options", [("unreal", {"size": 127, "tiles": 3}), ("unreal", {"size": 505, "tiles": 2}),
                                             ("unity", {"size": 129, "tiles": 2}), ("godot", {"size": 200})])
def test_a_geotiff_read_window_by_window_gives_the_same_files(tmp_path, preset, options):
    """export_file_for_engine never holds the terrain whole, yet writes the
    very files that exporting it from memory writes (shrunk and grown)."""
    from terrasynth_core.export.engines import export_file_for_engine
    from terrasynth_core.heightfield import GeoReference
    from terrasynth_core.io import save_dem

    field = _terrain(401)
    field = HeightField(field.heights, cell_size=(30.0, 30.0),
                        georef=GeoReference(400000.0, 4000000.0, 30.0, 30.0, 32619, None))
    save_dem(field, tmp_path / "world.tif")
    whole = export_for_engine(load_dem(tmp_path / "world.tif"), preset, tmp_path / "whole", **options)
    windows = export_file_for_engine(tmp_path / "world.tif", preset, tmp_path / "windows", **options)
    assert _files_equal(whole, windows)
    assert windows.settings == whole.settings and windows.notes == whole.notes


def test_a_geotiff_with_nodata_is_exported_whole(tmp_path):
    """Nodata needs the whole grid to be filled: such a file is read whole,
    with the same files and notes as from memory."""
    from terrasynth_core.export.engines import export_file_for_engine
    from terrasynth_core.io import save_dem

    heights = _terrain(200).heights.copy()
    heights[150:160, 20:90] = np.nan
    save_dem(HeightField(heights, cell_size=(30.0, 30.0)), tmp_path / "holes.tif")
    whole = export_for_engine(load_dem(tmp_path / "holes.tif"), "unreal", tmp_path / "whole", size=127, tiles=2)
    windows = export_file_for_engine(tmp_path / "holes.tif", "unreal", tmp_path / "windows", size=127, tiles=2)
    assert _files_equal(whole, windows)
    assert any("nodata" in note for note in windows.notes)


def test_tiles_of_a_large_geotiff_never_hold_it_whole(tmp_path, monkeypatch):
    """Memory follows the tile: cutting a 2100 x 2100 GeoTIFF into 4 x 4
    Unity tiles reads it in windows of at most a band of rows or a tile and
    its filters' reach, and allocates less than one float64 copy of it (the
    whole-grid path made three)."""
    import tracemalloc

    from terrasynth_core.export.engines import export_file_for_engine
    from terrasynth_core.io import save_dem
    from terrasynth_core.io.gdal import RasterWindows

    side = 2100
    save_dem(_terrain(side, cell=10.0), tmp_path / "world.tif")
    windows = []
    read = RasterWindows.read_with_fill

    def spy(self, r0=0, r1=None, c0=0, c1=None):
        windows.append((r1 - r0) * (c1 - c0))
        return read(self, r0, r1, c0, c1)

    monkeypatch.setattr(RasterWindows, "read_with_fill", spy)
    tracemalloc.start()
    try:
        done = export_file_for_engine(tmp_path / "world.tif", "unity", tmp_path / "tiles", size=513, tiles=4)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(done.settings["files"]) == 16
    assert max(windows) < 0.2 * side * side
    assert peak < side * side * 8, f"peak {peak / 1e6:.1f} MB"


@pytest.mark.parametrize("heights, message", [
    (np.where(np.arange(60 * 70).reshape(60, 70) == 777, np.inf, 500.0), "infinite"),
    (np.full((1, 50), 500.0), "at least 2x2"),
])
def test_a_file_the_whole_read_refuses_is_refused_by_name_before_any_folder_is_made(tmp_path, heights, message):
    """An infinite height or a grid one cell thin is refused as reading the
    file whole refuses it (naming the file), and no output folder is left."""
    import rasterio
    from rasterio.transform import Affine

    from terrasynth_core.export.engines import export_file_for_engine

    path = tmp_path / "odd.tif"
    with rasterio.open(path, "w", driver="GTiff", width=heights.shape[1], height=heights.shape[0], count=1,
                       dtype="float32", crs="EPSG:32633", transform=Affine(10.0, 0, 500000.0, 0, -10.0, 4e6)) as ds:
        ds.write(heights.astype(np.float32)[None])
    with pytest.raises(DEMFormatError, match=message) as caught:
        export_file_for_engine(path, "unreal", tmp_path / "out", size=127)
    assert str(path) in str(caught.value)
    assert not (tmp_path / "out").exists()


def test_a_failed_export_leaves_no_folder_it_made_and_no_file(tmp_path, monkeypatch):
    """A write failing after the first tile removes the tiles written and
    the folder the export made; a folder that was there stays."""
    from terrasynth_core.export import engines

    calls = []
    real = engines.save_dem

    def failing(field, path, **kw):
        calls.append(path)
        if len(calls) == 2:
            raise DEMFormatError(f"cannot write {path}: disk full")
        real(field, path, **kw)

    monkeypatch.setattr(engines, "save_dem", failing)
    with pytest.raises(DEMFormatError, match="disk full"):
        export_for_engine(_terrain(253), "unreal", tmp_path / "new", size=127, tiles=2)
    assert not (tmp_path / "new").exists()
    (tmp_path / "mine").mkdir()
    calls.clear()
    with pytest.raises(DEMFormatError, match="disk full"):
        export_for_engine(_terrain(253), "unreal", tmp_path / "mine", size=127, tiles=2)
    assert (tmp_path / "mine").is_dir() and not any((tmp_path / "mine").iterdir())


def test_a_dangling_link_named_like_an_output_is_not_replaced(tmp_path):
    (tmp_path / "terrain.png").symlink_to(tmp_path / "nowhere.png")
    with pytest.raises(DEMFormatError, match="exists"):
        export_for_engine(_terrain(127), "unreal", tmp_path)
    assert (tmp_path / "terrain.png").is_symlink()


def test_an_output_folder_inside_a_file_is_refused_as_such(tmp_path):
    (tmp_path / "afile").write_text("mine")
    with pytest.raises(DEMFormatError, match="afile is a file"):
        export_for_engine(_terrain(127), "unreal", tmp_path / "afile" / "sub")


def test_an_export_planned_before_its_terrain_exists_is_refused_early(tmp_path):
    """check_export, for a run that exports at its end: a grid past the
    largest, or an EXR of a world-size terrain, is refused before it."""
    from terrasynth_core.export.engines import check_export

    with pytest.raises(ParamsError, match="at most 32769"):
        check_export("unreal", tmp_path / "u", shape=(256, 256), size=8129, tiles=5)
    with pytest.raises(ParamsError, match="give its size, the longer side, up to 16384"):
        check_export("godot", tmp_path / "g", shape=(20000, 20000))
    check_export("godot", tmp_path / "g", shape=(20000, 20000), size=8192)
    check_export("unreal", tmp_path / "u", shape=(30000, 30000), tiles=4)  # 4 x 4 of 8129: 32513
    with pytest.raises(ParamsError, match="at most 32769"):
        check_export("unreal", tmp_path / "u", shape=(40000, 40000), tiles=5)
    assert not any(tmp_path.iterdir())


def test_a_cancelled_export_leaves_nothing(tmp_path):
    from terrasynth_core.errors import SynthesisCancelled

    asked = []

    def cancel():
        asked.append(True)
        return len(asked) > 3  # after the first pass has begun

    with pytest.raises(SynthesisCancelled):
        export_for_engine(_terrain(253), "unreal", tmp_path / "c", size=127, tiles=2, cancel=cancel)
    assert not (tmp_path / "c").exists()
