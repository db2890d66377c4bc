"""Writers: round trips through every format, GDAL reading our files, atomic
replacement, and meshes."""

import json
import struct

import numpy as np
import pytest
import rasterio
from PIL import Image

from terrasynth_core.errors import DEMFormatError
from terrasynth_core.heightfield import GeoReference, HeightField
from terrasynth_core.io import MESH_EXTENSIONS, WRITE_EXTENSIONS, load_dem, save_dem, save_mesh
from terrasynth_core.io.mesh import mesh_arrays

EXACT = (".tif", ".tiff", ".asc", ".npy", ".r32")
LEVELS = (".png", ".r16")


def _field(*, nodata=True, georef=True, shape=(40, 50), cell_size=(30.0, 30.0)):
    rng = np.random.default_rng(7)
    rows, cols = shape
    y, x = np.mgrid[0:rows, 0:cols]
    heights = (600 + 300 * np.sin(x / 7.0) * np.cos(y / 5.0) + rng.normal(0, 3, shape)).astype(np.float32)
    if nodata:
        heights[5:9, 10:20] = np.nan
        heights[-1, -1] = np.nan
    geo = GeoReference(376000.5, 3807900.25, 30.0, 30.0, 32611) if georef else None
    return HeightField(heights, cell_size=cell_size, georef=geo, source="synthetic")


def test_same_field_in_two_formats_of_one_stem_shares_its_sidecar(tmp_path):
    """Equal sidecars may be rewritten; a different one for a file of the same stem is refused."""
    field = _field()
    save_dem(field, tmp_path / "s.png")
    save_dem(field, tmp_path / "s.r16")  # the same levels sidecar: allowed
    np.testing.assert_array_equal(load_dem(tmp_path / "s.png").nodata, field.nodata)
    before = (tmp_path / "s.json").read_bytes()
    with pytest.raises(DEMFormatError, match=r"s\.json.*s\.(png|r16)"):
        save_dem(field, tmp_path / "s.npy")  # NaN-nodata sidecar would change how s.png reads
    assert (tmp_path / "s.json").read_bytes() == before and not (tmp_path / "s.npy").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json", "s.png", "s.r16"]


def test_write_extensions():
    assert set(WRITE_EXTENSIONS) == {".tif", ".tiff", ".asc", ".png", ".npy", ".ter", ".r16", ".r32", ".exr"}
    assert MESH_EXTENSIONS == (".obj", ".stl", ".ply", ".glb")


@pytest.mark.parametrize("ext", EXACT)
def test_exact_round_trip(tmp_path, ext):
    field = _field()
    path = tmp_path / f"out{ext.upper()}"
    save_dem(field, path)
    back = load_dem(path)
    np.testing.assert_array_equal(back.heights, field.heights)  # NaN where nodata
    assert back.cell_size == field.cell_size
    assert back.georef.x_origin == field.georef.x_origin and back.georef.y_origin == field.georef.y_origin
    # Every exact format keeps the CRS (ESRI ASCII in its .prj, as ESRI WKT).
    assert back.georef.epsg == 32611 or (ext == ".asc" and "UTM_Zone_11N" in back.georef.crs_wkt)


@pytest.mark.parametrize("ext", LEVELS)
@pytest.mark.parametrize("nodata", [True, False])
def test_level_round_trip(tmp_path, ext, nodata):
    field = _field(nodata=nodata)
    path = tmp_path / f"out{ext}"
    save_dem(field, path)
    back = load_dem(path)
    span = field.max - field.min
    levels = 65534 if nodata else 65535
    np.testing.assert_array_equal(back.nodata, field.nodata)
    error = np.nanmax(np.abs(back.heights.astype(np.float64) - field.heights))
    assert error <= span / levels / 2 + 1e-4
    assert back.min == pytest.approx(field.min, abs=1e-3) and back.max == pytest.approx(field.max, abs=1e-3)
    assert back.cell_size == field.cell_size and back.georef == field.georef

    sidecar = json.loads((tmp_path / "out.json").read_text())
    assert sidecar["format"] == "terrasynth-heightmap"
    assert sidecar["nodata_value"] == (0 if nodata else None)
    assert sidecar["cell_size"] == [30.0, 30.0] and sidecar["shape"] == [40, 50]


