"""Pictures: hillshade, the height ramp, shaded relief, patch colours,
feature overlays, PNG files and the 3D arrays."""

import math

import numpy as np
import pytest
from PIL import Image

from terrasynth_core import HeightField, ParamsError
from terrasynth_core.features import extract_features
from terrasynth_core.features.network import graph_mask
from terrasynth_core.pictures import (
    RIDGE_COLOUR,
    TERRAIN_LUT,
    VALLEY_COLOUR,
    camera_direction,
    grey_hillshade,
    height_range,
    hillshade,
    patch_colours,
    render_overlay,
    save_png,
    shaded_relief,
    shaded_window,
    surface_grid,
    terrain_colours,
    thumbnail,
    trim_background,
)
from terrasynth_core.pictures.colours import RAMP_RGB


def _plane(d_drow: float, d_dcol: float, shape=(40, 50)) -> np.ndarray:
    rr, cc = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float32)
    return (d_drow * rr + d_dcol * cc).astype(np.float32)


# -- hillshade ---------------------------------------------------------------
def test_flat_terrain_shade_is_sine_of_altitude():
    shade = hillshade(np.zeros((10, 10), np.float32), altitude=30)
    assert shade.dtype == np.float32
    np.testing.assert_allclose(shade, math.sin(math.radians(30)), atol=1e-6)


def test_slopes_facing_the_light_are_bright():
    west_facing = _plane(0, 1)  # rises to the east, faces west
    assert hillshade(west_facing, azimuth=270).mean() > 0.9
    assert hillshade(west_facing, azimuth=90).mean() < 0.2
    north_facing = _plane(1, 0)  # rises to the south (rows run south), faces north
    assert hillshade(north_facing, azimuth=0).mean() > hillshade(north_facing, azimuth=180).mean() + 0.5


def test_cell_size_flattens_the_shading():
    z = _plane(0, 10)
    steep = hillshade(z, azimuth=90)
    gentle = hillshade(z, cell_size=100.0, azimuth=90)
    assert gentle.mean() > steep.mean()
    from_field = hillshade(HeightField(z, cell_size=(100.0, 100.0)), azimuth=90)
    np.testing.assert_allclose(from_field, gentle)
    anisotropic = hillshade(z, cell_size=(1.0, 100.0), azimuth=90)
    np.testing.assert_allclose(anisotropic, gentle, atol=1e-6)


def test_hillshade_is_nan_safe_and_in_range():
    rng = np.random.default_rng(1)
    z = rng.normal(0, 50, (60, 60)).astype(np.float32)
    z[20:25, 30:40] = np.nan
    before = z.copy()
    shade = hillshade(z, cell_size=30)
    np.testing.assert_array_equal(np.isnan(shade), np.isnan(z))
    valid = shade[~np.isnan(shade)]
    assert valid.min() >= 0 and valid.max() <= 1
    np.testing.assert_array_equal(z, before)
    with pytest.raises(ParamsError, match="altitude"):
        hillshade(z, altitude=95)
    with pytest.raises(ParamsError, match="cell_size"):
        hillshade(z, cell_size=(0, 30))
    grey = grey_hillshade(z, cell_size=30)
    assert grey.dtype == np.uint8 and (grey[20:25, 30:40] == 255).all()


# -- the height ramp -----------------------------------------------------------
def test_ramp_ends_are_lowland_green_and_snow():
    assert TERRAIN_LUT.shape == (256, 3) and TERRAIN_LUT.dtype == np.uint8
    np.testing.assert_array_equal(TERRAIN_LUT[0], RAMP_RGB[0])
    np.testing.assert_array_equal(TERRAIN_LUT[-1], RAMP_RGB[-1])
    z = np.linspace(100, 900, 50, dtype=np.float32).reshape(5, 10)
    colours = terrain_colours(z, vrange=(100, 900))
    np.testing.assert_array_equal(colours[0, 0], RAMP_RGB[0])
    np.testing.assert_array_equal(colours[-1, -1], RAMP_RGB[-1])
    # Beyond the range the ends repeat; without a range 0.5 % tails are cut.
    np.testing.assert_array_equal(terrain_colours(z, vrange=(300, 400))[-1, -1], RAMP_RGB[-1])
    np.testing.assert_array_equal(terrain_colours(z)[-1, -1], RAMP_RGB[-1])


def test_height_range_skips_nan_and_is_never_empty():
    z = np.array([[np.nan, 1.0], [5.0, 3.0]], np.float32)
    assert height_range(z) == (1.0, 5.0)
    assert height_range(np.full((3, 3), 7.0)) == (7.0, 8.0)
    assert height_range(np.full((3, 3), np.nan)) == (0.0, 1.0)
    assert 0.0 < height_range(np.arange(1000.0), tail=1.0)[0] < 20.0


