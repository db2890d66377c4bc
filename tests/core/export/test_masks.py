"""Masks and hydrology: known answers on made terrains, files read back by Pillow and OpenEXR."""

from __future__ import annotations

import json
import math

import numpy as np
import OpenEXR
import pytest
from PIL import Image

from terrasynth_core.errors import DEMFormatError, ParamsError
from terrasynth_core.export import MASK_NAMES, terrain_masks, write_masks
from terrasynth_core.export.hydrology import fill_depressions, flow_accumulation
from terrasynth_core.heightfield import HeightField


def _valley(rows: int = 40, cols: int = 31) -> np.ndarray:
    """A V valley along the middle column, falling to the south edge."""
    y, x = np.mgrid[0:rows, 0:cols].astype(np.float64)
    return (np.abs(x - cols // 2) * 2.0 + (rows - y) * 1.0).astype(np.float32)


def test_a_valley_drains_to_its_outlet():
    heights = _valley()
    acc = flow_accumulation(heights)
    # The valley floor gathers everything upstream of it; its last cell most.
    # (Edge cells drain off the grid: the first row's cell keeps its own.)
    floor = acc[:, 15]
    assert floor[0] == 1 and np.all(np.diff(floor[1:]) >= 1)
    # Flanks run diagonally (the steepest way) to the floor; once they all
    # arrive, each floor cell gains one flank row: 31 cells but the two edge
    # columns, which leave the grid sideways.
    assert np.all(np.diff(floor[16:]) == 31 - 2)
    assert acc.max() == floor[-1]
    assert acc.min() == 1


def test_a_pit_is_filled_and_crossed():
    heights = _valley()
    heights[15:20, 10:21] = heights.min() - 5  # a lake bed below everything
    filled = fill_depressions(heights)
    assert np.all(filled >= heights)
    lake = filled[15:20, 10:21]
    assert np.ptp(lake) == 0  # filled flat, to its spill height
    acc = flow_accumulation(heights)
    # Water crosses the lake: below it the floor still gathers the whole valley above.
    assert acc[20:, 15].max() > acc[14, 15] + lake.size


def test_nodata_is_an_outlet_and_stays_nodata():
    heights = _valley()
    heights[20, 15] = np.nan
    acc = flow_accumulation(heights)
    assert np.isnan(acc[20, 15])
    assert acc[19, 15] >= 19  # the floor above drains into the hole


def test_plane_slope_and_normal():
    y, x = np.mgrid[0:20, 0:30].astype(np.float32)
    field = HeightField(0.5 * x * 2.0, cell_size=(2.0, 2.0))  # rises 0.5 m per metre eastward
    masks = terrain_masks(field, names=("slope", "normal", "convex", "concave"))
    np.testing.assert_allclose(masks.masks["slope"], math.degrees(math.atan(0.5)) / 90, rtol=1e-5)
    n = np.array([-0.5, 0.0, 1.0]) / math.sqrt(1.25)
    np.testing.assert_allclose(masks.masks["normal"], np.broadcast_to((n + 1) / 2, (20, 30, 3)), atol=1e-5)
    assert masks.masks["convex"].max() == 0 and masks.masks["concave"].max() == 0  # a plane does not curve


def test_normal_map_green_points_north():
    y, x = np.mgrid[0:20, 0:20].astype(np.float32)
    masks = terrain_masks(HeightField(y * 1.0, cell_size=(1.0, 1.0)), names=("normal",))  # rises southward
    green = masks.masks["normal"][..., 1]
    assert np.all(green > 0.5)  # the surface faces north


def test_curvature_finds_crests_and_hollows():
    y, x = np.mgrid[0:41, 0:41].astype(np.float32)
    hill = 100 * np.exp(-((x - 20) ** 2 + (y - 20) ** 2) / 50)
    masks = terrain_masks(HeightField(hill, cell_size=(1.0, 1.0)), names=("convex", "concave"))
    assert masks.masks["convex"][20, 20] > 0.5 and masks.masks["concave"][20, 20] == 0
    assert masks.masks["concave"][20, 20 + 12] > 0  # the foot of the hill is concave


def test_every_mask_in_range_and_bands_sum_to_one(white_mountains):
    masks = terrain_masks(white_mountains)
    assert set(masks.masks) == set(MASK_NAMES) - {"water"}
    assert any("water: left out" in n for n in masks.notes)
    for name, mask in masks.masks.items():
        assert mask.dtype == np.float32 and mask.shape[:2] == white_mountains.shape, name
        assert 0 <= mask.min() and mask.max() <= 1, name
    np.testing.assert_allclose(masks.masks["height_bands"].sum(axis=-1), 1, atol=1e-6)
    # The wettest cells are on the flow lines, not on the crests.
    wet = masks.masks["wetness"] > 0.9
    assert masks.masks["flow"][wet].mean() > masks.masks["flow"].mean()


def test_water_from_sea_level_or_from_a_given_layer():
    heights = _valley() - 10
    masks = terrain_masks(HeightField(heights, cell_size=(1.0, 1.0)), names=("water",))
    np.testing.assert_array_equal(masks.masks["water"], (heights <= 0).astype(np.float32))
    given = np.zeros(heights.shape, bool)
    given[:3] = True
    masks = terrain_masks(HeightField(heights, cell_size=(1.0, 1.0)), names=("water",), water=given)
    np.testing.assert_array_equal(masks.masks["water"], given)
    with pytest.raises(ParamsError, match="does not match"):
        terrain_masks(HeightField(heights, cell_size=(1.0, 1.0)), names=("water",), water=given[1:])


@pytest.mark.parametrize("fmt, top", [("png8", 255), ("png16", 65535)])
def test_png_masks_read_back_with_pillow(tmp_path, white_mountains, fmt, top):
    masks = terrain_masks(white_mountains.window(0, 120, 0, 150))
    written = write_masks(masks, tmp_path, fmt=fmt)
    key = json.loads((tmp_path / "terrain_masks.json").read_text())
    assert [p.name for p in written[:-1]] == list(key["files"].values())
    for name, values in masks.masks.items():
        path = tmp_path / key["files"][name]
        if fmt == "png16" and values.ndim == 3:
            # Pillow reads 16-bit colour reduced to 8 bits; the check is the
            # decoded 8-bit value (most significant byte) of our 16-bit level.
            with Image.open(path) as image:
                assert image.mode == ("RGB" if values.shape[2] == 3 else "RGBA")
                got = np.asarray(image).astype(np.float64) / 255
            np.testing.assert_allclose(got, values, atol=1 / 255 + 1e-6)
            continue
        with Image.open(path) as image:
            got = np.asarray(image).astype(np.float64) / top
        np.testing.assert_allclose(got, values, atol=0.5 / top + 1e-6)


def test_exr_masks_read_back_with_openexr(tmp_path, white_mountains):
    masks = terrain_masks(white_mountains.window(0, 100, 0, 100), names=("slope", "normal", "height_bands"))
    write_masks(masks, tmp_path, fmt="exr")
    with OpenEXR.File(str(tmp_path / "terrain_slope.exr")) as exr:
        np.testing.assert_array_equal(exr.channels()["Y"].pixels, masks.masks["slope"])
    with OpenEXR.File(str(tmp_path / "terrain_height_bands.exr"), separate_channels=True) as exr:
        channels = exr.channels()
        assert sorted(channels) == ["A", "B", "G", "R"]
        np.testing.assert_array_equal(channels["A"].pixels, masks.masks["height_bands"][..., 3])


def test_masks_never_replace_files(tmp_path):
    masks = terrain_masks(HeightField(_valley(), cell_size=(1.0, 1.0)), names=("slope", "flow"))
    (tmp_path / "terrain_flow.png").write_bytes(b"mine")
    with pytest.raises(DEMFormatError, match="terrain_flow.png exists"):
        write_masks(masks, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["terrain_flow.png"]
    assert (tmp_path / "terrain_flow.png").read_bytes() == b"mine"


def test_style_region_ids_are_written_as_levels(tmp_path):
    field = HeightField(_valley(), cell_size=(1.0, 1.0))
    ids = np.full(field.shape, -1, np.int16)
    ids[:, 20:] = 3
    masks = terrain_masks(field, names=("slope",), style_ids=ids)
    write_masks(masks, tmp_path, fmt="png16")
    with Image.open(tmp_path / "terrain_style_regions.png") as image:
        levels = np.asarray(image)
    np.testing.assert_array_equal(levels, ids + 1)
    with pytest.raises(ParamsError, match="style ids must be"):
        terrain_masks(field, names=("slope",), style_ids=ids[1:])