def test_png_is_16_bit_with_level_zero_only_for_nodata(tmp_path):
    field = _field(nodata=True)
    save_dem(field, tmp_path / "h.png")
    with Image.open(tmp_path / "h.png") as image:
        assert image.mode == "I;16"
        levels = np.asarray(image)
    assert (levels[field.nodata] == 0).all()
    assert levels[~field.nodata].min() == 1 and levels.max() == 65535

    save_dem(_field(nodata=False), tmp_path / "full.png")
    with Image.open(tmp_path / "full.png") as image:
        levels = np.asarray(image)
    assert levels.min() == 0 and levels.max() == 65535


def test_terragen_round_trip_quantisation_and_nodata_fill(tmp_path):
    field = _field(nodata=True, cell_size=(25.0, 25.0))
    path = tmp_path / "t.ter"
    save_dem(field, path)
    back = load_dem(path)
    assert back.cell_size == (25.0, 25.0) and back.nodata_count == 0
    valid = ~field.nodata
    span = field.max - field.min
    error = np.abs(back.heights[valid].astype(np.float64) - field.heights[valid]).max()
    assert error < span / 30000
    assert np.allclose(back.heights[field.nodata], field.min, atol=span / 30000)


def test_terragen_default_scale_without_cell_size(tmp_path):
    field = HeightField(np.array([[-20.0, 0.0], [100.0, 3000.0]], np.float32))
    save_dem(field, tmp_path / "d.ter")
    back = load_dem(tmp_path / "d.ter")
    assert back.cell_size == (30.0, 30.0)
    assert np.abs(back.heights - field.heights).max() < 3020 / 30000


def test_round_trip_without_georef_keeps_cell_size(tmp_path):
    field = _field(georef=False, cell_size=(10.0, 12.5))
    for ext in (".tif", ".npy", ".r32", ".png", ".r16", ".ter"):
        # One stem per format: heightmaps of one stem would share one sidecar (refused).
        save_dem(field, tmp_path / f"g_{ext[1:]}{ext}")
        back = load_dem(tmp_path / f"g_{ext[1:]}{ext}")
        assert back.cell_size == pytest.approx((10.0, 12.5)), ext
        assert back.georef is None, ext


def test_geographic_georef_round_trips_through_geotiff(tmp_path):
    step = 1 / 1200
    geo = GeoReference(-72 - step / 2, 45 + step / 2, step, step, 4326)
    field = HeightField(_field(nodata=False).heights, georef=geo)
    save_dem(field, tmp_path / "geo.tif")
    back = load_dem(tmp_path / "geo.tif")
    assert back.georef == geo
    assert back.cell_size[0] == pytest.approx(92.66, abs=0.01)
    with rasterio.open(tmp_path / "geo.tif") as ds:
        assert ds.crs.to_epsg() == 4326
        assert ds.transform.c == pytest.approx(geo.x_origin) and ds.transform.f == pytest.approx(geo.y_origin)


def test_rasterio_reads_our_geotiff(tmp_path):
    field = _field()
    save_dem(field, tmp_path / "g.tif")
    with rasterio.open(tmp_path / "g.tif") as ds:
        assert ds.crs.to_epsg() == 32611 and np.isnan(ds.nodata)
        assert tuple(ds.transform)[:6] == (30.0, 0.0, 376000.5, 0.0, -30.0, 3807900.25)
        np.testing.assert_array_equal(ds.read(1), field.heights)


def test_rasterio_reads_our_esri_ascii(tmp_path):
    field = _field()
    save_dem(field, tmp_path / "g.asc")
    with rasterio.open(tmp_path / "g.asc") as ds:
        assert ds.nodata == -9999
        assert tuple(ds.transform)[:6] == pytest.approx((30.0, 0.0, 376000.5, 0.0, -30.0, 3807900.25))
        grid = ds.read(1, masked=True)
    np.testing.assert_array_equal(grid.mask, field.nodata)
    np.testing.assert_allclose(grid.filled(0)[~field.nodata], field.heights[~field.nodata], rtol=1e-7)


def test_rasterio_reads_our_terragen(tmp_path):
    field = _field(nodata=False)
    save_dem(field, tmp_path / "g.ter")
    ours = load_dem(tmp_path / "g.ter")
    with rasterio.open(tmp_path / "g.ter") as ds:
        gdal = ds.read(1).astype(np.float64) * ds.scales[0] + ds.offsets[0]
        assert ds.transform.a == 30.0
    # Same orientation and values: GDAL and our reader agree to float32 precision.
    np.testing.assert_allclose(ours.heights, gdal, rtol=1e-6)
    assert np.abs(gdal - field.heights).max() < (field.max - field.min) / 30000


