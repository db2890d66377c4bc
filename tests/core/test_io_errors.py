"""Bad input: every failure is one DEMFormatError line naming the file."""

import json
import shutil

import numpy as np
import pytest
import tifffile
from PIL import Image

from terrasynth_core.errors import DEMFormatError, ParamsError
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import load_dem, save_dem, save_mesh


def _raises(call, *args, name, match=None, **kwargs):
    """Assert ``call`` raises exactly DEMFormatError, one line naming ``name``."""
    with pytest.raises(DEMFormatError) as info:
        call(*args, **kwargs)
    message = str(info.value)
    assert type(info.value) is DEMFormatError
    assert name in message, message
    assert "\n" not in message, message
    if match is not None:
        assert match in message, message
    return message


def _field():
    return HeightField(np.arange(12, dtype=np.float32).reshape(3, 4), cell_size=(30.0, 30.0))


def test_a_builtin_key_given_to_load_dem_says_how_to_load_it():
    _raises(load_dem, "builtin:himalaya", name="builtin:himalaya", match="resolve_dem")


def test_unknown_extension_lists_supported(tmp_path):
    path = tmp_path / "terrain.xyz"
    path.write_bytes(b"1 2 3")
    message = _raises(load_dem, path, name="terrain.xyz", match="'.xyz'")
    assert ".hgt" in message and ".tif" in message and ".r32" in message
    message = _raises(save_dem, _field(), tmp_path / "out.hgt", name="out.hgt")
    assert ".png" in message and ".hgt" not in message.split("supported:")[1]
    _raises(save_mesh, _field(), tmp_path / "out.fbx", name="out.fbx", match=".obj")


def test_missing_file_and_directory(tmp_path):
    _raises(load_dem, tmp_path / "absent.tif", name="absent.tif", match="no such file")
    (tmp_path / "folder.asc").mkdir()
    _raises(load_dem, tmp_path / "folder.asc", name="folder.asc", match="not a file")


def test_hgt_wrong_size_names_found_and_expected(tmp_path):
    path = tmp_path / "N10E010.hgt"
    path.write_bytes(b"\x00" * 1000)
    message = _raises(load_dem, path, name="N10E010.hgt", match="1000 bytes")
    assert "2884802" in message and "25934402" in message


@pytest.mark.parametrize("cut", [0.5, 0.001])
def test_truncated_geotiff(dems_dir, tmp_path, cut):
    content = (dems_dir / "bigtujunga.tif").read_bytes()
    path = tmp_path / "cut.tif"
    path.write_bytes(content[: int(len(content) * cut)])
    _raises(load_dem, path, name="cut.tif")


def test_garbage_geotiff_and_multiband(tmp_path):
    (tmp_path / "junk.tif").write_bytes(b"this is not a tiff at all" * 10)
    _raises(load_dem, tmp_path / "junk.tif", name="junk.tif")
    tifffile.imwrite(tmp_path / "rgb.tif", np.zeros((4, 5, 3), np.uint8), photometric="rgb")
    _raises(load_dem, tmp_path / "rgb.tif", name="rgb.tif", match="3 bands")


def test_envi_missing_or_bad_header(dems_dir, tmp_path):
    shutil.copy(dems_dir / "Mandakini.bil", tmp_path / "basin.bil")
    _raises(load_dem, tmp_path / "basin.bil", name="basin.bil", match="header not found")

    (tmp_path / "basin.hdr").write_text("not an envi header\nsamples = 3\n")
    _raises(load_dem, tmp_path / "basin.bil", name="basin.hdr", match="not an ENVI header")

    header = (dems_dir / "Mandakini.hdr").read_text()
    (tmp_path / "basin.hdr").write_text(header.replace("lines   = 648", "lines   = 700"))
    _raises(load_dem, tmp_path / "basin.bil", name="basin.bil", match="1521504 bytes")

    # GDAL reads ENVI now: its messages name the data file.
    (tmp_path / "basin.hdr").write_text(header.replace("bands   = 1", "bands   = 3"))
    _raises(load_dem, tmp_path / "basin.bil", name="basin.bil", match="3 bands")

    (tmp_path / "basin.hdr").write_text(header.replace("data type = 4", "data type = 6"))
    _raises(load_dem, tmp_path / "basin.bil", name="basin.bil", match="complex64")

    (tmp_path / "basin.hdr").write_text(header.replace("samples = 587", ""))
    _raises(load_dem, tmp_path / "basin.bil", name="basin.bil", match="samples")


