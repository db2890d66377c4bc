"""A corpus of rasters written by rasterio (GDAL): every compression and
container artists bring, read by load_dem with the values GDAL reads."""

import warnings

import numpy as np
import pytest
import rasterio
from rasterio.crs import CRS
from rasterio.errors import NotGeoreferencedWarning
from rasterio.shutil import copy as gdal_copy
from rasterio.transform import Affine

from terrasynth_core.errors import DEMFormatError
from terrasynth_core.heightfield import HeightField, geographic_cell_size
from terrasynth_core.io import format_name, load_dem, save_dem
from terrasynth_core.io.resample import to_square_cells

STEP = 1 / 1200
ROW0, COL0, ROWS, COLS = 500, 600, 64, 80
#: Upper-left corner of the crop of N44W072.hgt.
ORIGIN = (-72 - STEP / 2 + COL0 * STEP, 45 + STEP / 2 - ROW0 * STEP)
TRANSFORM = Affine(STEP, 0.0, ORIGIN[0], 0.0, -STEP, ORIGIN[1])
NODATA = -9999.0


@pytest.fixture(scope="module")
def crop(dems_dir):
    """64 x 80 int16 heights of the SRTM tile."""
    raw = np.fromfile(dems_dir / "N44W072.hgt", dtype=">i2").reshape(1201, 1201)
    return raw[ROW0 : ROW0 + ROWS, COL0 : COL0 + COLS].astype(np.int16)


@pytest.fixture(scope="module")
def crop_float(crop):
    """The crop as float32 with the nodata value in a block and NaNs in another."""
    data = crop.astype(np.float32) + 0.25
    data[10:14, 20:30] = NODATA
    data[40:42, 5:9] = np.nan
    return data


def _expected(data):
    """Heights load_dem should give: nodata and NaN as NaN, float32."""
    out = data.astype(np.float32)
    out[out == NODATA] = np.nan
    return out


def _write(path, data, *, driver="GTiff", crs="EPSG:4326", transform=TRANSFORM, nodata=None, **options):
    with rasterio.open(path, "w", driver=driver, width=data.shape[-1], height=data.shape[-2],
                       count=1 if data.ndim == 2 else data.shape[0], dtype=data.dtype, crs=crs,
                       transform=transform, nodata=nodata, **options) as ds:
        ds.write(data if data.ndim == 3 else data[None])
    return path


def _gdal_read(path, band=1):
    """What rasterio reads: masked cells as NaN, float32."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        with rasterio.open(path) as ds:
            return ds.read(band, masked=True).astype(np.float32).filled(np.nan), ds.crs


def _check(path, expected, *, epsg=4326, rel=1e-9):
    """load_dem gives GDAL's values, ``expected`` (unless None), the cell size
    at the crop's latitude (to ``rel``: some formats round the corners) and
    GDAL's EPSG code, which must be ``epsg`` unless that is None."""
    dem = load_dem(path)
    gdal, crs = _gdal_read(path)
    np.testing.assert_array_equal(dem.heights, gdal)
    if expected is not None:
        np.testing.assert_array_equal(dem.heights, expected)
    lat = ORIGIN[1] - ROWS * STEP / 2
    assert dem.cell_size == pytest.approx(geographic_cell_size(lat, STEP), rel=rel)
    assert dem.georef.epsg == (crs.to_epsg() if crs else None)
    if epsg is not None:
        assert dem.georef.epsg == epsg
    if crs is not None:
        assert CRS.from_wkt(dem.georef.crs_wkt) == crs
    assert (dem.georef.x_origin, dem.georef.y_origin) == pytest.approx(ORIGIN, abs=rel * 1e3)
    assert dem.format == format_name(path)
    return dem


