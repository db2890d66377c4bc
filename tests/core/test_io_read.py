"""Readers: the built-in DEMs, cross-checked with GDAL, and small synthetic
files for the variants the built-in ones do not cover."""

import hashlib
import json
import logging
import shutil
import struct

import numpy as np
import pytest
import rasterio
import tifffile
from PIL import Image

from terrasynth_core.errors import DEMFormatError
from terrasynth_core.heightfield import GeoReference, geographic_cell_size
from terrasynth_core.io import READ_EXTENSIONS, format_name, load_dem


# name, shape, min, max, nodata fraction, cell size (dy, dx), format, EPSG
BUILT_IN = [
    ("N44W072.hgt", (1201, 1201), 115, 1908, 0.0, (92.66, 66.09), "hgt", 4326),
    ("N00E010.hgt", (1201, 1201), 1, 1005, 0.0, (92.66, 92.66), "hgt", 4326),
    ("bigtujunga.tif", (643, 1197), 315, 2295, 0.0, (30.0, 30.0), "geotiff", 32611),
    ("Mandakini.bil", (648, 587), 644, 6741, 0.45, (88.81, 88.81), "envi", 32644),
    ("SainteHelens.dem", (466, 327), 682, 2543, 0.023, (30.0, 30.0), "usgs-dem", None),
]


@pytest.mark.parametrize("name, shape, low, high, nodata, cell, fmt, epsg", BUILT_IN)
def test_built_in_dems_load(dems_dir, name, shape, low, high, nodata, cell, fmt, epsg):
    dem = load_dem(dems_dir / name)
    assert dem.shape == shape
    assert dem.heights.dtype == np.float32
    assert abs(dem.min - low) <= 1 and abs(dem.max - high) <= 1
    assert dem.nodata_count / dem.heights.size == pytest.approx(nodata, abs=0.005)
    assert dem.cell_size == pytest.approx(cell, abs=0.01)
    assert dem.format == fmt == format_name(name)
    assert dem.source == str(dems_dir / name)
    assert dem.georef.epsg == epsg


@pytest.mark.parametrize("name", ["N44W072.hgt", "N00E010.hgt", "bigtujunga.tif", "Mandakini.bil"])
def test_built_in_dems_match_gdal(dems_dir, name):
    dem = load_dem(dems_dir / name)
    with rasterio.open(dems_dir / name) as ds:
        expected = ds.read(1, masked=True).astype(np.float32).filled(np.nan)
        transform, crs = ds.transform, ds.crs
    np.testing.assert_array_equal(dem.heights, expected)
    geo = dem.georef
    assert (geo.x_origin, geo.y_origin) == pytest.approx((transform.c, transform.f), abs=1e-9)
    assert (geo.x_step, geo.y_step) == pytest.approx((transform.a, -transform.e), abs=1e-12)
    assert geo.epsg == crs.to_epsg()


def test_usgs_dem_matches_gdal_inside_its_padding(dems_dir):
    # GDAL's USGSDEM driver sizes the grid from the quadrangle corners and
    # adds one empty row above and below the nodes the profiles hold.
    dem = load_dem(dems_dir / "SainteHelens.dem")
    with rasterio.open(dems_dir / "SainteHelens.dem") as ds:
        gdal = ds.read(1, masked=True).astype(np.float32).filled(np.nan)
        transform = ds.transform
    assert np.isnan(gdal[0]).all() and np.isnan(gdal[-1]).all()
    np.testing.assert_array_equal(dem.heights, gdal[1:-1])
    assert dem.georef.x_origin == pytest.approx(transform.c)
    assert dem.georef.y_origin == pytest.approx(transform.f - 30.0)


#: sha256 of the shared library's independently parsed grid
#: SainteHelens_30m_int16.npy (int16, -32768 outside the quadrangle), kept here
#: so the check needs no file outside the repository.
SAINTE_HELENS_SHA256 = "26a95927c48f5b7d693e44700c1c0580ab7f0218d4bf03f7be8ea65cff566ef5"


def test_usgs_dem_matches_shared_grid(dems_dir):
    dem = load_dem(dems_dir / "SainteHelens.dem")
    as_int16 = np.where(dem.nodata, -32768, dem.heights).astype("<i2")
    assert hashlib.sha256(as_int16.tobytes()).hexdigest() == SAINTE_HELENS_SHA256