def test_esri_ascii_writes_its_crs_as_a_prj_and_never_leaves_a_stale_one(tmp_path):
    field = _field()
    save_dem(field, tmp_path / "g.asc")
    assert "PROJCS[" in (tmp_path / "g.prj").read_text()
    with rasterio.open(tmp_path / "g.asc") as ds:
        assert ds.crs.to_epsg() == 32611
    # A terrain without a CRS next to a .prj of that stem: refused, both kept.
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    with pytest.raises(DEMFormatError, match=r"g\.prj beside it names a CRS"):
        save_dem(HeightField(np.ones((4, 4), np.float32)), tmp_path / "g.asc")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_esri_ascii_non_square_cells_and_colliding_nodata(tmp_path):
    heights = np.array([[-9999.0, 1.0, np.nan], [2.0, 3.0, 4.0]], np.float32)
    field = HeightField(heights, cell_size=(20.0, 10.0))
    save_dem(field, tmp_path / "c.asc")
    text = (tmp_path / "c.asc").read_text()
    assert "dx 10.0" in text and "dy 20.0" in text and "NODATA_value -10000" in text
    back = load_dem(tmp_path / "c.asc")
    np.testing.assert_array_equal(back.heights, heights)
    assert back.cell_size == (20.0, 10.0)


def test_r16_non_square_loads_back_through_sidecar_shape(tmp_path):
    field = _field(shape=(13, 29), georef=False)
    save_dem(field, tmp_path / "n.r16")
    assert (tmp_path / "n.r16").stat().st_size == 13 * 29 * 2
    back = load_dem(tmp_path / "n.r16")
    assert back.shape == (13, 29)


def test_flat_field_round_trips(tmp_path):
    field = HeightField(np.full((3, 4), 42.5, np.float32))
    for ext in (".png", ".r16", ".ter", ".asc"):
        save_dem(field, tmp_path / f"f{ext}")
        np.testing.assert_allclose(load_dem(tmp_path / f"f{ext}").heights, 42.5, atol=1e-3)


def test_saving_replaces_atomically_and_leaves_no_temporaries(tmp_path):
    path = tmp_path / "dem.tif"
    save_dem(_field(), path)
    save_dem(HeightField(np.ones((3, 3), np.float32)), path)
    assert load_dem(path).shape == (3, 3)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dem.tif"]

    # A write that fails half-way leaves the previous file and no temporary.
    save_dem(_field(), tmp_path / "dem.ter")
    before = (tmp_path / "dem.ter").read_bytes()
    too_high = HeightField(np.array([[0.0, 2.0e6], [0.0, 0.0]], np.float32))
    with pytest.raises(DEMFormatError, match="dem.ter"):
        save_dem(too_high, tmp_path / "dem.ter")
    assert (tmp_path / "dem.ter").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dem.ter", "dem.tif"]


def test_writers_do_not_mutate_the_field(tmp_path):
    field = _field()
    copy = field.heights.copy()
    for ext in WRITE_EXTENSIONS:
        save_dem(field, tmp_path / f"m_{ext[1:]}{ext}")
    np.testing.assert_array_equal(field.heights, copy)


# -- meshes -------------------------------------------------------------


def _parse_obj(path):
    vertices, faces = [], []
    for line in path.read_text().splitlines():
        parts = line.split()
        if parts and parts[0] == "v":
            vertices.append([float(v) for v in parts[1:]])
        elif parts and parts[0] == "f":
            faces.append([int(i) - 1 for i in parts[1:]])
    return np.array(vertices), np.array(faces)


def _parse_ply(path):
    content = path.read_bytes()
    end = content.index(b"end_header\n") + len(b"end_header\n")
    header = content[:end].decode().splitlines()
    n_vertices = int(next(l for l in header if l.startswith("element vertex")).split()[-1])
    n_faces = int(next(l for l in header if l.startswith("element face")).split()[-1])
    vertices = np.frombuffer(content, "<f4", n_vertices * 3, end).reshape(-1, 3)
    faces = np.frombuffer(content, [("n", "u1"), ("i", "<i4", 3)], n_faces, end + vertices.nbytes)
    assert (faces["n"] == 3).all() and len(content) == end + vertices.nbytes + faces.nbytes
    return vertices, faces["i"]


def _small_field():
    heights = np.array(
        [[1.5, -2.25, 3.0, 4.0], [4.0, np.nan, 6.0, 7.0], [7.0, 8.0, 9.125, 10.0]], np.float32
    )
    return HeightField(heights, cell_size=(10.0, 20.0))