#: name, creation options, float data (with nodata) or int16
GEOTIFFS = [
    ("lzw-int16", {"compress": "LZW"}, False),
    ("lzw-float", {"compress": "LZW", "predictor": 3}, True),
    ("deflate-predictor2", {"compress": "DEFLATE", "predictor": 2}, False),
    ("deflate-predictor3", {"compress": "DEFLATE", "predictor": 3}, True),
    ("zstd", {"compress": "ZSTD", "predictor": 2}, False),
    ("zstd-float", {"compress": "ZSTD", "predictor": 3}, True),
    ("lerc-deflate", {"compress": "LERC_DEFLATE", "max_z_error": 0}, True),
    ("lzma-tiled", {"compress": "LZMA", "tiled": True, "blockxsize": 16, "blockysize": 16}, True),
    ("packbits-strips", {"compress": "PACKBITS", "blockysize": 7}, False),
    ("bigtiff", {"compress": "DEFLATE", "bigtiff": "YES"}, True),
]


@pytest.mark.parametrize("name, options, as_float", GEOTIFFS, ids=[g[0] for g in GEOTIFFS])
def test_geotiff_compressions(tmp_path, crop, crop_float, name, options, as_float):
    data = crop_float if as_float else crop
    path = _write(tmp_path / f"{name}.tif", data, nodata=NODATA if as_float else None, **options)
    _check(path, _expected(data))


def test_bigtiff_really_is_bigtiff(tmp_path, crop):
    path = _write(tmp_path / "big.tif", crop, bigtiff="YES")
    assert path.read_bytes()[2:4] == b"\x2b\x00"  # BigTIFF version 43, little-endian


def test_cog(tmp_path, crop_float):
    source = _write(tmp_path / "plain.tif", crop_float, nodata=NODATA)
    gdal_copy(source, tmp_path / "cog.tif", driver="COG", compress="DEFLATE", predictor="FLOATING_POINT",
              blocksize=32)
    dem = _check(tmp_path / "cog.tif", _expected(crop_float))
    assert dem.metadata["driver"] == "GTiff"


#: driver, extension, creation options, whether values and nodata survive
#: exactly, whether GDAL's CRS has an EPSG code (ESRI-style .prj files do not
#: always match one), relative precision of the stored corners
OTHER_FORMATS = [
    ("HFA", ".img", {}, True, True, 1e-9),
    ("HFA", ".img", {"compressed": "YES"}, True, True, 1e-9),
    ("ENVI", ".bil", {"interleave": "bil"}, True, True, 1e-9),
    ("EHdr", ".flt", {}, True, False, 1e-9),
    ("netCDF", ".nc", {}, True, True, 1e-9),
    ("SAGA", ".sdat", {}, True, False, 1e-7),
    # Surfer 7 keeps no CRS, its own blank value and the corners as centres.
    ("GS7BG", ".grd", {}, False, False, 1e-5),
    ("ERS", ".ers", {}, True, True, 1e-9),
    ("RST", ".rst", {}, True, False, 1e-5),
    ("BT", ".bt", {}, True, True, 1e-9),
    # HF2 stores heights quantised (0.01 by default): GDAL's values, not the source's.
    ("HF2", ".hf2", {}, False, True, 1e-9),
    ("GTX", ".gtx", {}, True, True, 1e-9),
    ("GPKG", ".gpkg", {}, True, True, 1e-9),
]


def _require_driver(driver: str) -> None:
    """The README promises these formats: a rasterio wheel whose GDAL lacks
    the driver fails here rather than skipping quietly."""
    with rasterio.Env() as env:
        assert driver in env.drivers(), f"GDAL in this rasterio wheel has no {driver} driver"


@pytest.mark.parametrize("driver, ext, options, exact, has_epsg, rel", OTHER_FORMATS,
                         ids=[f"{d}{e}{'-' if o else ''}{'-'.join(o)}" for d, e, o, *_ in OTHER_FORMATS])
def test_other_gdal_formats(tmp_path, crop_float, driver, ext, options, exact, has_epsg, rel):
    _require_driver(driver)
    # CreateCopy from a GeoTIFF: some drivers (netCDF) cannot be opened in "w" mode.
    data = np.nan_to_num(crop_float, nan=NODATA) if driver == "HF2" else crop_float  # HF2 refuses NaN
    source = _write(tmp_path / "source.tif", data, nodata=NODATA)
    gdal_copy(source, tmp_path / f"dem{ext}", driver=driver, **options)
    _check(tmp_path / f"dem{ext}", _expected(crop_float) if exact else None,
           epsg=4326 if has_epsg else None, rel=rel)