def test_usgs_dem_origin_and_orientation(dems_dir):
    dem = load_dem(dems_dir / "SainteHelens.dem")
    # First profile starts at x 557820: the cell corner is half a cell west.
    assert dem.georef.x_origin == 557805.0
    assert dem.metadata["utm_zone"] == 10
    # The crater breach opens north: the northern half is lower on average.
    rows = dem.shape[0]
    assert np.nanmean(dem.heights[: rows // 3]) < np.nanmean(dem.heights[rows // 3 : 2 * rows // 3])


def test_hgt_georef_and_latitude_cell_size(dems_dir):
    dem = load_dem(dems_dir / "N44W072.hgt")
    step = 1 / 1200
    assert dem.georef == GeoReference(-72 - step / 2, 45 + step / 2, step, step, 4326)
    assert dem.cell_size == pytest.approx(geographic_cell_size(44.5, step))
    assert dem.cell_size[1] < dem.cell_size[0]


def test_hgt_southern_name_and_unparsable_name(dems_dir, tmp_path):
    south = tmp_path / "s01w010.HGT"
    shutil.copy(dems_dir / "N00E010.hgt", south)
    dem = load_dem(south)
    assert dem.georef.y_origin == pytest.approx(0 + 1 / 2400)
    assert dem.georef.x_origin == pytest.approx(-10 - 1 / 2400)

    plain = tmp_path / "tile.hgt"
    shutil.copy(dems_dir / "N00E010.hgt", plain)
    dem = load_dem(plain)
    assert dem.cell_size is None and dem.georef is None
    assert dem.max == 1005


def test_hgt_voids_are_nan(tmp_path):
    raw = np.full((1201, 1201), 250, dtype=">i2")
    raw[10:20, 30:35] = -32768
    path = tmp_path / "N10E020.hgt"
    raw.tofile(path)
    dem = load_dem(path)
    assert dem.nodata_count == 50 and dem.nodata[15, 32]
    assert dem.max == 250


def test_geotiff_reader_is_quiet(dems_dir, caplog):
    # bigtujunga.tif's nodata 32767 once made tifffile log a warning; GDAL logs nothing.
    with caplog.at_level(logging.WARNING):
        load_dem(dems_dir / "bigtujunga.tif")
    assert caplog.records == []


def _write_tiff(path, data, *, extratags=()):
    tifffile.imwrite(path, data, photometric="minisblack", metadata=None, extratags=list(extratags))


def _geokeys(*pairs):
    directory = [1, 1, 0, len(pairs)]
    for key, value in sorted(pairs):
        directory += [key, 0, 1, value]
    return (34735, "H", len(directory), tuple(directory), True)


@pytest.mark.parametrize("dtype", [np.int16, np.uint16, np.int32, np.float32, np.float64, np.uint8])
def test_geotiff_dtypes_and_nodata_tag(tmp_path, dtype):
    data = (np.arange(30).reshape(5, 6) + 3).astype(dtype)
    data[2, 3] = 7  # nodata
    path = tmp_path / "grid.tif"
    _write_tiff(path, data, extratags=[(42113, "s", 0, "7", True)])
    dem = load_dem(path)
    assert dem.shape == (5, 6) and dem.nodata_count == 2  # the 7 at (0, 4) too
    assert dem.nodata[2, 3] and dem.nodata[0, 4]
    assert dem.heights[4, 5] == 32
    assert dem.cell_size is None and dem.georef is None


def test_geotiff_pixel_is_point_and_geographic(tmp_path):
    data = np.ones((100, 200), dtype=np.float32)
    step = 0.001
    path = tmp_path / "geo.tiff"
    _write_tiff(
        path,
        data,
        extratags=[
            (33550, "d", 3, (step, step, 0.0), True),
            (33922, "d", 6, (0.0, 0.0, 0.0, 7.0, 46.0, 0.0), True),
            _geokeys((1024, 2), (1025, 2), (2048, 4326)),
        ],
    )
    dem = load_dem(path)
    # The tiepoint is the centre of the first cell: the corner is half a cell off.
    assert dem.georef == GeoReference(7.0 - step / 2, 46.0 + step / 2, step, step, 4326)
    centre_lat = 46.0 + step / 2 - 50 * step
    assert dem.cell_size == pytest.approx(geographic_cell_size(centre_lat, step))


@pytest.mark.parametrize("unit_key, foot, epsg", [(9003, 1200 / 3937, 2227), (9002, 0.3048, None)])
def test_geotiff_projected_feet(tmp_path, unit_key, foot, epsg):
    # EPSG 2227 is in US survey feet.  A file that says international feet
    # instead (9002) is another CRS: GDAL honours the unit, so no EPSG code.
    path = tmp_path / "feet.tif"
    _write_tiff(
        path,
        np.zeros((4, 4), dtype=np.float32),
        extratags=[
            (33550, "d", 3, (10.0, 20.0, 0.0), True),
            (33922, "d", 6, (0.0, 0.0, 0.0, 1000.0, 5000.0, 0.0), True),
            _geokeys((1024, 1), (3072, 2227), (3076, unit_key)),
        ],
    )
    dem = load_dem(path)
    assert dem.georef == GeoReference(1000.0, 5000.0, 10.0, 20.0, epsg, dem.georef.crs_wkt)
    assert "foot" in dem.georef.crs_wkt
    assert dem.cell_size == pytest.approx((20 * foot, 10 * foot))


#: ENVI ``data type`` codes of the sample types used here.
_ENVI_TYPES = {"int16": 2, "uint16": 12}


def _write_envi(path, raw, header_name, *, offset=0, **entries):
    """Write ``raw`` (rows, cols) after ``offset`` zero bytes and its header,
    named ``header_name``, beside it; the header's size, offset, type and
    byte order come from ``raw``, other ``entries`` are written as given."""
    path.write_bytes(b"\x00" * offset + raw.tobytes())
    lines = ["ENVI", "description = {", "  synthetic test grid}", f"samples = {raw.shape[1]}",
             f"lines = {raw.shape[0]}", f"header offset = {offset}", f"data type = {_ENVI_TYPES[raw.dtype.name]}",
             f"byte order = {int(raw.dtype.byteorder == '>')}"]
    lines += [f"{key.replace('_', ' ')} = {value}" for key, value in entries.items()]
    (path.parent / header_name).write_text("\n".join(lines) + "\n")


def test_envi_big_endian_geographic_with_bil_hdr_name(tmp_path):
    raw = (np.arange(12).reshape(3, 4) * 10).astype(">i2")
    raw[1, 2] = -32768
    path = tmp_path / "grid.bsq"
    # map info reference pixel (1.5, 1.5) is the centre of the first cell.
    _write_envi(path, raw, "grid.bsq.hdr", bands=1, interleave="bsq", data_ignore_value=-32768,
                map_info="{Geographic Lat/Lon, 1.5, 1.5, 10.0, 45.0, 0.001, 0.001, WGS-84, units=Degrees}")
    dem = load_dem(path)
    assert dem.format == "envi"
    assert dem.heights[2, 3] == 110 and dem.nodata_count == 1 and dem.nodata[1, 2]
    assert dem.georef == GeoReference(10.0 - 0.0005, 45.0 + 0.0005, 0.001, 0.001, 4326)
    assert dem.cell_size == pytest.approx(geographic_cell_size(45.0 + 0.0005 - 0.0015, 0.001))


def test_envi_utm_south_uint16_with_offset(tmp_path):
    raw = np.arange(6, dtype="<u2").reshape(2, 3)
    path = tmp_path / "south.bil"
    _write_envi(path, raw, "south.hdr", offset=16, bands=1,
                map_info="{UTM, 1, 1, 300000, 7000000, 25, 25, 33, South, WGS-84, units=Meters}")
    dem = load_dem(path)
    np.testing.assert_array_equal(dem.heights, raw.astype(np.float32))
    assert dem.georef == GeoReference(300000.0, 7000000.0, 25.0, 25.0, 32733)
    assert dem.cell_size == (25.0, 25.0)


def _usgs_dem(profiles, *, elevation_units=2, z_res=1.0, datum_code=b"  "):
    """A small USGS ASCII DEM: profiles are (x, y, z_datum, elevations)."""
    a = bytearray(b" " * 1024)

    def put(offset, text):
        a[offset : offset + len(text)] = text

    put(0, b"SYNTHETIC QUAD")
    put(144, b"%6d%6d%6d%6d" % (1, 1, 1, 10))
    put(528, b"%6d%6d%6d" % (2, elevation_units, 4))
    put(816, b"%12.6E%12.6E%12.6E" % (30.0, 30.0, z_res))
    put(852, b"%6d%6d" % (1, len(profiles)))
    put(890, datum_code)
    body = b""
    for col, (x, y, z_datum, values) in enumerate(profiles, start=1):
        head = b"%6d%6d%6d%6d" % (1, col, len(values), 1)
        head += b"".join(b"%24.15E" % v for v in (x, y, z_datum, min(values), max(values)))
        record = (head + b"".join(b"%6d" % v for v in values)).replace(b"E", b"D")
        # 1020 characters of fields per 1024-byte block
        for start in range(0, len(record), 1020):
            body += record[start : start + 1020].ljust(1024)
    return bytes(a) + body


def test_usgs_dem_ragged_profiles_feet_and_voids(tmp_path):
    path = tmp_path / "quad.dem"
    path.write_bytes(
        _usgs_dem(
            [
                (500000.0, 4000030.0, 0.0, [10, 20, 30, 40]),
                (500030.0, 4000000.0, 100.0, [-12, 1, 2, 3, 4]),
                (500060.0, 4000060.0, 0.0, [-32767, 7]),
            ],
            elevation_units=1,
            z_res=0.5,
            datum_code=b" 3",
        )
    )
    dem = load_dem(path)
    feet = 0.3048
    expected = np.full((5, 3), np.nan)
    expected[0:4, 0] = np.array([40, 30, 20, 10]) * 0.5 * feet  # north first
    expected[:, 1] = (100 + np.array([4, 3, 2, 1, -12]) * 0.5) * feet
    expected[1, 2] = 7 * 0.5 * feet  # above the void
    np.testing.assert_allclose(dem.heights, expected.astype(np.float32), rtol=1e-6)
    assert dem.georef == GeoReference(499985.0, 4000000.0 + 4 * 30 + 15, 30.0, 30.0, 32610)
    assert dem.cell_size == (30.0, 30.0)


def test_usgs_dem_spanning_several_blocks(tmp_path):
    values = list(range(400))  # 146 + 170 + 84: three 1024-byte blocks
    path = tmp_path / "long.dem"
    path.write_bytes(_usgs_dem([(0.0, 0.0, 0.0, values), (30.0, 0.0, 0.0, values)]))
    dem = load_dem(path)
    assert dem.shape == (400, 2) and dem.nodata_count == 0
    np.testing.assert_array_equal(dem.heights[:, 1], np.arange(399, -1, -1, dtype=np.float32))


def test_esri_ascii_crlf_centre_and_nodata(tmp_path):
    path = tmp_path / "grid.asc"
    text = (
        "NCOLS   3\r\nnrows 2\r\n  XLLCENTER 1000.5 \r\nYLLCENTER\t2000.5\r\n"
        "CellSize 1\r\nNODATA_value  -9999\r\n1.5  2   3\r\n\r\n4 -9999 6.25\r\n"
    )
    path.write_bytes(text.encode())
    dem = load_dem(path)
    np.testing.assert_array_equal(dem.heights, np.array([[1.5, 2, 3], [4, np.nan, 6.25]], np.float32))
    assert dem.georef == GeoReference(1000.0, 2002.0, 1.0, 1.0, None)
    assert dem.cell_size == (1.0, 1.0)


def test_esri_ascii_geographic_and_dx_dy(tmp_path):
    path = tmp_path / "geo.asc"
    values = " ".join(["5"] * 12)
    path.write_text(f"ncols 4\nnrows 3\nxllcorner -72.0\nyllcorner 44.0\ndx 0.002\ndy 0.001\n{values}\n")
    dem = load_dem(path)
    assert dem.georef == GeoReference(-72.0, 44.003, 0.002, 0.001, None)
    lat = 44.0015
    assert dem.cell_size == pytest.approx(
        (geographic_cell_size(lat, 0.001)[0], geographic_cell_size(lat, 0.002)[1])
    )


def test_png_gray_levels_without_sidecar(tmp_path):
    levels = np.array([[0, 1000], [40000, 65535]], dtype=np.uint16)
    path = tmp_path / "h16.png"
    Image.fromarray(levels).save(path)
    dem = load_dem(path)
    np.testing.assert_array_equal(dem.heights, levels.astype(np.float32))
    assert dem.cell_size is None and dem.metadata["bit_depth"] == 16

    gray = np.array([[0, 128], [255, 7]], dtype=np.uint8)
    Image.fromarray(gray).save(tmp_path / "h8.png")
    np.testing.assert_array_equal(load_dem(tmp_path / "h8.png").heights, gray.astype(np.float32))


def test_png_rgb_with_equal_channels_is_gray(tmp_path):
    gray = np.array([[10, 20, 30], [40, 50, 60]], dtype=np.uint8)
    Image.fromarray(np.dstack([gray, gray, gray, np.full_like(gray, 255)])).save(tmp_path / "rgba.png")
    dem = load_dem(tmp_path / "rgba.png")
    np.testing.assert_array_equal(dem.heights, gray.astype(np.float32))


def write_png16(path, samples: np.ndarray, colour_type: int) -> None:
    """A hand-made 16-bit PNG (Pillow cannot write 16-bit colour): ``samples``
    of shape (rows, cols, channels), colour type 0, 2, 4 or 6."""
    import zlib

    rows, cols = samples.shape[:2]
    raw = b"".join(b"\x00" + samples[r].astype(">u2").tobytes() for r in range(rows))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", cols, rows, 16, colour_type, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


@pytest.mark.parametrize("colour_type,channels", [(6, "gggA"), (2, "ggg"), (4, "gA")])
def test_png_16bit_colour_heightmap_keeps_16_bits(tmp_path, colour_type, channels):
    """Issue 13, finding 2: a 16-bit RGBA/RGB/LA heightmap was read at 8 bits (max 232 for 59400)."""
    levels = np.array([[0, 1000, 59400], [258, 40000, 65535]], dtype=np.uint16)
    alpha = np.array([[65535, 65535, 65535], [65535, 0, 65535]], dtype=np.uint16)
    samples = np.dstack([alpha if c == "A" else levels for c in channels])
    path = tmp_path / "h.png"
    write_png16(path, samples, colour_type)
    dem = load_dem(path)
    expected = levels.astype(np.float32)
    if "A" in channels:
        expected[1, 1] = np.nan  # alpha 0 is nodata
    np.testing.assert_array_equal(dem.heights, expected)
    assert dem.metadata["bit_depth"] == 16


def test_png_16bit_real_colour_is_refused(tmp_path):
    red = np.array([[0, 1000], [5000, 65535]], dtype=np.uint16)
    write_png16(tmp_path / "pic.png", np.dstack([red, red // 2, red, np.full_like(red, 65535)]), 6)
    with pytest.raises(DEMFormatError, match=r"pic\.png.*colour"):
        load_dem(tmp_path / "pic.png")


def test_png_foreign_json_is_ignored(tmp_path):
    Image.fromarray(np.full((2, 2), 9, np.uint8)).save(tmp_path / "map.png")
    (tmp_path / "map.json").write_text(json.dumps({"min": 0, "max": 1}))
    dem = load_dem(tmp_path / "map.png")
    assert dem.max == 9 and dem.metadata["sidecar"] is False


def test_npy_integer_array_with_sidecar_nodata(tmp_path):
    array = np.array([[1, 2], [-32768, 4]], dtype=np.int16)
    np.save(tmp_path / "grid.npy", array)
    (tmp_path / "grid.json").write_text(
        json.dumps(
            {"format": "terrasynth-heightmap", "min": 1, "max": 4, "cell_size": [5, 6], "nodata_value": -32768}
        )
    )
    dem = load_dem(tmp_path / "grid.npy")
    assert dem.nodata_count == 1 and dem.nodata[1, 0]
    assert dem.cell_size == (5.0, 6.0) and dem.georef is None


def test_npy_without_sidecar_reads_conventional_fill_values_as_nodata(tmp_path, dems_dir):
    """A bare ``.npy`` cannot say what nodata is: SRTM's -32768 (an int16's
    lowest value), -9999, -32767 and GDAL's float32 -3.4e38 are; real low
    ground and an unsigned zero are not."""
    helens = np.where(load_dem(dems_dir / "SainteHelens.dem").nodata, -32768,
                      np.nan_to_num(load_dem(dems_dir / "SainteHelens.dem").heights)).astype(np.int16)
    np.save(tmp_path / "helens.npy", helens)
    dem = load_dem(tmp_path / "helens.npy")
    assert dem.nodata_count == int((helens == -32768).sum()) > 3000
    assert dem.min == 682.0 and dem.metadata["nodata_value"] == -32768.0
    cases = {"float": (np.array([[10.5, -9999.0], [-3.4028235e38, -420.0]], np.float32), 2, -9999.0),
             "int32": (np.array([[1, -32767], [np.iinfo(np.int32).min, -11000]], np.int32), 2, -32767.0),
             "uint16": (np.array([[0, 1], [2, 65535]], np.uint16), 0, None),
             "dead sea": (np.array([[-430.0, -415.5], [-9998.0, 12.0]], np.float64), 0, None)}
    for name, (array, voids, fill) in cases.items():
        np.save(tmp_path / "grid.npy", array)
        dem = load_dem(tmp_path / "grid.npy")
        assert dem.nodata_count == voids, name
        assert dem.metadata.get("nodata_value") == fill, name


def _terragen(elevations, *, scale=(30.0, 30.0, 30.0), height_scale=100, base=50, square_only=False):
    rows, cols = elevations.shape
    content = b"TERRAGENTERRAIN " + b"SIZE" + struct.pack("<hh", min(rows, cols) - 1, 0)
    if not square_only:
        content += b"XPTS" + struct.pack("<hh", cols, 0) + b"YPTS" + struct.pack("<hh", rows, 0)
    content += b"SCAL" + struct.pack("<3f", *scale)
    content += b"CRAD" + struct.pack("<f", 6370.0) + b"CRVM" + struct.pack("<I", 0)
    content += b"ALTW" + struct.pack("<hh", height_scale, base) + elevations.astype("<i2").tobytes()
    return content + b"EOF "


def test_terragen_formula_and_row_order_match_gdal(tmp_path):
    elevations = np.arange(-6, 6, dtype=np.int16).reshape(3, 4) * 1000  # file order: south first
    path = tmp_path / "t.ter"
    path.write_bytes(_terragen(elevations, scale=(10.0, 10.0, 10.0), height_scale=200, base=-3))
    dem = load_dem(path)
    expected = ((-3 + elevations.astype(np.float64) * 200 / 65536) * 10)[::-1]
    np.testing.assert_allclose(dem.heights, expected.astype(np.float32), rtol=1e-6)
    assert dem.cell_size == (10.0, 10.0)
    with rasterio.open(path) as ds:
        gdal = ds.read(1).astype(np.float64) * ds.scales[0] + ds.offsets[0]
    np.testing.assert_allclose(dem.heights, gdal, rtol=1e-6)


def test_terragen_square_without_xpts(tmp_path):
    path = tmp_path / "square.ter"
    path.write_bytes(_terragen(np.zeros((3, 3), np.int16), base=2, square_only=True))
    dem = load_dem(path)
    assert dem.shape == (3, 3) and dem.max == 60.0


def test_raw_r16_and_r32_with_and_without_size(tmp_path):
    levels = np.arange(12, dtype="<u2").reshape(3, 4)
    (tmp_path / "a.r16").write_bytes(levels.tobytes())
    dem = load_dem(tmp_path / "a.r16", size=(3, 4))
    np.testing.assert_array_equal(dem.heights, levels.astype(np.float32))
    assert dem.format == "r16"

    square = np.linspace(-5, 5, 9, dtype="<f4").reshape(3, 3)
    (tmp_path / "b.R32").write_bytes(square.tobytes())
    dem = load_dem(tmp_path / "b.R32")
    np.testing.assert_array_equal(dem.heights, square)
    assert dem.format == "r32"


def test_read_extensions_are_all_dispatched():
    names = {format_name(f"x{ext.upper()}") for ext in READ_EXTENSIONS}
    assert names == {"hgt", "geotiff", "envi", "usgs-dem", "esri-ascii", "png", "npy", "terragen", "r16", "r32",
                     "erdas-imagine", "gdal-vrt", "netcdf", "dted", "gridfloat", "grd", "saga", "er-mapper",
                     "idrisi", "vtp-bt", "hf2", "geopackage", "jpeg2000", "bag", "gtx", "exr"}
