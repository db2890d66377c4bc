"""to_square_cells: one cell size in metres for every example."""

import math

import numpy as np
import pytest
from scipy.ndimage import binary_dilation

from terrasynth_core.errors import ParamsError
from terrasynth_core.heightfield import EARTH_RADIUS_M, GeoReference, HeightField, geographic_cell_size
from terrasynth_core.io import load_dem
from terrasynth_core.io.resample import ground_cell_size, to_square_cells
from terrasynth_core.measures import slope


def _plane_fit(field):
    """(east, north) gradient in m/m of a least-squares plane through the valid cells."""
    geo = field.georef
    rows, cols = field.shape
    i, j = np.mgrid[0:rows, 0:cols]
    x = geo.x_origin + (j + 0.5) * geo.x_step
    y = geo.y_origin - (i + 0.5) * geo.y_step
    valid = ~field.nodata
    a = np.column_stack([x[valid], y[valid], np.ones(valid.sum())])
    (east, north, _), *_ = np.linalg.lstsq(a, field.heights[valid].astype(np.float64), rcond=None)
    return east, north


def _geographic_plane(east=0.1, north=0.05, rows=120, cols=180, lat0=44.0, lon0=-72.0, step=1 / 1200):
    """A plane of known slope (m/m) sampled on a geographic grid from (lat0, lon0) north-east."""
    lat_c, lon_c = lat0 + rows * step / 2, lon0 + cols * step / 2
    i, j = np.mgrid[0:rows, 0:cols]
    lat = lat0 + (rows - i - 0.5) * step
    lon = lon0 + (j + 0.5) * step
    northing = EARTH_RADIUS_M * np.radians(lat - lat_c)
    easting = EARTH_RADIUS_M * np.cos(np.radians(lat)) * np.radians(lon - lon_c)
    heights = 500 + east * easting + north * northing
    geo = GeoReference(lon0, lat0 + rows * step, step, step, 4326)
    return HeightField(heights.astype(np.float32), cell_size=geographic_cell_size(lat_c, step), georef=geo)


@pytest.mark.parametrize("size", [50.0, 100.0])
def test_geographic_plane_keeps_its_slope_in_square_metre_cells(size):
    field = _geographic_plane()
    out = to_square_cells(field, size)
    assert out.cell_size == (size, size)
    assert out.georef.x_step == out.georef.y_step == size
    assert out.georef.epsg is None and "Transverse_Mercator" in out.georef.crs_wkt
    assert out.metadata["resampling"] == ("bilinear" if size < 92 else "average")
    east, north = _plane_fit(out)
    assert east == pytest.approx(0.1, rel=0.01) and north == pytest.approx(0.05, rel=0.01)
    # Shape: the ground extent over the cell size (the footprint's bounding box
    # is a little wider than the middle: meridians converge northwards).
    dy, dx = field.cell_size
    assert out.shape[0] == pytest.approx(120 * dy / size, rel=0.02, abs=2)
    assert out.shape[1] == pytest.approx(180 * dx / size, rel=0.03, abs=2)
    # Inside the footprint every cell is valid; NaN only at the edges.
    assert out.crop_valid().shape[0] >= out.shape[0] - 4


def test_projected_30_m_to_60_m_halves_the_shape_and_averages():
    rng = np.random.default_rng(3)
    heights = rng.normal(800, 50, (64, 80)).astype(np.float32)
    geo = GeoReference(376000.0, 3807900.0, 30.0, 30.0, 32611)
    field = HeightField(heights, cell_size=(30.0, 30.0), georef=geo)
    out = to_square_cells(field, 60.0)
    assert out.shape == (32, 40) and out.cell_size == (60.0, 60.0)
    assert out.georef == GeoReference(376000.0, 3807900.0, 60.0, 60.0, 32611)
    blocks = heights.reshape(32, 2, 40, 2).mean(axis=(1, 3))
    np.testing.assert_allclose(out.heights, blocks, rtol=1e-5)


def test_square_cells_of_that_size_are_returned_as_is():
    geo = GeoReference(0.0, 3000.0, 30.0, 30.0, 32611)
    field = HeightField(np.ones((4, 4), np.float32), cell_size=(30.0, 30.0), georef=geo)
    assert to_square_cells(field, 30.0) is field
    plain = HeightField(np.ones((4, 4), np.float32), cell_size=(30.0, 30.0))
    assert to_square_cells(plain, 30.0) is plain