def test_mesh_arrays_geometry_and_winding():
    vertices, faces = mesh_arrays(_small_field(), vertical_scale=2.0)
    assert vertices.shape == (11, 3)  # 12 nodes, one nodata
    # The nodata node touches 6 triangles of the 12.
    assert faces.shape == (6, 3)
    np.testing.assert_array_equal(vertices[0], [0.0, 20.0, 3.0])  # north-west corner, top row
    np.testing.assert_array_equal(vertices[-1], [60.0, 0.0, 20.0])  # south-east corner
    corners = vertices[faces]
    normal_z = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])[:, 2]
    assert (normal_z > 0).all()  # counter-clockwise seen from above


def test_full_grid_counts_and_step():
    field = _field(nodata=False, shape=(41, 51))
    vertices, faces = mesh_arrays(field)
    assert len(vertices) == 41 * 51 and len(faces) == 2 * 40 * 50
    vertices, faces = mesh_arrays(field, step=10)
    assert len(vertices) == 5 * 6 and len(faces) == 2 * 4 * 5
    assert vertices[:, 0].max() == 50 * 30.0 and vertices[:, 1].max() == 40 * 30.0


@pytest.mark.parametrize("ext", MESH_EXTENSIONS)
def test_mesh_files_parse_back(tmp_path, ext):
    field = _small_field()
    vertices, faces = mesh_arrays(field)
    path = tmp_path / f"m{ext}"
    save_mesh(field, path)
    if ext == ".obj":
        parsed_vertices, parsed_faces = _parse_obj(path)
        np.testing.assert_allclose(parsed_vertices, vertices, atol=1e-5)
        np.testing.assert_array_equal(parsed_faces, faces)
    elif ext == ".ply":
        parsed_vertices, parsed_faces = _parse_ply(path)
        np.testing.assert_array_equal(parsed_vertices, vertices)
        np.testing.assert_array_equal(parsed_faces, faces)
    elif ext == ".glb":
        import trimesh

        (mesh,) = trimesh.load(path, process=False).geometry.values()
        # glTF is Y-up: (x, y, z) -> (x, z, -y).
        np.testing.assert_array_equal(mesh.vertices, vertices[:, [0, 2, 1]] * [1, 1, -1])
        np.testing.assert_array_equal(mesh.faces, faces)
    else:
        content = path.read_bytes()
        (count,) = struct.unpack_from("<I", content, 80)
        assert count == len(faces) and len(content) == 84 + 50 * count
        triangles = np.frombuffer(
            content, [("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")], count, 84
        )
        np.testing.assert_array_equal(triangles["v"], vertices[faces])
        np.testing.assert_allclose(np.linalg.norm(triangles["n"], axis=1), 1.0, rtol=1e-6)
        assert (triangles["n"][:, 2] > 0).all()
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]


def test_obj_text_of_a_larger_grid_parses_exactly(tmp_path):
    field = _field(nodata=True, shape=(60, 70))
    vertices, faces = mesh_arrays(field, vertical_scale=1.5)
    save_mesh(field, tmp_path / "big.obj", vertical_scale=1.5)
    parsed_vertices, parsed_faces = _parse_obj(tmp_path / "big.obj")
    np.testing.assert_array_equal(parsed_faces, faces)
    # Seven significant digits at the largest magnitude of each axis.
    np.testing.assert_allclose(parsed_vertices, vertices, atol=0.01)
    assert np.abs(parsed_vertices[:, 2] - vertices[:, 2]).max() <= 0.0005


def test_a_replaced_file_keeps_its_permissions(tmp_path):
    """``--overwrite`` of a read-only file leaves a read-only file (the
    atomic writer's temporary would otherwise bring the umask's mode)."""
    import os
    import stat

    from terrasynth_core.io._common import atomic_outputs, open_new

    target = tmp_path / "terrain.bin"
    target.write_bytes(b"old")
    os.chmod(target, 0o444)
    with atomic_outputs(target) as (tmp,), open_new(tmp) as f:
        f.write(b"new")
    assert target.read_bytes() == b"new"
    assert stat.S_IMODE(os.stat(target).st_mode) == 0o444
    fresh = tmp_path / "fresh.bin"
    with atomic_outputs(fresh) as (tmp,), open_new(tmp) as f:
        f.write(b"x")
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(os.stat(fresh).st_mode) == 0o666 & ~umask  # a new file: the umask's
