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
from pathlib import Path

import numpy as np
import pytest

from terrasynth_core.cli.main import EXIT_BAD_INPUT, EXIT_OK, main
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import save_dem


def _digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


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
    """Finding 7: the output exists, the debug folder cannot be made: say which part failed."""
    _example(tmp / "x.npy")
    _mine(tmp / "dbg", "a file where the debug folder should go")
    return (["synth", "--example", tmp / "x.npy", "--size", "64x64", "--patch-size", "32", "--debug-dir",
             tmp / "dbg", "--out", tmp / "t.tif"], EXIT_BAD_INPUT, ["wrote", "t.tif", "but the debug folder", "dbg"])


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
    c_sketch_decompression_bomb,
    c_sketch_over_the_pixel_limit,
    c_style_map_over_the_pixel_limit,
    c_variations_over_the_limit,
    c_debug_dir_fails_after_the_output,
    c_example_with_every_other_row_nodata,
    c_debug_dir_on_a_full_disk,
    c_all_transparent_sketch_is_blank,
    c_nodata_to_terragen_is_reported,
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
    argv, expected, words = case(tmp_path)
    if "No space left on device" in words:
        _full_disk_for_numpy(monkeypatch)
    before = _digests(tmp_path)
    code, out, err = run_case(capsys, argv)
    assert code == expected, err
    assert "Traceback" not in err
    if expected == EXIT_BAD_INPUT:
        # One line of error (argparse's usage lines before it are not a message).
        lines = [line for line in err.strip().splitlines() if "error:" in line]
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
    script = (
        "import os, signal, sys\n"
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
