"""The corruption corpus (issue 13): bad inputs and dangerous outputs through
the CLI, in-process.

Every case builds its files in an empty folder, hashes them, runs
``terrasynth-cli`` through :func:`terrasynth_core.cli.main` and asserts:
exit 0 or 2, no traceback, on error one line naming the file or value at
fault, and no file that existed before changed.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np
import pytest

from terrasynth_core.cli.main import EXIT_BAD_INPUT, EXIT_OK, main
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import save_dem


def _digests(folder: Path) -> dict[str, str]:
    """SHA-256 of every file under ``folder``, the analysis cache's aside (it is
    the program's own, rewritten by design when unreadable)."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.relative_to(folder).parts[0] != "cache"}


def _example(path: Path, shape=(120, 120), offset=500.0, relief=300.0) -> Path:
    """A small smooth example DEM with a sidecar giving 30 m cells."""
    y, x = np.mgrid[0:shape[0], 0:shape[1]]
    heights = (offset + relief * np.sin(x / 9.0) * np.cos(y / 7.0)).astype(np.float32)
    save_dem(HeightField(heights, cell_size=(30.0, 30.0)), path)
    return path


def _mine(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


# -- cases: each takes the folder, makes its inputs, returns (argv, code, words in the message)

def _keeps_users_json(ext: str, text: str):
    """``convert X u<ext>`` beside the user's own ``u.json`` holding ``text``."""
    def case(tmp):
        _example(tmp / "x.npy")
        _mine(tmp / "u.json", text)
        return ["convert", tmp / "x.npy", tmp / f"u{ext}"], EXIT_BAD_INPUT, ["u.json", "not a TerraSynth sidecar"]

    case.__name__ = f"c_convert_{ext[1:]}_keeps_users_json"
    return case


def c_convert_r16_beside_npy_of_same_stem(tmp):
    """Issue 13: ".npy, .r16, .r32 outputs of one stem" share (and clobber) one sidecar."""
    _example(tmp / "x.npy")
    save_dem(HeightField(np.full((8, 8), 7.0, np.float32), cell_size=(10.0, 10.0)), tmp / "t.npy")
    return ["convert", tmp / "x.npy", tmp / "t.r16"], EXIT_BAD_INPUT, ["t.json", "t.npy", "another output name"]


def c_convert_png_beside_plain_png_picture(tmp):
    from PIL import Image

    _example(tmp / "x.npy")
    Image.fromarray(np.arange(64, dtype=np.uint8).reshape(8, 8)).save(tmp / "h.png")
    return ["convert", tmp / "x.npy", tmp / "h.npy"], EXIT_BAD_INPUT, ["h.json", "h.png"]


def c_synth_report_is_outputs_sidecar(tmp):
    _example(tmp / "x.npy")
    return (["synth", "--example", tmp / "x.npy", "--size", "64x64", "--out", tmp / "t.png",
             "--report", tmp / "t.json"], EXIT_BAD_INPUT, ["t.json", "sidecar", "t.png"])


def c_synth_report_over_other_sidecar(tmp):
    _example(tmp / "x.npy")
    save_dem(HeightField(np.ones((4, 4), np.float32)), tmp / "old.r16")
    return (["synth", "--example", tmp / "x.npy", "--size", "64x64", "--out", tmp / "t.tif",
             "--report", tmp / "old.json"], EXIT_BAD_INPUT, ["old.json", "sidecar"])


def c_features_json_over_sidecar(tmp):
    _example(tmp / "x.npy")
    return (["features", tmp / "x.npy", "--json", tmp / "x.json"], EXIT_BAD_INPUT, ["x.json", "sidecar"])


# -- 16-bit colour PNG heightmaps (finding 2)

def c_info_16bit_rgba_png(tmp):
    from test_io_read import write_png16

    levels = np.array([[0, 59400], [1000, 30000]], np.uint16)
    write_png16(tmp / "h.png", np.dstack([levels, levels, levels, np.full_like(levels, 65535)]), 6)
    return ["info", tmp / "h.png", "--json"], EXIT_OK, ['"max": 59400.0']


def c_info_16bit_colour_png_refused(tmp):
    from test_io_read import write_png16

    levels = np.array([[0, 59400], [1000, 30000]], np.uint16)
    write_png16(tmp / "pic.png", np.dstack([levels, levels // 3, levels]), 2)
    return ["info", tmp / "pic.png"], EXIT_BAD_INPUT, ["pic.png", "colour"]


def c_info_16bit_grey_alpha_png_nodata(tmp):
    from test_io_read import write_png16

    levels = np.array([[0, 59400], [1000, 30000]], np.uint16)
    write_png16(tmp / "la.png", np.dstack([levels, np.array([[65535, 0], [65535, 65535]], np.uint16)]), 4)
    return ["info", tmp / "la.png", "--json"], EXIT_OK, ['"max": 30000.0', '"nodata": 1']


def c_info_png_with_malformed_sidecar(tmp):
    save_dem(HeightField(np.arange(16, dtype=np.float32).reshape(4, 4)), tmp / "m.png")
    side = json.loads((tmp / "m.json").read_text())
    side["max"] = "lots"
    (tmp / "m.json").write_text(json.dumps(side))
    return ["info", tmp / "m.png"], EXIT_BAD_INPUT, ["m.json", "malformed"]


# -- extreme numbers (finding 4): refused before the run, naming the value and the range

def _synth_pin(tmp, *options):
    _example(tmp / "x.npy")
    return ["synth", "--example", tmp / "x.npy", "--size", "128x128", "--patch-size", "32",
            "--out", tmp / "t.tif", *options]


def c_pin_nan_position(tmp):
    return _synth_pin(tmp, "--pin", "nan,nan,nan"), EXIT_BAD_INPUT, ["'nan,nan,nan'", "whole cells"]


def c_pin_inf_position(tmp):
    return _synth_pin(tmp, "--pin=inf,0,500"), EXIT_BAD_INPUT, ["'inf,0,500'", "whole cells"]


def c_pin_nan_height(tmp):
    return _synth_pin(tmp, "--pin", "10,10,nan"), EXIT_BAD_INPUT, ["(10, 10)", "non-finite"]


def c_pin_height_1e30(tmp):
    return _synth_pin(tmp, "--pin", "100,100,1e30"), EXIT_BAD_INPUT, ["(100, 100)", "1e+30", "examples' heights"]


def c_pin_height_1e9(tmp):
    return (_synth_pin(tmp, "--pin", "100,100,1e9"), EXIT_BAD_INPUT,
            ["(100, 100)", "1e+09", "examples' heights", "widened by 3 times"])


def c_pin_height_range_1e30(tmp):
    return (_synth_pin(tmp, "--height-range=-1e30,1e30"), EXIT_BAD_INPUT, ["-1e+30..1e+30", "100000"])


def c_pin_beyond_height_range(tmp):
    return (_synth_pin(tmp, "--height-range=0,1000", "--pin", "5,5,9000"), EXIT_BAD_INPUT,
            ["9000", "the height range 0..1000", "-3000..4000"])


def c_example_near_1e30(tmp):
    heights = np.full((120, 120), 1e30, np.float32)
    heights[::2] = 3e29
    np.save(tmp / "huge.npy", heights)
    return (["synth", "--example", tmp / "huge.npy", "--size", "128x128", "--patch-size", "32",
             "--out", tmp / "t.tif"], EXIT_BAD_INPUT, ["huge.npy", "1e+30", "100000"])


def c_pin_within_range_runs(tmp):
    return _synth_pin(tmp, "--pin", "64,64,900"), EXIT_OK, []


# -- silent wrong output, huge images, lesser (finding 5, 6 and 8 parts)

def _sketch(path: Path, rgb: np.ndarray) -> Path:
    from PIL import Image

    Image.fromarray(rgb).save(path)
    return path


def _png_header_only(path: Path, cols: int, rows: int) -> Path:
    """A PNG that claims ``cols x rows`` RGB pixels but holds no data: enough to
    test that the size is refused before any pixel is decoded."""
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", cols, rows, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(b"")) + chunk(b"IEND", b""))
    return path


def c_all_red_sketch_is_reported(tmp):
    _example(tmp / "x.npy")
    rgb = np.zeros((64, 64, 3), np.uint8)
    rgb[..., 0] = 255
    _sketch(tmp / "red.png", rgb)
    return (["synth", "--example", tmp / "x.npy", "--sketch", tmp / "red.png", "--patch-size", "32",
             "--out", tmp / "t.tif"], EXIT_OK, ["100 % of it painted", "no ridge or valley line"])


def c_flat_example_is_reported(tmp):
    save_dem(HeightField(np.full((120, 120), 250.0, np.float32), cell_size=(30.0, 30.0)), tmp / "flat.npy")
    return (["synth", "--example", tmp / "flat.npy", "--size", "64x64", "--patch-size", "32",
             "--out", tmp / "t.tif"], EXIT_OK, ["flat.npy is flat", "250 m"])


def c_negative_size(tmp):
    _example(tmp / "x.npy")
    return (["synth", "--example", tmp / "x.npy", "--size", "-5x5", "--out", tmp / "t.tif"], EXIT_BAD_INPUT,
            ["--size", "'-5x5'", "at least 2"])


def c_size_with_three_numbers(tmp):
    _example(tmp / "x.npy")
    return (["synth", "--example", tmp / "x.npy", "--size", "256x256x2", "--out", tmp / "t.tif"], EXIT_BAD_INPUT,
            ["--size", "'256x256x2' has 3 numbers", "ROWSxCOLS (two)"])


def c_sketch_decompression_bomb(tmp):
    _example(tmp / "x.npy")
    _png_header_only(tmp / "bomb.png", 20000, 20000)
    return (["synth", "--example", tmp / "x.npy", "--sketch", tmp / "bomb.png", "--out", tmp / "t.tif"],
            EXIT_BAD_INPUT, ["bomb.png", "400000000 pixels", "64000000"])


def c_sketch_over_the_pixel_limit(tmp):
    _example(tmp / "x.npy")
    _png_header_only(tmp / "big.png", 10000, 10000)
    return (["synth", "--example", tmp / "x.npy", "--sketch", tmp / "big.png", "--out", tmp / "t.tif"],
            EXIT_BAD_INPUT, ["big.png", "10000x10000", "64000000"])


def c_style_map_over_the_pixel_limit(tmp):
    _example(tmp / "x.npy")
    _png_header_only(tmp / "regions.png", 9000, 9000)
    return (["synth", "--example", tmp / "x.npy", "--styles", tmp / "regions.png", "--style",
             f"#ff0000={tmp / 'x.npy'}", "--out", tmp / "t.tif"], EXIT_BAD_INPUT, ["regions.png", "9000x9000"])


def c_variations_over_the_limit(tmp):
    _example(tmp / "x.npy")
    return (["synth", "--example", tmp / "x.npy", "--size", "64x64", "--patch-size", "32", "--variations", "1000",
             "--out", tmp / "t.tif"], EXIT_BAD_INPUT, ["--variations", "1 to 64", "1000"])


def c_debug_dir_fails_after_the_output(tmp):
    """Finding 7: the output exists, the debug folder cannot be made: say which part failed.  (A
    debug folder that is itself a file is refused before the run; one inside a file is found when
    it is made.)"""
    _example(tmp / "x.npy")
    _mine(tmp / "dbg", "a file where the debug folder's parent should go")
    return (["synth", "--example", tmp / "x.npy", "--size", "64x64", "--patch-size", "32", "--debug-dir",
             tmp / "dbg" / "run", "--out", tmp / "t.tif"], EXIT_BAD_INPUT,
            ["wrote", "t.tif", "but the debug folder", "dbg"])


def c_example_with_every_other_row_nodata(tmp):
    """Finding 8: the valid rectangle is one row; the README's fill fallback applies."""
    y, x = np.mgrid[0:160, 0:160]
    heights = (500 + 300 * np.sin(x / 9.0) * np.cos(y / 7.0)).astype(np.float32)
    heights[::2] = np.nan
    np.save(tmp / "rows.npy", heights)
    return (["synth", "--example", tmp / "rows.npy", "--size", "64x64", "--patch-size", "32",
             "--out", tmp / "t.tif"], EXIT_OK, ["rows.npy", "nodata cells filled"])


def c_debug_dir_on_a_full_disk(tmp):
    """Finding 7: a full disk left a truncated patch_id.npy and said "error: : 65536 requested..."."""
    _example(tmp / "x.npy")
    (tmp / "dbg").mkdir()
    _mine(tmp / "dbg" / "patch_id.npy", "an older file of the user's")
    return (["synth", "--example", tmp / "x.npy", "--size", "64x64", "--patch-size", "32", "--debug-dir",
             tmp / "dbg", "--out", tmp / "t.tif"], EXIT_BAD_INPUT, ["wrote", "t.tif", "but the debug folder",
                                                                      "No space left on device"])


def c_all_transparent_sketch_is_blank(tmp):
    """Finding 8: transparent pixels keeping colours underneath read as "no red strokes but drawn"."""
    _example(tmp / "x.npy")
    rgba = np.random.default_rng(3).integers(0, 256, (64, 64, 4), dtype=np.uint8)
    rgba[..., 3] = 0
    _sketch(tmp / "clear.png", rgba)
    return (["synth", "--example", tmp / "x.npy", "--sketch", tmp / "clear.png", "--patch-size", "32",
             "--out", tmp / "t.tif"], EXIT_OK, ["the sketch has no strokes"])


def c_nodata_to_terragen_is_reported(tmp):
    """Finding 8: NaN holes written to .ter silently became the minimum height."""
    heights = np.linspace(100, 200, 64 * 64, dtype=np.float32).reshape(64, 64)
    heights[10:20, 10:20] = np.nan
    save_dem(HeightField(heights, cell_size=(30.0, 30.0)), tmp / "holes.npy")
    return ["convert", tmp / "holes.npy", tmp / "holes.ter"], EXIT_OK, ["100 nodata cells", "holes.npy", "minimum"]



# -- readers: damaged and foreign files, named in one line

def _info(path):
    return ["info", path]


def c_reader_empty_tif(tmp):
    (tmp / "e.tif").write_bytes(b"")
    return _info(tmp / "e.tif"), EXIT_BAD_INPUT, ["e.tif"]


def c_reader_text_as_tif(tmp):
    _mine(tmp / "notes.tif", "these are my notes, not a GeoTIFF\n")
    return _info(tmp / "notes.tif"), EXIT_BAD_INPUT, ["notes.tif"]


def c_reader_truncated_tif(tmp):
    _example(tmp / "x.npy")
    main(["convert", str(tmp / "x.npy"), str(tmp / "full.tif")])
    data = (tmp / "full.tif").read_bytes()
    (tmp / "cut.tif").write_bytes(data[: len(data) // 3])
    (tmp / "full.tif").unlink()
    return _info(tmp / "cut.tif"), EXIT_BAD_INPUT, ["cut.tif"]


def c_reader_hgt_of_wrong_size(tmp):
    (tmp / "N44W072.hgt").write_bytes(b"\0\1" * 1000)
    return _info(tmp / "N44W072.hgt"), EXIT_BAD_INPUT, ["N44W072.hgt"]


def c_reader_asc_bad_header(tmp):
    _mine(tmp / "g.asc", "ncols ten\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n3 4\n")
    return _info(tmp / "g.asc"), EXIT_BAD_INPUT, ["g.asc"]


def c_reader_asc_short_grid(tmp):
    _mine(tmp / "s.asc", "ncols 3\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 10\n1 2 3\n4 5 6\n")
    return _info(tmp / "s.asc"), EXIT_BAD_INPUT, ["s.asc"]


def c_reader_npy_3d(tmp):
    np.save(tmp / "cube.npy", np.zeros((4, 4, 4), np.float32))
    return _info(tmp / "cube.npy"), EXIT_BAD_INPUT, ["cube.npy"]


def c_reader_npy_object_array(tmp):
    np.save(tmp / "obj.npy", np.array([[{"a": 1}, None]], dtype=object), allow_pickle=True)
    return _info(tmp / "obj.npy"), EXIT_BAD_INPUT, ["obj.npy"]


def c_reader_ter_garbage(tmp):
    (tmp / "t.ter").write_bytes(b"TERRAGENTERRAIN " + bytes(range(256)) * 3)
    return _info(tmp / "t.ter"), EXIT_BAD_INPUT, ["t.ter"]


def c_reader_r16_not_square(tmp):
    (tmp / "h.r16").write_bytes(b"\0\0" * 1000)
    return _info(tmp / "h.r16"), EXIT_BAD_INPUT, ["h.r16"]


def c_reader_r32_size_mismatch(tmp):
    (tmp / "h.r32").write_bytes(np.zeros(100, np.float32).tobytes())
    return ["info", tmp / "h.r32", "--size", "20x20"], EXIT_BAD_INPUT, ["h.r32"]


def c_reader_usgs_dem_garbage(tmp):
    _mine(tmp / "q.dem", "not a USGS DEM " * 100)
    return _info(tmp / "q.dem"), EXIT_BAD_INPUT, ["q.dem"]


def c_reader_missing_file(tmp):
    return _info(tmp / "nowhere.tif"), EXIT_BAD_INPUT, ["nowhere.tif"]


def c_reader_folder(tmp):
    (tmp / "dem.tif").mkdir()
    return _info(tmp / "dem.tif"), EXIT_BAD_INPUT, ["dem.tif"]


def c_reader_unknown_extension(tmp):
    _mine(tmp / "heights.xyz", "1 2 3\n")
    return _info(tmp / "heights.xyz"), EXIT_BAD_INPUT, ["heights.xyz"]


def c_reader_truncated_png(tmp):
    save_dem(HeightField(np.arange(64, dtype=np.float32).reshape(8, 8)), tmp / "p.png")
    data = (tmp / "p.png").read_bytes()
    (tmp / "p.png").write_bytes(data[: len(data) // 2])
    return _info(tmp / "p.png"), EXIT_BAD_INPUT, ["p.png"]


def c_reader_all_nodata(tmp):
    np.save(tmp / "void.npy", np.full((32, 32), np.nan, np.float32))
    return (["synth", "--example", tmp / "void.npy", "--size", "64x64", "--patch-size", "32",
             "--out", tmp / "t.tif"], EXIT_BAD_INPUT, ["void.npy"])


def c_convert_onto_a_folder(tmp):
    _example(tmp / "x.npy")
    (tmp / "out.tif").mkdir()
    return ["convert", tmp / "x.npy", tmp / "out.tif"], EXIT_BAD_INPUT, ["out.tif"]


# -- sketches

def _synth_sketch(tmp, sketch):
    _example(tmp / "x.npy")
    return ["synth", "--example", tmp / "x.npy", "--sketch", sketch, "--patch-size", "32", "--out", tmp / "t.tif"]


def c_sketch_not_a_png(tmp):
    _mine(tmp / "s.png", "a shopping list")
    return _synth_sketch(tmp, tmp / "s.png"), EXIT_BAD_INPUT, ["s.png"]


def c_sketch_truncated(tmp):
    rgb = np.full((64, 64, 3), 255, np.uint8)
    rgb[30, :, 1:] = 0
    _sketch(tmp / "s.png", rgb)
    data = (tmp / "s.png").read_bytes()
    (tmp / "s.png").write_bytes(data[: len(data) // 2])
    return _synth_sketch(tmp, tmp / "s.png"), EXIT_BAD_INPUT, ["s.png"]


def c_sketch_missing(tmp):
    return _synth_sketch(tmp, tmp / "gone.png"), EXIT_BAD_INPUT, ["gone.png"]


def c_sketch_smaller_than_a_patch(tmp):
    _sketch(tmp / "tiny.png", np.full((8, 8, 3), 255, np.uint8))
    return _synth_sketch(tmp, tmp / "tiny.png"), EXIT_BAD_INPUT, ["8x8", "patch"]


# -- options

def _synth_opts(tmp, *options):
    _example(tmp / "x.npy")
    return ["synth", "--example", tmp / "x.npy", "--size", "128x128", "--patch-size", "32",
            "--out", tmp / "t.tif", *options]


def c_option_size_words(tmp):
    _example(tmp / "x.npy")
    return (["synth", "--example", tmp / "x.npy", "--size", "big", "--out", tmp / "t.tif"], EXIT_BAD_INPUT,
            ["--size", "'big'"])


def c_option_size_zero(tmp):
    _example(tmp / "x.npy")
    return (["synth", "--example", tmp / "x.npy", "--size", "0x0", "--out", tmp / "t.tif"], EXIT_BAD_INPUT,
            ["--size", "'0x0'"])


def c_option_size_over_the_limit(tmp):
    return _synth_opts(tmp, "--size", "9000x9000"), EXIT_BAD_INPUT, ["9000x9000", "64 million"]


def c_option_cell_size_negative(tmp):
    return _synth_opts(tmp, "--cell-size=-3"), EXIT_BAD_INPUT, ["--cell-size", "'-3'"]


def c_option_cell_size_nan(tmp):
    return _synth_opts(tmp, "--cell-size", "nan"), EXIT_BAD_INPUT, ["--cell-size", "'nan'"]


def c_option_band_zero(tmp):
    return _synth_opts(tmp, "--band", "0"), EXIT_BAD_INPUT, ["--band", "'0'"]


def c_option_height_range_reversed(tmp):
    return _synth_opts(tmp, "--height-range", "500,100"), EXIT_BAD_INPUT, ["500", "100"]


def c_option_height_range_words(tmp):
    return _synth_opts(tmp, "--height-range", "low,high"), EXIT_BAD_INPUT, ["--height-range", "'low,high'"]


def c_option_style_without_colour(tmp):
    _sketch(tmp / "regions.png", np.full((128, 128, 3), 200, np.uint8))
    return (_synth_opts(tmp, "--styles", tmp / "regions.png", "--style", "builtin:himalaya"), EXIT_BAD_INPUT,
            ["--style", "#RRGGBB=DEM"])


def c_option_stamp_window_outside(tmp):
    return (_synth_opts(tmp, "--stamp", f"{tmp / 'x.npy'}[0:500,0:20]@64,64"), EXIT_BAD_INPUT,
            ["stamp window", "x.npy", "120x120"])


def c_option_thin_stamp(tmp):
    """A 100x10 window at scale 0.1 is 10x1 output cells: the engine said only "make it larger"."""
    return (_synth_opts(tmp, "--stamp", f"{tmp / 'x.npy'}[0:100,0:10]@64,64,0,0.1"), EXIT_BAD_INPUT,
            ["stamp 1", "x.npy", "100x10-cell window", "10.0 x 1.0 output cells", "scale of at least 0.5"])


def c_option_pin_outside(tmp):
    return _synth_opts(tmp, "--pin", "500,500,600"), EXIT_BAD_INPUT, ["(500, 500)", "128x128"]


def c_option_water_without_level(tmp):
    _sketch(tmp / "w.png", np.full((128, 128, 3), 255, np.uint8))
    return _synth_opts(tmp, "--water", tmp / "w.png"), EXIT_BAD_INPUT, ["--water", "--water-level"]


def c_option_patch_larger_than_output(tmp):
    _example(tmp / "x.npy")
    return (["synth", "--example", tmp / "x.npy", "--size", "64x64", "--patch-size", "100", "--out",
             tmp / "t.tif"], EXIT_BAD_INPUT, ["64x64", "patch (100)"])


def c_option_unknown_output_extension(tmp):
    _example(tmp / "x.npy")
    return (["synth", "--example", tmp / "x.npy", "--size", "64x64", "--out", tmp / "t.doc"], EXIT_BAD_INPUT,
            ["t.doc", "'.doc'"])


def c_option_output_folder_missing(tmp):
    _example(tmp / "x.npy")
    return (["synth", "--example", tmp / "x.npy", "--size", "64x64", "--out", tmp / "no" / "t.tif"],
            EXIT_BAD_INPUT, ["no", "does not exist"])


def c_option_cog_not_tif(tmp):
    _example(tmp / "x.npy")
    return ["convert", tmp / "x.npy", tmp / "y.png", "--cog"], EXIT_BAD_INPUT, ["--cog", "y.png"]


# -- projects (synth --project)

def _project(tmp: Path, name="p.tsproj") -> Path:
    """A small saved project (written with the core's project writer)."""
    from terrasynth_core.project import ExampleRef, ProjectData, write_project
    from terrasynth_core.synthesis import Pin, SynthesisParams

    _example(tmp / "x.npy")
    ridge = np.zeros((96, 96), np.uint8)
    ridge[48, 10:86] = 255
    data = ProjectData(ridge, np.zeros_like(ridge), np.full(ridge.shape, -1, np.int16), np.zeros(ridge.shape, bool),
                       examples=(ExampleRef(path=str(tmp / "x.npy")),),
                       params=SynthesisParams(patch_size=32, seed=2), pins=(Pin(48, 48, 600.0),))
    return write_project(data, tmp / name)


def _synth_project(tmp, path, *options):
    return ["synth", "--project", path, "--out", tmp / "t.tif", *options]


def c_project_renders(tmp):
    return _synth_project(tmp, _project(tmp)), EXIT_OK, ["wrote", "t.tif", "pin (48, 48)"]


def c_project_not_a_zip(tmp):
    _mine(tmp / "p.tsproj", "not a project")
    return _synth_project(tmp, tmp / "p.tsproj"), EXIT_BAD_INPUT, ["p.tsproj", "damaged"]


def c_project_missing(tmp):
    return _synth_project(tmp, tmp / "gone.tsproj"), EXIT_BAD_INPUT, ["gone.tsproj", "does not exist"]


def c_project_bit_rot(tmp):
    import zipfile

    path = _project(tmp)
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo("sketch_ridge.npy")
    raw = bytearray(path.read_bytes())
    start = info.header_offset + 30 + len(info.filename.encode()) + len(info.extra)
    for i in range(start + 2, start + min(info.compress_size, 40)):
        raw[i] ^= 0x5A
    path.write_bytes(bytes(raw))
    return _synth_project(tmp, path), EXIT_BAD_INPUT, ["p.tsproj", "damaged"]


def _rewrite_member(path: Path, member: str, data: bytes) -> None:
    import zipfile

    with zipfile.ZipFile(path) as zf:
        content = {name: zf.read(name) for name in zf.namelist()}
    content[member] = data
    with zipfile.ZipFile(path, "w") as zf:
        for name, value in content.items():
            zf.writestr(name, value)


def c_project_json_is_a_list(tmp):
    path = _project(tmp)
    _rewrite_member(path, "project.json", b"[1, 2, 3]")
    return _synth_project(tmp, path), EXIT_BAD_INPUT, ["p.tsproj", "list"]


def c_project_newer_version(tmp):
    import zipfile

    path = _project(tmp)
    with zipfile.ZipFile(path) as zf:
        meta = json.loads(zf.read("project.json"))
    meta["version"] = 99
    _rewrite_member(path, "project.json", json.dumps(meta).encode())
    return _synth_project(tmp, path), EXIT_BAD_INPUT, ["p.tsproj", "version 99"]


def c_project_huge_layers(tmp):
    import io

    path = _project(tmp)
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "|u1", "fortran_order": False, "shape": (40000, 40000)})
    _rewrite_member(path, "sketch_ridge.npy", buf.getvalue() + b"\0" * 64)
    return _synth_project(tmp, path), EXIT_BAD_INPUT, ["p.tsproj", "40000 x 40000"]


def c_project_example_gone(tmp):
    path = _project(tmp)
    (tmp / "x.npy").unlink()
    (tmp / "x.json").unlink()
    return _synth_project(tmp, path), EXIT_BAD_INPUT, ["x.npy"]


def c_project_with_a_contradicting_option(tmp):
    return (_synth_project(tmp, _project(tmp), "--sketch", tmp / "s.png"), EXIT_BAD_INPUT,
            ["--sketch", "cannot be combined with --project"])


def c_project_pin_out_of_range(tmp):
    import zipfile

    path = _project(tmp)
    with zipfile.ZipFile(path) as zf:
        meta = json.loads(zf.read("project.json"))
    meta["pins"] = [{"row": 48, "col": 48, "height": 1e9}]
    _rewrite_member(path, "project.json", json.dumps(meta).encode())
    return _synth_project(tmp, path), EXIT_BAD_INPUT, ["(48, 48)", "1e+09"]


def c_project_nan_water_level(tmp):
    import zipfile

    path = _project(tmp)
    with zipfile.ZipFile(path) as zf:
        meta = json.loads(zf.read("project.json"))
    meta["water_level"] = float("nan")
    _rewrite_member(path, "project.json", json.dumps(meta).encode())
    return _synth_project(tmp, path), EXIT_BAD_INPUT, ["p.tsproj", "water_level"]


# -- caches: an unreadable, truncated or foreign analysis cache is ignored, never an error

def _with_cache(tmp, monkeypatch, spoil):
    """Run once to fill a fresh cache, spoil its files, and run again with empty in-memory memos."""
    from terrasynth_core.exemplars import cache, ground, prepare

    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp / "cache"))

    def fresh_memos():
        monkeypatch.setattr(prepare, "_CACHE", cache.Memo(8, cache.load, lambda k, v: cache.save(k, *v)))
        monkeypatch.setattr(ground, "_MEMO", cache.Memo(16, cache.load_array, cache.save_array))

    fresh_memos()
    _example(tmp / "x.npy")
    argv = ["synth", "--example", str(tmp / "x.npy"), "--size", "64x64", "--patch-size", "32",
            "--out", str(tmp / "first.tif")]
    assert main(argv) == EXIT_OK
    files = sorted((tmp / "cache").glob("*.npz"))
    assert files
    for f in files:
        spoil(f)
    fresh_memos()
    return ["synth", "--example", tmp / "x.npy", "--size", "64x64", "--patch-size", "32", "--out", tmp / "t.tif"]


def c_cache_files_are_garbage(tmp, monkeypatch):
    return _with_cache(tmp, monkeypatch, lambda f: f.write_bytes(b"garbage" * 10)), EXIT_OK, ["wrote", "t.tif"]


def c_cache_files_truncated(tmp, monkeypatch):
    return (_with_cache(tmp, monkeypatch, lambda f: f.write_bytes(f.read_bytes()[: f.stat().st_size // 2])),
            EXIT_OK, ["wrote", "t.tif"])


def c_cache_folder_is_a_file(tmp, monkeypatch):
    from terrasynth_core.exemplars import cache, prepare

    _mine(tmp / "cachefile", "not a folder")
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp / "cachefile"))
    monkeypatch.setattr(prepare, "_CACHE", cache.Memo(8, cache.load, lambda k, v: cache.save(k, *v)))
    _example(tmp / "x.npy")
    return (["synth", "--example", tmp / "x.npy", "--size", "64x64", "--patch-size", "32", "--out", tmp / "t.tif"],
            EXIT_OK, ["wrote", "t.tif"])


def c_truncated_exr(tmp):
    """An .exr cut short is one line naming it."""
    _example(tmp / "x.npy")
    main(["convert", str(tmp / "x.npy"), str(tmp / "whole.exr")])
    data = (tmp / "whole.exr").read_bytes()
    (tmp / "whole.exr").unlink()
    (tmp / "cut.exr").write_bytes(data[: len(data) // 2])
    return ["info", tmp / "cut.exr"], EXIT_BAD_INPUT, ["cut.exr"]


def c_export_keeps_users_tile(tmp):
    """An export into a folder holding one of its tile names refuses before writing any tile."""
    _example(tmp / "x.npy", shape=(253, 253))
    (tmp / "ue").mkdir()
    _mine(tmp / "ue" / "terrain_x1_y1.png", "my picture")
    return (["export", tmp / "x.npy", "--preset", "unreal", "--out", tmp / "ue", "--size", "127", "--tiles", "2"],
            EXIT_BAD_INPUT, ["terrain_x1_y1.png", "never replaces"])


def c_export_keeps_users_settings_json(tmp):
    _example(tmp / "x.npy")
    _mine(tmp / "terrain.godot.json", '{"mine": true}')
    return (["export", tmp / "x.npy", "--preset", "godot", "--out", tmp],
            EXIT_BAD_INPUT, ["terrain.godot.json", "never replaces"])


def c_masks_keep_users_file(tmp):
    _example(tmp / "x.npy")
    _mine(tmp / "terrain_masks.json", "my notes")
    return ["masks", tmp / "x.npy", "--out", tmp], EXIT_BAD_INPUT, ["terrain_masks.json", "never replaces"]


def c_export_out_is_a_file(tmp):
    _example(tmp / "x.npy")
    _mine(tmp / "folder", "a file, not a folder")
    return ["export", tmp / "x.npy", "--preset", "blender", "--out", tmp / "folder"], EXIT_BAD_INPUT, ["folder is a file"]


CASES = [
    c_truncated_exr,
    c_export_keeps_users_tile,
    c_export_keeps_users_settings_json,
    c_masks_keep_users_file,
    c_export_out_is_a_file,
    _keeps_users_json(".png", '{"mine": 1}\n'),
    _keeps_users_json(".npy", "[1, 2]"),
    _keeps_users_json(".r16", "not json at all"),
    _keeps_users_json(".r32", '{"format": "something-else"}'),
    c_convert_r16_beside_npy_of_same_stem,
    c_convert_png_beside_plain_png_picture,
    c_synth_report_is_outputs_sidecar,
    c_synth_report_over_other_sidecar,
    c_features_json_over_sidecar,
    c_info_16bit_rgba_png,
    c_info_16bit_colour_png_refused,
    c_info_16bit_grey_alpha_png_nodata,
    c_info_png_with_malformed_sidecar,
    c_pin_nan_position,
    c_pin_inf_position,
    c_pin_nan_height,
    c_pin_height_1e30,
    c_pin_height_1e9,
    c_pin_height_range_1e30,
    c_pin_beyond_height_range,
    c_example_near_1e30,
    c_pin_within_range_runs,
    c_all_red_sketch_is_reported,
    c_flat_example_is_reported,
    c_negative_size,
    c_size_with_three_numbers,
    c_sketch_decompression_bomb,
    c_sketch_over_the_pixel_limit,
    c_style_map_over_the_pixel_limit,
    c_variations_over_the_limit,
    c_debug_dir_fails_after_the_output,
    c_example_with_every_other_row_nodata,
    c_debug_dir_on_a_full_disk,
    c_all_transparent_sketch_is_blank,
    c_nodata_to_terragen_is_reported,
    # readers
    c_reader_empty_tif,
    c_reader_text_as_tif,
    c_reader_truncated_tif,
    c_reader_hgt_of_wrong_size,
    c_reader_asc_bad_header,
    c_reader_asc_short_grid,
    c_reader_npy_3d,
    c_reader_npy_object_array,
    c_reader_ter_garbage,
    c_reader_r16_not_square,
    c_reader_r32_size_mismatch,
    c_reader_usgs_dem_garbage,
    c_reader_missing_file,
    c_reader_folder,
    c_reader_unknown_extension,
    c_reader_truncated_png,
    c_reader_all_nodata,
    c_convert_onto_a_folder,
    # sketches
    c_sketch_not_a_png,
    c_sketch_truncated,
    c_sketch_missing,
    c_sketch_smaller_than_a_patch,
    # options
    c_option_size_words,
    c_option_size_zero,
    c_option_size_over_the_limit,
    c_option_cell_size_negative,
    c_option_cell_size_nan,
    c_option_band_zero,
    c_option_height_range_reversed,
    c_option_height_range_words,
    c_option_style_without_colour,
    c_option_stamp_window_outside,
    c_option_thin_stamp,
    c_option_pin_outside,
    c_option_water_without_level,
    c_option_patch_larger_than_output,
    c_option_unknown_output_extension,
    c_option_output_folder_missing,
    c_option_cog_not_tif,
    # projects
    c_project_renders,
    c_project_not_a_zip,
    c_project_missing,
    c_project_bit_rot,
    c_project_json_is_a_list,
    c_project_newer_version,
    c_project_huge_layers,
    c_project_example_gone,
    c_project_with_a_contradicting_option,
    c_project_pin_out_of_range,
    c_project_nan_water_level,
    # caches
    c_cache_files_are_garbage,
    # (exemplars/cache.py opens the file itself: np.load given a path would
    # leave a truncated archive's file open.)
    pytest.param(c_cache_files_truncated, marks=[pytest.mark.filterwarnings("error::ResourceWarning")]),
    c_cache_folder_is_a_file,
]


def run_case(capsys, argv) -> tuple[int, str, str]:
    """``main(argv)`` -> (exit code, stdout, stderr); argparse's exit counts as a code."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def _full_disk_for_numpy(monkeypatch):
    """``np.save`` fails half-way as on a full disk (a tmpfs is not mountable here)."""
    real_save = np.save

    def save(file, array, *args, **kwargs):
        if hasattr(file, "write"):
            file.write(b"\x93NUMPY partial")
            raise OSError(28, "No space left on device")
        return real_save(file, array, *args, **kwargs)

    monkeypatch.setattr(np, "save", save)


@pytest.mark.parametrize("case", CASES, ids=lambda f: f.__name__[2:])
def test_corruption_corpus(capsys, tmp_path, monkeypatch, case):
    import inspect

    if len(inspect.signature(case).parameters) == 2:
        argv, expected, words = case(tmp_path, monkeypatch)
    else:
        argv, expected, words = case(tmp_path)
    if "No space left on device" in words:
        _full_disk_for_numpy(monkeypatch)
    capsys.readouterr()  # what making the inputs printed is not the case's output
    before = _digests(tmp_path)
    code, out, err = run_case(capsys, argv)
    assert code == expected, err
    assert "Traceback" not in err
    if expected == EXIT_BAD_INPUT:
        # One line of error (notes may come before it).
        lines = [line for line in err.strip().splitlines() if "error:" in line]
        assert "usage:" not in err
        assert len(lines) == 1, err
        for word in words:
            assert word in lines[0], lines[0]
    else:
        for word in words:
            assert word in out + err, out + err
    after = _digests(tmp_path)
    changed = [name for name, digest in before.items() if after.get(name) != digest]
    assert not changed, f"pre-existing files changed: {changed}"
    if code != EXIT_OK and "wrote" not in words:
        assert set(after) == set(before), f"files left behind: {set(after) - set(before)}"


def test_sidecar_rewritten_when_it_is_ours(tmp_path):
    """Writing the same heightmap again replaces our own sidecar (no false refusal)."""
    _example(tmp_path / "x.npy")
    assert main(["convert", str(tmp_path / "x.npy"), str(tmp_path / "u.png")]) == EXIT_OK
    first = json.loads((tmp_path / "u.json").read_text())
    save_dem(HeightField(np.full((8, 8), 5.0, np.float32) + np.arange(8, dtype=np.float32)), tmp_path / "u.png")
    second = json.loads((tmp_path / "u.json").read_text())
    assert first["format"] == second["format"] == "terrasynth-heightmap"
    assert second["shape"] == [8, 8]


def test_sigterm_during_a_write_leaves_no_temporary_file(tmp_path):
    """Issue 13, finding 7: SIGTERM during a large write left a hidden .NAME.HEX.tmp."""
    import subprocess
    import sys

    _example(tmp_path / "x.npy")
    # (A shell that starts the test suite in the background hands its
    # children SIGINT ignored; Python then installs no handler for it.)
    script = (
        "import os, signal, sys\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "import numpy as np\n"
        "real = np.save\n"
        "def save(fh, array, **kw):\n"
        "    fh.write(b'partial' * 1000); fh.flush()\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    real(fh, array, **kw)\n"
        "np.save = save\n"
        "from terrasynth_core.cli.main import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    before = _digests(tmp_path)
    done = subprocess.run([sys.executable, "-c", script, "convert", str(tmp_path / "x.npy"), str(tmp_path / "y.npy")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip() == "terrasynth-cli: interrupted"
    assert _digests(tmp_path) == before  # no y.npy, no y.json, no temporary file


# -- a real full disk: a tiny tmpfs (needs root; skipped, saying why, elsewhere)

@pytest.fixture
def tiny_disk(tmp_path):
    """A 256 KiB tmpfs mounted at ``tmp_path / "disk"``, unmounted after."""
    import shutil
    import subprocess

    disk = tmp_path / "disk"
    disk.mkdir()
    # CI runs as root with mount: there the real full disk must be tried.
    give_up = pytest.fail if os.environ.get("CI") else pytest.skip
    mount = shutil.which("mount")
    if mount is None:
        give_up("no mount command here: the full-disk case needs a tiny tmpfs")
    done = subprocess.run([mount, "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(disk)], capture_output=True,
                          text=True)
    if done.returncode != 0:
        give_up(f"cannot mount a tmpfs here ({done.stderr.strip() or 'not root'}): the full-disk case "
                "is simulated by c_debug_dir_on_a_full_disk instead")
    try:
        yield disk
    finally:
        subprocess.run(["umount", str(disk)], check=False)


@pytest.mark.parametrize("output", ["big.npy", "big.tif", "big.png", "big.ter", "big.stl"])
def test_full_disk_leaves_nothing_and_says_so(capsys, tmp_path, tiny_disk, output):
    """convert onto a full tmpfs: exit 2, one line naming the file and the full disk,
    no temporary file, no truncated output, the user's file there unchanged."""
    rng = np.random.default_rng(0)
    # Random heights: no format compresses them below the disk's 256 KiB.
    save_dem(HeightField(rng.normal(500, 100, (400, 400)).astype(np.float32), cell_size=(30.0, 30.0)),
             tmp_path / "x.npy")
    (tiny_disk / "mine.txt").write_text("the user's notes")
    before = _digests(tmp_path)
    code, out, err = run_case(capsys, ["convert", tmp_path / "x.npy", tiny_disk / output])
    assert code == EXIT_BAD_INPUT, err
    assert "Traceback" not in err
    [line] = [line for line in err.strip().splitlines() if "error:" in line]
    assert output in line and "No space left on device" in line, line
    assert sorted(p.name for p in tiny_disk.iterdir()) == ["mine.txt"]
    assert _digests(tmp_path) == before


def test_debug_dir_on_a_really_full_disk(capsys, tmp_path, tiny_disk):
    """Finding 7 on a real full disk: the output is written elsewhere; the debug
    folder fails and the line says which part failed; no truncated array stays."""
    _example(tmp_path / "x.npy")
    filler = tiny_disk / "filler.bin"
    with open(filler, "wb") as fh:  # leave a few KiB: the first debug array does not fit
        try:
            fh.write(b"\0" * (250 * 1024))
        except OSError:
            pass
    code, out, err = run_case(capsys, ["synth", "--example", tmp_path / "x.npy", "--size", "128x128",
                                       "--patch-size", "32", "--debug-dir", tiny_disk / "dbg",
                                       "--out", tmp_path / "t.tif"])
    assert code == EXIT_BAD_INPUT and "Traceback" not in err
    [line] = [line for line in err.strip().splitlines() if "error:" in line]
    assert "wrote" in line and "t.tif" in line and "debug folder" in line and "No space left on device" in line
    assert (tmp_path / "t.tif").exists()
    assert [p.name for p in (tiny_disk / "dbg").iterdir() if p.suffix == ".npy" or p.name.endswith(".tmp")] == []


# SIGINT here; SIGTERM takes the same path in test_sigterm_during_a_write_leaves_no_temporary_file.
@pytest.mark.parametrize("signame", ["SIGINT"])
def test_a_signal_during_synth_project_leaves_no_temporary_file(tmp_path, signame):
    """SIGINT or SIGTERM while ``synth --project`` writes its output: status 130,
    one line, no temporary and no output file, the project unchanged."""
    import subprocess
    import sys

    path = _project(tmp_path)
    # (A shell that starts the test suite in the background hands its
    # children SIGINT ignored; Python then installs no handler for it.)
    script = (
        "import os, signal, sys\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "import numpy as np\n"
        "real = np.save\n"
        "def save(fh, array, **kw):\n"
        "    fh.write(b'partial' * 1000); fh.flush()\n"
        f"    os.kill(os.getpid(), signal.{signame})\n"
        "    real(fh, array, **kw)\n"
        "np.save = save\n"
        "from terrasynth_core.cli.main import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    before = _digests(tmp_path)
    done = subprocess.run([sys.executable, "-c", script, "synth", "--project", str(path), "--out",
                           str(tmp_path / "out.npy")], capture_output=True, text=True, timeout=300)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip().splitlines()[-1] == "terrasynth-cli: interrupted"
    assert _digests(tmp_path) == before
