"""Property-based tests (Hypothesis) of the readers and the CLI's option
parsers (issue 13): whatever the bytes or the text, the answer is a valid
result or one :class:`TerraSynthError` (argparse's usage error for options),
never another exception.

Examples are few and small (``max_examples``), so the module runs in seconds.
"""

from __future__ import annotations

import argparse
import functools
import math
import tempfile
import warnings
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from terrasynth_core.cli.controls import _numbers, parse_pin, parse_stamp, parse_style
from terrasynth_core.cli.main import _join_signed_values, build_parser, parse_size, positive_band, positive_metres
from terrasynth_core.controls.options import check_height_range
from terrasynth_core.errors import TerraSynthError
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import load_dem, save_dem
from terrasynth_core.project import read_project

QUICK = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])

#: Extensions the readers take by their own code or GDAL's.
READ_EXTENSIONS = [".tif", ".png", ".npy", ".asc", ".ter", ".hgt", ".dem", ".r16", ".r32", ".img"]
#: Extensions written and read back (truncation cases).
ROUND_TRIP_EXTENSIONS = [".tif", ".png", ".npy", ".asc", ".ter", ".r16", ".r32"]


def _load_or_refuse(path: Path) -> None:
    """``load_dem(path)`` gives a 2-D float32 field or raises TerraSynthError."""
    with warnings.catch_warnings():
        # Library warnings (not georeferenced...) are not the property here.
        warnings.simplefilter("ignore")
        try:
            field = load_dem(path, size=(4, 4) if path.suffix in (".r16", ".r32") and path.stat().st_size in (32, 64)
                             else None)
        except TerraSynthError as exc:
            message = str(exc)
            assert message and "\n" not in message.strip(), message
            return
    assert isinstance(field, HeightField)
    assert field.heights.ndim == 2 and field.heights.dtype == np.float32


@QUICK
@given(data=st.binary(max_size=2048), ext=st.sampled_from(READ_EXTENSIONS))
def test_random_bytes_are_read_or_refused(data, ext):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"random{ext}"
        path.write_bytes(data)
        _load_or_refuse(path)


@functools.lru_cache(maxsize=None)
def _valid_file(ext: str) -> bytes:
    """The bytes of a small valid file in the format of ``ext`` (its sidecar aside)."""
    y, x = np.mgrid[0:24, 0:24]
    field = HeightField((300 + 50 * np.sin(x / 3.0) * np.cos(y / 4.0)).astype(np.float32), cell_size=(10.0, 10.0))
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"valid{ext}"
        save_dem(field, path)
        return path.read_bytes()


@QUICK
@given(ext=st.sampled_from(ROUND_TRIP_EXTENSIONS), cut=st.floats(0.0, 1.0), flips=st.lists(
    st.tuples(st.floats(0.0, 1.0, exclude_max=True), st.integers(1, 255)), max_size=4))
def test_truncated_or_bit_flipped_files_are_read_or_refused(ext, cut, flips):
    valid = _valid_file(ext)
    data = bytearray(valid[: int(len(valid) * cut)])
    for where, mask in flips:
        if data:
            data[int(where * len(data))] ^= mask
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"damaged{ext}"
        path.write_bytes(bytes(data))
        _load_or_refuse(path)


@QUICK
@given(data=st.binary(max_size=4096))
def test_random_project_files_are_read_or_refused(data):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "p.tsproj"
        path.write_bytes(data)
        try:
            read_project(path)
        except TerraSynthError as exc:
            assert "p.tsproj" in str(exc) and "\n" not in str(exc)


# -- option parsers -------------------------------------------------------------------

NUMBER_TEXT = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**12, 10**12).map(str),
    st.sampled_from(["nan", "inf", "-inf", "1e30", "-0", "0x10", "", " ", "1_000", "½", "１２"]),
)
#: Comma-separated lists of numbers and junk, as typed on a command line.
LIST_TEXT = st.one_of(st.lists(NUMBER_TEXT, max_size=5).map(",".join), st.text(max_size=30))


@QUICK
@given(text=st.one_of(st.text(max_size=20), st.tuples(NUMBER_TEXT, NUMBER_TEXT).map("x".join)))
def test_size_is_two_sides_of_at_least_2_or_a_usage_error(text):
    try:
        rows, cols = parse_size(text)
    except argparse.ArgumentTypeError as exc:
        assert repr(text) in str(exc)
        return
    assert isinstance(rows, int) and isinstance(cols, int) and min(rows, cols) >= 2


@QUICK
@given(text=LIST_TEXT)
def test_pin_is_whole_cells_or_one_params_error(text):
    try:
        pin = parse_pin(text)
    except TerraSynthError as exc:
        assert "--pin" in str(exc) and "\n" not in str(exc)
        return
    assert isinstance(pin.row, int) and isinstance(pin.col, int)


@QUICK
@given(text=LIST_TEXT)
def test_height_range_is_two_finite_ordered_heights_or_one_error(text):
    try:
        low, high = check_height_range(tuple(_numbers(text, "--height-range", (2,))))
    except TerraSynthError as exc:
        assert "\n" not in str(exc)
        return
    assert math.isfinite(low) and math.isfinite(high) and low < high


@QUICK
@given(text=st.one_of(NUMBER_TEXT, st.text(max_size=10)))
def test_cell_size_and_band_are_positive_or_a_usage_error(text):
    for parse in (positive_metres, positive_band):
        try:
            value = parse(text)
        except argparse.ArgumentTypeError as exc:
            assert repr(text) in str(exc)
            continue
        assert 0 < value < math.inf


@QUICK
@given(dem=st.text(max_size=12), where=LIST_TEXT, window=st.one_of(st.just(""), st.tuples(
    *[st.integers(-5, 500)] * 4).map(lambda w: "[{}:{},{}:{}]".format(*w))))
def test_stamp_and_style_texts_parse_or_give_one_params_error(dem, where, window):
    for parse, text in ((parse_stamp, f"{dem}{window}@{where}"), (parse_style, f"#{where}={dem}")):
        try:
            parse(text)
        except TerraSynthError as exc:
            assert "\n" not in str(exc)


@QUICK
@given(option=st.sampled_from(["--size", "--pin", "--height-range", "--cell-size", "--band", "--seed",
                               "--patch-size", "--variations", "--water-level"]),
       value=st.one_of(LIST_TEXT, NUMBER_TEXT, st.text(max_size=8).map(lambda t: "-" + t)))
def test_the_parser_takes_any_option_value_or_exits_2(option, value):
    """The whole argparse path (with signed values joined): a namespace or
    SystemExit(2) with a usage line, never a traceback."""
    import contextlib
    import io

    argv = _join_signed_values(["synth", "--out", "t.tif", option, value])
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            build_parser().parse_args(argv)
    except SystemExit as exc:
        assert exc.code == 2
        assert "error:" in err.getvalue()