def test_shaded_relief_is_rgba_transparent_at_nan():
    rng = np.random.default_rng(3)
    z = rng.normal(500, 40, (30, 40)).astype(np.float32)
    z[:4, :4] = np.nan
    rgba = shaded_relief(z, cell_size=30.0, vrange=height_range(z))
    assert rgba.shape == (30, 40, 4) and rgba.dtype == np.uint8
    assert (rgba[:4, :4, 3] == 0).all() and (rgba[4:, 4:, 3] == 255).all()
    assert (shaded_relief(np.full((5, 5), np.nan, np.float32)) == 0).all()
    window = shaded_window(z, (10, 20, 5, 25), cell_size=30.0, vrange=height_range(z))
    np.testing.assert_array_equal(window, rgba[10:20, 5:25])
    small = thumbnail(np.zeros((300, 100), np.float32), cell_size=(30.0, 30.0), side=100)
    assert small.shape == (100, 34, 4)


# -- patch colours ------------------------------------------------------------
def test_patch_colours_are_distinct_for_neighbouring_ids():
    ids = np.arange(-1, 64).reshape(5, 13)
    rgba = patch_colours(ids)
    assert rgba.shape == (5, 13, 4) and rgba.dtype == np.uint8
    assert (rgba[0, 0] == 0).all()  # id -1
    colours = rgba.reshape(-1, 4)[1:, :3].astype(int)
    assert len({tuple(c) for c in colours}) == 64
    # Ids one apart, typically touching patches, differ clearly.
    assert np.abs(np.diff(colours, axis=0)).sum(axis=1).min() > 60
    np.testing.assert_array_equal(patch_colours(np.array([[5]])), patch_colours(np.array([[5 + 256]])))


# -- overlay -----------------------------------------------------------------
def test_overlay_is_drawn_where_the_graph_is(tmp_path):
    rows, cols = 120, 160
    z = np.repeat(100 * np.sin(np.arange(cols, dtype=np.float32) / 4)[None, :], rows, axis=0)  # N-S ridges
    z[:5, :5] = np.nan
    maps = extract_features(z)
    rgb = render_overlay(z, maps, cell_size=30.0, line_width=1, show_nodes=False)
    assert rgb.shape == z.shape + (3,) and rgb.dtype == np.uint8
    ridge_cells = graph_mask(maps.ridges)
    assert (rgb[ridge_cells] == RIDGE_COLOUR).all(axis=1).mean() > 0.9
    assert not (rgb[~ridge_cells] == RIDGE_COLOUR).all(axis=1).any()
    assert (rgb == VALLEY_COLOUR).all(axis=2).any()
    with pytest.raises(ParamsError, match="shape"):
        render_overlay(z[:50], maps)


# -- files -------------------------------------------------------------------
def test_save_png_scales_quantizes_and_keeps_a_budget(tmp_path):
    rgb = np.random.default_rng(4).integers(0, 256, (60, 800, 3), dtype=np.uint8)
    path = save_png(rgb, tmp_path / "a.png", max_width=300, colours=16)
    with Image.open(path) as image:
        assert image.size == (300, round(60 * 300 / 800)) and image.mode == "P"
    with pytest.raises(ParamsError, match="budget"):
        save_png(rgb, tmp_path / "b.png", max_bytes=1000)
    with pytest.raises(ParamsError, match="uint8"):
        save_png(rgb.astype(float), tmp_path / "c.png")
    assert [p.name for p in tmp_path.iterdir()] == ["a.png"]


# -- 3D arrays ----------------------------------------------------------------
def test_surface_grid_runs_south_to_north():
    z = np.array([[10.0, 11.0], [0.0, 1.0]])  # the north row is higher
    colours = np.zeros((2, 2, 3))
    colours[0] = 255
    heights, rgb = surface_grid(z, colours)
    np.testing.assert_array_equal(heights, [0.0, 1.0, 10.0, 11.0])
    assert rgb.dtype == np.uint8 and rgb[:2].max() == 0 and rgb[2:].min() == 255


def test_camera_direction_and_trim():
    np.testing.assert_allclose(camera_direction(0, 0), [0, -1, 0], atol=1e-12)  # from the south
    np.testing.assert_allclose(camera_direction(90, 0), [1, 0, 0], atol=1e-12)  # from the east
    np.testing.assert_allclose(np.linalg.norm(camera_direction(-30, 35)), 1.0)
    shot = np.full((100, 100, 3), 255, np.uint8)
    shot[40:50, 20:30] = 0
    assert trim_background(shot, pad=2).shape == (14, 14, 3)