def test_vrt_mosaic_of_two_tiles(tmp_path, crop_float):
    half = COLS // 2
    west = _write(tmp_path / "west.tif", crop_float[:, :half], nodata=NODATA, compress="LZW")
    east_transform = Affine(STEP, 0.0, ORIGIN[0] + half * STEP, 0.0, -STEP, ORIGIN[1])
    east = _write(tmp_path / "east.tif", crop_float[:, half:], nodata=NODATA, compress="ZSTD",
                  transform=east_transform)
    sources = "".join(
        f"""<ComplexSource><SourceFilename relativeToVRT="1">{tile.name}</SourceFilename>
        <SourceBand>1</SourceBand><SrcRect xOff="0" yOff="0" xSize="{half}" ySize="{ROWS}"/>
        <DstRect xOff="{offset}" yOff="0" xSize="{half}" ySize="{ROWS}"/><NODATA>{NODATA}</NODATA>
        </ComplexSource>"""
        for tile, offset in ((west, 0), (east, half))
    )
    gt = ", ".join(repr(v) for v in (ORIGIN[0], STEP, 0.0, ORIGIN[1], 0.0, -STEP))
    (tmp_path / "mosaic.vrt").write_text(
        f"""<VRTDataset rasterXSize="{COLS}" rasterYSize="{ROWS}"><SRS>EPSG:4326</SRS>
        <GeoTransform>{gt}</GeoTransform>
        <VRTRasterBand dataType="Float32" band="1"><NoDataValue>{NODATA}</NoDataValue>{sources}
        </VRTRasterBand></VRTDataset>"""
    )
    _check(tmp_path / "mosaic.vrt", _expected(crop_float))


def test_dted_level_1_tile(tmp_path, dems_dir):
    raw = np.fromfile(dems_dir / "N44W072.hgt", dtype=">i2").reshape(1201, 1201).astype(np.int16)
    transform = Affine(STEP, 0.0, -72 - STEP / 2, 0.0, -STEP, 45 + STEP / 2)
    _require_driver("DTED")
    source = _write(tmp_path / "tile.tif", raw, transform=transform)
    gdal_copy(source, tmp_path / "w072n44.dt1", driver="DTED")
    dem = load_dem(tmp_path / "w072n44.dt1")
    gdal, _ = _gdal_read(tmp_path / "w072n44.dt1")
    np.testing.assert_array_equal(dem.heights, gdal)
    np.testing.assert_array_equal(dem.heights, raw.astype(np.float32))
    hgt = load_dem(dems_dir / "N44W072.hgt")
    assert dem.georef == hgt.georef and dem.cell_size == pytest.approx(hgt.cell_size)
    assert dem.format == "dted"


def test_scale_and_offset_applied(tmp_path, crop):
    path = _write(tmp_path / "scaled.tif", crop, compress="DEFLATE")
    with rasterio.open(path, "r+") as ds:
        ds.scales, ds.offsets = (0.5,), (100.0,)
    dem = load_dem(path)
    np.testing.assert_array_equal(dem.heights, (crop.astype(np.float64) * 0.5 + 100).astype(np.float32))
    assert dem.metadata["scale"] == 0.5 and dem.metadata["offset"] == 100.0


@pytest.mark.parametrize("unit, metres", [("ft", 0.3048), ("US survey foot", 1200 / 3937), ("cm", 0.01),
                                          ("metre", 1.0)])
def test_height_units_to_metres(tmp_path, crop, unit, metres):
    path = _write(tmp_path / "units.tif", crop.astype(np.float32))
    with rasterio.open(path, "r+") as ds:
        ds.units = (unit,)
    dem = load_dem(path)
    np.testing.assert_allclose(dem.heights, crop * metres, rtol=1e-6)
    assert dem.metadata["height_unit"] == unit and dem.metadata["height_unit_metres"] == metres