def test_usgs_dem_short_and_truncated(dems_dir, tmp_path):
    content = (dems_dir / "SainteHelens.dem").read_bytes()
    (tmp_path / "short.dem").write_bytes(content[:500])
    _raises(load_dem, tmp_path / "short.dem", name="short.dem", match="A record")
    (tmp_path / "half.dem").write_bytes(content[: len(content) // 2])
    _raises(load_dem, tmp_path / "half.dem", name="half.dem", match="truncated")
    (tmp_path / "blank.dem").write_bytes(b" " * 2048)
    _raises(load_dem, tmp_path / "blank.dem", name="blank.dem")


def test_esri_ascii_problems(tmp_path):
    header = "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 10\n"
    cases = {
        "count.asc": header + "1 2 3 4 5\n",
        "word.asc": header + "1 2 3 4 five 6\n",
        "nosize.asc": "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\n1 2 3 4 5 6\n",
        "unknown.asc": "ncols 3\nnrows 2\nbands 1\n1 2 3 4 5 6\n",
        "inf.asc": header + "1 2 3 4 inf 6\n",
        "empty.asc": "",
    }
    expected = {"count.asc": "5 values", "nosize.asc": "cellsize", "unknown.asc": "bands", "inf.asc": "infinite"}
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
        _raises(load_dem, tmp_path / name, name=name, match=expected.get(name))


def test_png_colour_corrupt_and_truncated(tmp_path):
    rgb = np.zeros((8, 8, 3), np.uint8)
    rgb[2:4, :, 0] = 255  # a red ridge stroke
    rgb[5:7, :, 2] = 255  # a blue valley stroke
    Image.fromarray(rgb).save(tmp_path / "sketch.png")
    _raises(load_dem, tmp_path / "sketch.png", name="sketch.png", match="colour image")

    (tmp_path / "junk.png").write_bytes(b"\x89PNG\r\n\x1a\n" + b"garbage" * 20)
    _raises(load_dem, tmp_path / "junk.png", name="junk.png")

    Image.fromarray(np.arange(10000, dtype=np.uint16).reshape(100, 100)).save(tmp_path / "full.png")
    content = (tmp_path / "full.png").read_bytes()
    (tmp_path / "cut.png").write_bytes(content[: len(content) // 2])
    _raises(load_dem, tmp_path / "cut.png", name="cut.png")

    Image.fromarray(np.zeros((4, 4), np.uint8)).save(tmp_path / "really.png", format="BMP")
    _raises(load_dem, tmp_path / "really.png", name="really.png", match="BMP")


def test_malformed_sidecar_is_named(tmp_path):
    save_dem(_field(), tmp_path / "h.png")
    (tmp_path / "h.json").write_text("{not json")
    _raises(load_dem, tmp_path / "h.png", name="h.json")
    (tmp_path / "h.json").write_text(json.dumps({"format": "terrasynth-heightmap", "min": "low", "max": 3}))
    _raises(load_dem, tmp_path / "h.png", name="h.json", match="malformed")
    (tmp_path / "h.json").write_text(json.dumps({"format": "terrasynth-heightmap", "min": 5, "max": 3}))
    _raises(load_dem, tmp_path / "h.png", name="h.json", match="min <= max")


def test_npy_problems(tmp_path):
    np.save(tmp_path / "cube.npy", np.zeros((2, 3, 4)))
    _raises(load_dem, tmp_path / "cube.npy", name="cube.npy", match="2-D")
    np.save(tmp_path / "complex.npy", np.zeros((3, 3), complex))
    _raises(load_dem, tmp_path / "complex.npy", name="complex.npy", match="complex")
    np.save(tmp_path / "objects.npy", np.array([[1, "a"], [2, "b"]], dtype=object), allow_pickle=True)
    _raises(load_dem, tmp_path / "objects.npy", name="objects.npy")
    (tmp_path / "junk.npy").write_bytes(b"\x93NUMPY garbage")
    _raises(load_dem, tmp_path / "junk.npy", name="junk.npy")
    np.save(tmp_path / "tiny.npy", np.zeros((1, 5)))
    _raises(load_dem, tmp_path / "tiny.npy", name="tiny.npy", match="at least 2x2")
    np.save(tmp_path / "inf.npy", np.array([[1, np.inf], [2, 3]]))
    _raises(load_dem, tmp_path / "inf.npy", name="inf.npy", match="infinite")
    np.savez(tmp_path / "archive.npy", a=np.zeros((2, 2)))  # savez adds .npz
    shutil.move(tmp_path / "archive.npy.npz", tmp_path / "archive.npy")
    _raises(load_dem, tmp_path / "archive.npy", name="archive.npy", match="archive")


def test_all_nodata_grids(tmp_path):
    np.save(tmp_path / "void.npy", np.full((4, 4), np.nan, np.float32))
    _raises(load_dem, tmp_path / "void.npy", name="void.npy", match="no valid cell")
    (tmp_path / "void.r32").write_bytes(np.full((3, 3), np.nan, "<f4").tobytes())
    _raises(load_dem, tmp_path / "void.r32", name="void.r32", match="no valid cell")
    (tmp_path / "void.asc").write_text("ncols 2\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\nNODATA_value -1\n-1 -1 -1 -1\n")
    _raises(load_dem, tmp_path / "void.asc", name="void.asc", match="no valid cell")


def test_terragen_problems(tmp_path):
    (tmp_path / "magic.ter").write_bytes(b"LEVELLERTERRAIN " + b"\x00" * 40)
    _raises(load_dem, tmp_path / "magic.ter", name="magic.ter", match="not a Terragen terrain")
    (tmp_path / "noalt.ter").write_bytes(b"TERRAGENTERRAIN SIZE\x02\x00\x00\x00EOF ")
    _raises(load_dem, tmp_path / "noalt.ter", name="noalt.ter", match="ALTW")
    (tmp_path / "chunk.ter").write_bytes(b"TERRAGENTERRAIN ABCD\x00\x00\x00\x00")
    _raises(load_dem, tmp_path / "chunk.ter", name="chunk.ter", match="unknown chunk")
    save_dem(_field(), tmp_path / "good.ter")
    content = (tmp_path / "good.ter").read_bytes()
    (tmp_path / "cut.ter").write_bytes(content[:-10])
    _raises(load_dem, tmp_path / "cut.ter", name="cut.ter", match="truncated")
    (tmp_path / "stub.ter").write_bytes(content[:30])
    _raises(load_dem, tmp_path / "stub.ter", name="stub.ter")


def test_raw_size_problems(tmp_path):
    (tmp_path / "strip.r16").write_bytes(np.zeros(12, "<u2").tobytes())
    _raises(load_dem, tmp_path / "strip.r16", name="strip.r16", match="square")
    _raises(load_dem, tmp_path / "strip.r16", size=(5, 5), name="strip.r16", match="5 x 5")
    (tmp_path / "odd.r32").write_bytes(b"\x00" * 10)
    _raises(load_dem, tmp_path / "odd.r32", name="odd.r32", match="4-byte")
    with pytest.raises(ParamsError, match="size"):
        load_dem(tmp_path / "strip.r16", size=(0, 12))
    with pytest.raises(ParamsError, match="size"):
        load_dem(tmp_path / "strip.r16", size="3x4")


def test_write_problems(tmp_path):
    _raises(save_dem, _field(), tmp_path / "missing" / "out.tif", name="out.tif")
    huge = HeightField(np.zeros((2, 40000), np.float32))
    _raises(save_dem, huge, tmp_path / "wide.ter", name="wide.ter", match="32767")
    assert list(tmp_path.iterdir()) == []


def test_mesh_problems(tmp_path):
    holes = np.full((4, 4), np.nan, np.float32)
    holes[::2, ::2] = 1.0  # valid nodes, but no cell with three valid corners
    _raises(save_mesh, HeightField(holes), tmp_path / "holes.stl", name="holes.stl", match="no triangle")
    with pytest.raises(ParamsError, match="step"):
        save_mesh(_field(), tmp_path / "m.obj", step=3)
    with pytest.raises(ParamsError, match="step"):
        save_mesh(_field(), tmp_path / "m.obj", step=0)
    with pytest.raises(ParamsError, match="vertical_scale"):
        save_mesh(_field(), tmp_path / "m.obj", vertical_scale=float("nan"))
    _raises(save_mesh, _field(), tmp_path / "missing" / "m.ply", name="m.ply")
    assert list(tmp_path.iterdir()) == []