def test_compose_lays_panels_out_in_a_labelled_grid():
    from terrasynth_core.pictures import compose, fit_panel

    panels = [fit_panel(np.full((50, 100, 3), v, np.uint8), 40) for v in (0, 100, 200)]
    assert panels[0].size == (40, 20)
    sheet = compose(panels, ["a", "b", "c"], "title", columns=2, margin=10)
    assert sheet.size == (2 * 40 + 3 * 10, 34 + 2 * (26 + 20) + 3 * 5 + 5)
    rgb = np.asarray(sheet)
    assert (rgb[34 + 5 + 26 + 10, 10 + 20] == 0).all()  # first panel, first row
    assert (rgb[34 + 5 + 26 + 20 + 5 + 26 + 10, 10 + 20] == 200).all()  # third panel, second row


def test_water_is_every_cell_below_the_level_blue_by_depth_with_a_light_shoreline():
    from terrasynth_core.pictures import DEEP_RGB, SHALLOW_RGB, SHORE_RGB, depth_colours, water_rgba

    heights = np.tile(np.arange(20, dtype=np.float32), (10, 1))  # rises 1 m per column, east
    heights[0, 0] = np.nan
    rgba = water_rgba(heights, 8.5)
    wet = rgba[..., 3] > 0
    assert np.array_equal(wet[1:], np.broadcast_to(np.arange(20) < 8.5, (9, 20)))
    assert not wet[0, 0]  # not synthesized yet: dry
    assert tuple(rgba[5, 8, :3]) == SHORE_RGB and rgba[5, 8, 3] == 255  # the last wet column meets land
    assert rgba[5, 0, :3].sum() < rgba[5, 6, :3].sum()  # deeper is darker
    assert np.allclose(depth_colours(np.array([0.0, 5.0, 10.0]), full_depth=10.0)[[0, 2]], [SHALLOW_RGB, DEEP_RGB])
    assert not water_rgba(heights, -1.0).any()


def test_height_ticks_are_round_metres_within_the_range_and_the_strip_is_the_ramp():
    from terrasynth_core.pictures import TERRAIN_LUT, height_ticks, ramp_strip

    assert height_ticks(0.0, 1000.0) == [0.0, 200.0, 400.0, 600.0, 800.0, 1000.0]
    ticks = height_ticks(-14.7, 905.3)
    assert all(-14.7 <= t <= 905.3 for t in ticks) and len(ticks) >= 3
    assert all(float(t / 200).is_integer() for t in ticks)
    assert height_ticks(3.0, 3.0) == [3.0]
    strip = ramp_strip(64, width=3)
    assert strip.shape == (64, 3, 3) and np.array_equal(strip[0, 0], TERRAIN_LUT[255])
    assert np.array_equal(strip[-1, 2], TERRAIN_LUT[0])


def test_connected_water_leaves_a_basin_without_painted_water_dry():
    from terrasynth_core.pictures import water_cells

    heights = np.full((5, 9), 10.0, np.float32)
    heights[1:4, 1:3] = 0.0  # western basin, painted
    heights[1:4, 6:8] = 0.0  # eastern basin, not
    painted = np.zeros((5, 9), bool)
    painted[2, 1] = True
    assert water_cells(heights, 5.0).sum() == 12
    connected = water_cells(heights, 5.0, painted=painted)
    assert connected.sum() == 6 and connected[2, 2] and not connected[2, 6]


def test_mask_pictures_of_every_kind():
    from terrasynth_core.pictures import BAND_COLOURS, mask_picture

    grey = mask_picture(np.array([[0.0, 0.5], [1.0, np.nan]], np.float32))
    assert grey.shape == (2, 2, 3) and grey[0, 1].tolist() == [128, 128, 128] and grey[1, 1].tolist() == [0, 0, 0]
    bands = np.zeros((2, 2, 4), np.float32)
    bands[..., 3] = 1
    assert mask_picture(bands)[0, 0].tolist() == BAND_COLOURS[3].tolist()
    normal = np.full((2, 2, 3), 0.5, np.float32)
    assert mask_picture(normal)[0, 0].tolist() == [128, 128, 128]
    ids = mask_picture(np.array([[0, 1], [2, 1]], np.uint8))
    assert ids[0, 0].tolist() == [0, 0, 0] and ids[0, 1].tolist() == ids[1, 1].tolist() != ids[1, 0].tolist()