def test_vertical_crs_in_us_survey_feet(tmp_path, crop):
    # NAD83 / UTM 11N + NAVD88 height (ftUS): a compound CRS, no single EPSG code.
    path = _write(tmp_path / "navd88.tif", crop.astype(np.float32), crs=CRS.from_string("EPSG:26911+6360"),
                  transform=Affine(30.0, 0.0, 400000.0, 0.0, -30.0, 4000000.0))
    dem = load_dem(path)
    np.testing.assert_allclose(dem.heights, crop * (1200 / 3937), rtol=1e-6)
    assert dem.cell_size == (30.0, 30.0) and "NAVD88" in dem.georef.crs_wkt


def test_unknown_unit_is_kept_and_noted(tmp_path, crop):
    path = _write(tmp_path / "fathoms.tif", crop.astype(np.float32))
    with rasterio.open(path, "r+") as ds:
        ds.units = ("fathom",)
    dem = load_dem(path)
    np.testing.assert_array_equal(dem.heights, crop.astype(np.float32))
    assert dem.metadata["height_unit"] == "fathom" and dem.metadata["height_unit_metres"] is None


def test_two_bands_refused_unless_one_is_chosen(tmp_path, crop):
    data = np.stack([crop, crop // 2 + 7])
    path = _write(tmp_path / "two.tif", data, compress="LZW")
    with pytest.raises(DEMFormatError, match="two.tif: 2 bands") as info:
        load_dem(path)
    assert "band=" in str(info.value) and "\n" not in str(info.value)
    second = load_dem(path, band=2)
    np.testing.assert_array_equal(second.heights, _gdal_read(path, band=2)[0])
    np.testing.assert_array_equal(second.heights, (crop // 2 + 7).astype(np.float32))
    assert second.metadata["band"] == 2
    for bad in (0, 3):
        with pytest.raises(DEMFormatError, match=f"two.tif: band {bad} does not exist"):
            load_dem(path, band=bad)


def test_nan_and_infinite_nodata_values(tmp_path, crop):
    for nodata in (np.nan, -np.inf):
        data = crop.astype(np.float32)
        data[3:5, 3:5] = nodata
        path = _write(tmp_path / "special.tif", data, nodata=nodata)
        dem = load_dem(path)
        assert dem.nodata_count == 4 and dem.nodata[3, 3]


def test_south_up_grid_is_flipped(tmp_path, crop):
    south_left = Affine(STEP, 0.0, ORIGIN[0], 0.0, STEP, ORIGIN[1] - ROWS * STEP)
    path = _write(tmp_path / "south_up.tif", crop[::-1], transform=south_left)
    dem = load_dem(path)
    np.testing.assert_array_equal(dem.heights, crop.astype(np.float32))
    assert (dem.georef.x_origin, dem.georef.y_origin) == pytest.approx(ORIGIN)
    assert dem.georef.y_step == pytest.approx(STEP)


def test_rotated_grid_refused(tmp_path, crop):
    path = _write(tmp_path / "rotated.tif", crop, crs="EPSG:32618",
                  transform=Affine(30.0, 5.0, 700000.0, 5.0, -30.0, 4900000.0))
    with pytest.raises(DEMFormatError, match="rotated.tif: rotated or sheared"):
        load_dem(path)


def test_projected_feet_crs_cell_size(tmp_path, crop):
    # NAD83 / California zone 5 (ftUS): 100 ft cells are 30.48 m.
    path = _write(tmp_path / "stateplane.tif", crop, crs="EPSG:2229",
                  transform=Affine(100.0, 0.0, 6.4e6, 0.0, -100.0, 1.9e6))
    dem = load_dem(path)
    assert dem.georef.epsg == 2229
    assert dem.cell_size == pytest.approx((100 * 1200 / 3937, 100 * 1200 / 3937))


# -- writing --------------------------------------------------------------


def test_cog_output_is_a_valid_cog(tmp_path, dems_dir):
    field = to_square_cells(load_dem(dems_dir / "N44W072.hgt"), 66.0)  # a local TM, no EPSG code
    save_dem(field, tmp_path / "out.tif", cog=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.tif"]
    with rasterio.open(tmp_path / "out.tif") as ds:
        assert ds.driver == "GTiff" and ds.block_shapes[0] == (512, 512)
        assert ds.overviews(1) == [2, 4]  # down to below one tile
        assert ds.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"
        assert ds.compression.name == "deflate" and np.isnan(ds.nodata)
        assert ds.crs == CRS.from_wkt(field.georef.crs_wkt)
        np.testing.assert_array_equal(ds.read(1), field.heights)
    # GDAL's COG ghost header: the IFDs come before the data, as readers over HTTP expect.
    head = (tmp_path / "out.tif").read_bytes()[:400]
    assert b"GDAL_STRUCTURAL_METADATA_SIZE" in head and b"LAYOUT=IFDS_BEFORE_DATA" in head
    back = load_dem(tmp_path / "out.tif")
    np.testing.assert_array_equal(back.heights, field.heights)
    # GDAL's GeoTIFF keys give back the same CRS in other WKT words.
    assert CRS.from_wkt(back.georef.crs_wkt) == CRS.from_wkt(field.georef.crs_wkt)
    assert (back.georef.x_origin, back.georef.y_origin) == (field.georef.x_origin, field.georef.y_origin)
    assert back.cell_size == pytest.approx((66.0, 66.0))


def test_plain_geotiff_output_is_tiled_deflate_predictor_3(tmp_path, crop_float):
    field = load_dem(_write(tmp_path / "in.tif", crop_float, nodata=NODATA))
    save_dem(field, tmp_path / "out.tif")
    with rasterio.open(tmp_path / "out.tif") as ds:
        assert ds.block_shapes[0] == (256, 256) and ds.compression.name == "deflate"
        assert ds.tags(ns="IMAGE_STRUCTURE").get("PREDICTOR") == "3"
        assert ds.dtypes[0] == "float32" and np.isnan(ds.nodata) and ds.crs.to_epsg() == 4326


def test_cog_needs_a_tif_name(tmp_path, crop_float):
    field = load_dem(_write(tmp_path / "in.tif", crop_float, nodata=NODATA))
    with pytest.raises(DEMFormatError, match="out.png"):
        save_dem(field, tmp_path / "out.png", cog=True)


def test_esri_ascii_with_prj_gets_its_crs(tmp_path, crop_float):
    # Our own .asc reader (GDAL's shifts values on indented headers) reads the
    # .prj that GDAL's AAIGrid writes beside the grid.
    source = _write(tmp_path / "source.tif", crop_float, nodata=NODATA)
    gdal_copy(source, tmp_path / "dem.asc", driver="AAIGrid", force_cellsize="YES")
    assert (tmp_path / "dem.prj").is_file()
    dem = load_dem(tmp_path / "dem.asc")
    np.testing.assert_array_equal(dem.heights, _gdal_read(tmp_path / "dem.asc")[0])
    np.testing.assert_array_equal(dem.heights, _expected(crop_float))
    assert dem.georef.epsg == 4326 and dem.format == "esri-ascii"
    lat = ORIGIN[1] - ROWS * STEP / 2
    assert dem.cell_size == pytest.approx(geographic_cell_size(lat, STEP), rel=1e-9)
    (tmp_path / "dem.prj").write_text("not a CRS")
    with pytest.raises(DEMFormatError, match="dem.prj"):
        load_dem(tmp_path / "dem.asc")


def test_netcdf_with_several_variables_is_refused_by_name(tmp_path, crop):
    source = _write(tmp_path / "two.tif", np.stack([crop, crop]))
    gdal_copy(source, tmp_path / "two.nc", driver="netCDF")
    with pytest.raises(DEMFormatError, match=r"two.nc: holds 2 grids \(Band1, Band2\)"):
        load_dem(tmp_path / "two.nc")


def test_lossless_jpeg2000(tmp_path, crop):
    _require_driver("JP2OpenJPEG")
    source = _write(tmp_path / "source.tif", crop)
    gdal_copy(source, tmp_path / "dem.jp2", driver="JP2OpenJPEG", reversible="YES", quality=100)
    _check(tmp_path / "dem.jp2", crop.astype(np.float32))


def test_bag_elevation_is_band_1(tmp_path, crop_float):
    # BAG bathymetry holds elevation and uncertainty: the band must be chosen.
    source = _write(tmp_path / "source.tif", crop_float, nodata=NODATA)
    gdal_copy(source, tmp_path / "survey.bag", driver="BAG")
    with pytest.raises(DEMFormatError, match="survey.bag: 2 bands"):
        load_dem(tmp_path / "survey.bag")
    dem = load_dem(tmp_path / "survey.bag", band=1)
    np.testing.assert_array_equal(dem.heights, _gdal_read(tmp_path / "survey.bag")[0])
    np.testing.assert_array_equal(dem.heights, _expected(crop_float))


def test_local_projection_survives_sidecar_and_geotiff_round_trips(tmp_path, dems_dir):
    field = to_square_cells(load_dem(dems_dir / "N00E010.hgt"), 200.0)
    save_dem(field, tmp_path / "h.npy")
    back = load_dem(tmp_path / "h.npy")
    assert back.georef == field.georef and back.georef.crs_wkt == field.georef.crs_wkt
    for cog in (False, True):
        save_dem(field, tmp_path / "h.tif", cog=cog)
        with rasterio.open(tmp_path / "h.tif") as ds:
            assert ds.crs == CRS.from_wkt(field.georef.crs_wkt) and ds.crs.is_projected


@pytest.mark.parametrize("cog", [False, True])
def test_geotiff_without_georeference_keeps_its_cell_size(tmp_path, cog):
    field = HeightField(np.arange(12, dtype=np.float32).reshape(3, 4), cell_size=(10.0, 12.5))
    save_dem(field, tmp_path / "g.tif", cog=cog)
    back = load_dem(tmp_path / "g.tif")
    assert back.cell_size == (10.0, 12.5) and back.georef is None
    np.testing.assert_array_equal(back.heights, field.heights)


def test_a_raster_without_a_nodata_tag_reads_srtm_voids_as_nodata(tmp_path, crop):
    """An int16 GeoTIFF whose voids are SRTM's -32768 but which carries no
    nodata tag (older conversions): the voids are nodata, and the value
    found is named; a tagged file keeps its tag."""
    data = np.asarray(crop, dtype=np.int16).copy()
    data[3:5, 3:5] = -32768
    dem = load_dem(_write(tmp_path / "untagged.tif", data))
    assert dem.nodata_count == 4 and dem.nodata[3, 3]
    assert dem.metadata["nodata_value"] == -32768.0
    assert dem.min == float(data[data != -32768].min())
    plain = np.asarray(crop, dtype=np.int16)
    assert load_dem(_write(tmp_path / "plain.tif", plain)).nodata_count == 0


def test_windows_are_the_whole_reads_cells(tmp_path, crop, crop_float):
    """A window read converts as the whole read does: south-up flipped, scale
    and offset, feet to metres, declared and conventional nodata."""
    from terrasynth_core.io.gdal import RasterWindows

    south_left = Affine(30.0, 0.0, 400000.0, 0.0, 30.0, 4000000.0 - ROWS * 30.0)
    scaled = _write(tmp_path / "scaled_south.tif", crop[::-1], crs="EPSG:32619", transform=south_left)
    with rasterio.open(scaled, "r+") as ds:
        ds.scales, ds.offsets, ds.units = (0.5,), (100.0,), ("ft",)
    declared = _write(tmp_path / "declared.tif", crop_float, nodata=NODATA)
    conventional = _write(tmp_path / "conventional.tif", crop_float)  # -9999 not declared
    for path in (scaled, declared, conventional):
        whole = load_dem(path)
        raster = RasterWindows(path)
        assert raster.shape == whole.shape and raster.cell_size == whole.cell_size and raster.georef == whole.georef
        for r0, r1, c0, c1 in ((0, ROWS, 0, COLS), (3, 17, 11, 50), (40, ROWS, 0, 9)):
            np.testing.assert_array_equal(raster.read(r0, r1, c0, c1), whole.heights[r0:r1, c0:c1])
    with pytest.raises(ValueError, match="outside"):
        RasterWindows(scaled).read(0, ROWS + 1, 0, COLS)