def test_builtin_srtm_tile_to_66_m_keeps_its_median_slope(dems_dir):
    field = load_dem(dems_dir / "N44W072.hgt")
    assert field.cell_size == pytest.approx((92.66, 66.09), abs=0.01)
    out = to_square_cells(field, 66.0)
    assert out.cell_size == (66.0, 66.0)
    before = np.nanmedian(np.tan(np.radians(slope(field))))  # with its true (dy, dx)
    after = np.nanmedian(np.tan(np.radians(slope(out.crop_valid()))))
    assert after == pytest.approx(before, rel=0.03)
    assert out.shape[0] == pytest.approx(1201 * 92.66 / 66, rel=0.01)


def test_no_crs_plane_is_zoomed_separably_and_keeps_nodata():
    rows, cols, dy, dx = 60, 40, 10.0, 20.0
    i, j = np.mgrid[0:rows, 0:cols]
    heights = (100 + 0.3 * (j + 0.5) * dx - 0.2 * (i + 0.5) * dy).astype(np.float32)
    heights[20:30, 10:20] = np.nan
    field = HeightField(heights, cell_size=(dy, dx))
    for size in (20.0, 5.0):
        out = to_square_cells(field, size)
        assert out.shape == (rows * dy // size, cols * dx // size) and out.cell_size == (size, size)
        y, x = np.mgrid[0 : out.shape[0], 0 : out.shape[1]]
        # Away from the outer edge (bilinear clamps there), exactly the plane.
        inner = (slice(2, -2), slice(2, -2))
        expected = 100 + 0.3 * (x + 0.5) * size - 0.2 * (y + 0.5) * size
        # Cells within a source cell of the hole mix only their valid side: not the plane.
        valid = ~binary_dilation(out.nodata, iterations=int(dx // size) + 1)[inner]
        np.testing.assert_allclose(out.heights[inner][valid], expected[inner][valid], rtol=1e-5)
        # The hole stays a hole of the same ground size.
        hole = out.nodata.sum() * size * size
        assert hole == pytest.approx(100 * dy * dx, rel=0.25)


def test_field_without_cell_size_is_returned_with_the_size_assumed():
    field = HeightField(np.ones((3, 3), np.float32))
    out = to_square_cells(field, 30.0)
    assert out.cell_size == (30.0, 30.0) and out.metadata["cell_size_assumed"] is True
    np.testing.assert_array_equal(out.heights, field.heights)


@pytest.mark.parametrize("bad", [0, -5, math.nan, math.inf, "thirty", None])
def test_bad_cell_size(bad):
    with pytest.raises(ParamsError, match="cell_size"):
        to_square_cells(HeightField(np.ones((3, 3), np.float32), cell_size=(1.0, 1.0)), bad)


def test_ground_cell_size_is_the_smaller_side():
    assert ground_cell_size(HeightField(np.ones((2, 2), np.float32), cell_size=(92.6, 66.1))) == 66.1
    assert ground_cell_size(HeightField(np.ones((2, 2), np.float32))) is None


@pytest.mark.parametrize("shape", [(40, 57), (300, 260), (121, 400)])
def test_node_grid_windows_are_the_whole_resampled_grids_cells(shape):
    """Any window of the new grid, made from only the old cells it reaches,
    holds the same float32 values as that window of the whole grid."""
    from terrasynth_core.io.resample import NodeGrid, resample_nodes

    rng = np.random.default_rng(3)
    heights = (rng.normal(size=(151, 131)).cumsum(0).cumsum(1) + 700).astype(np.float32)
    whole = resample_nodes(HeightField(heights, cell_size=(5.0, 5.0)), shape).heights
    grid = NodeGrid(heights.shape, shape)
    reads = []

    def read(i0, i1, j0, j1):
        reads.append((i1 - i0) * (j1 - j0))
        return heights[i0:i1, j0:j1]

    for r0 in range(0, shape[0], 37):
        for c0 in range(0, shape[1], 53):
            r1, c1 = min(r0 + 37, shape[0]), min(c0 + 53, shape[1])
            np.testing.assert_array_equal(grid.window(read, r0, r1, c0, c1), whole[r0:r1, c0:c1])
    # The windows read parts of the old grid, not all of it.
    assert min(reads) < heights.size / 4
