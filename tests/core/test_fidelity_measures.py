"""The fidelity measures of benchmarks/fidelity_measures.py on terrain with a known answer, and
the evaluation's count of source reuse where the issue asks it."""

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import fidelity_measures as fm  # noqa: E402

from terrasynth_core.measures import topographic_position_index  # noqa: E402


def _cone(n=101):
    r, c = np.mgrid[0:n, 0:n]
    return 100.0 - np.hypot(r - n // 2, c - n // 2)


def test_cone_tpi_sign_and_percentile():
    cone = _cone()
    tpi = topographic_position_index(cone, radius=10)
    assert tpi[50, 50] > 0
    assert topographic_position_index(-cone, radius=10)[50, 50] < 0
    top = np.zeros(cone.shape, bool)
    top[50, 50] = True
    assert fm.height_percentile(cone, top) > 0.999
    assert fm.height_percentile(-cone, top) < 0.001
    assert np.isnan(fm.height_percentile(cone, np.zeros_like(top)))


def test_height_percentile_of_a_plane_row():
    plane = np.repeat(np.arange(100.0)[:, None], 10, axis=1)
    row = np.zeros(plane.shape, bool)
    row[25] = True
    assert fm.height_percentile(plane, row) == pytest.approx(0.255)


def test_wrong_half_counts_a_ridge_stretch_in_lowland():
    # A ridge drawn across a plane rising to the east: the part of the
    # stroke on the western, lower half of the map is in the wrong half.
    plane = np.repeat(np.arange(100.0)[None, :], 100, axis=0)
    stroke = np.zeros(plane.shape, bool)
    stroke[50, 20:100] = True
    assert fm.wrong_half(plane, stroke, high=True) == pytest.approx(30 / 80)
    assert fm.wrong_half(plane, stroke, high=False) == pytest.approx(50 / 80)
    assert np.isnan(fm.wrong_half(plane, np.zeros_like(stroke), high=True))


def test_tilted_plane_drains_along_its_fall_line():
    pytest.importorskip("richdem")
    r, c = np.mgrid[0:200, 0:200]
    valley = 0.5 * r + 2.0 * np.abs(c - 100)  # falls to row 0, a V trough down column 100
    acc = fm.d8_accumulation(valley)
    assert acc[0, 100] >= 0.5 * valley.size  # nearly all water leaves at the trough's outlet
    streams = fm.d8_streams(valley, area_share=1 / 20)
    assert streams[:150, 100].all()  # the fall line drains the plane
    assert not streams[:, np.abs(np.arange(200) - 100) > 2].any()
    ridge = 0.5 * r - 2.0 * np.abs(c - 100)  # a crest down column 100: water leaves it
    assert not fm.d8_streams(ridge, area_share=1 / 2000)[:, 100].any()
    # a pit in the trough is filled, not a sink
    valley[100, 100] -= 50
    assert fm.d8_streams(valley, area_share=1 / 20)[:100, 100].all()


def _record(source, example=0, feature="ridge", kind="path"):
    return SimpleNamespace(kind=kind, feature=feature, example=example, source=source)


def test_sinusoid_power_in_its_octave():
    r, c = np.mgrid[0:512, 0:512]
    wave = 10.0 * np.sin(2 * np.pi * c / 24.0)  # 24 cells per cycle: the 16-32 octave
    powers = fm.band_powers(wave)
    assert np.argmax(powers) == 1
    assert powers[1] > 100 * max(powers[0], powers[2], powers[3])
    wavelength, power = fm.welch_spectrum(wave)
    assert wavelength[np.argmax(power)] == pytest.approx(256 / 11, rel=0.1)
    assert fm.band_power_ratios(2 * wave, wave)[1] == pytest.approx(4.0)
    with pytest.raises(ValueError):
        fm.welch_spectrum(wave[:100])


def test_relief_and_range():
    h = np.arange(1000.0).reshape(10, 100)
    assert fm.relief(h, tail=0.0) == 999.0
    assert fm.relief(h) == pytest.approx(np.percentile(h, 99.5) - np.percentile(h, 0.5))
    assert fm.share_out_of_range(h, h[:5]) == 0.5
    assert fm.share_out_of_range(h, h) == 0.0


def test_reuse_counted_where_the_issue_asks_it():
    from eval_fidelity import reuse_where_it_applies

    rows = [{"example": "big", "reuse": 0.08, "pool_windows": 40},
            {"example": "big", "reuse": 0.20, "pool_windows": 25},
            {"example": "volcano", "reuse": 0.30, "pool_windows": 8},
            {"example": "old", "reuse": 0.05}]  # (a run saved before pools were counted)
    line = reuse_where_it_applies(rows)
    assert "1/2 runs met" in line and "1 runs have smaller pools (volcano)" in line


def test_closed_depressions_count_a_basin_below_its_rim_and_nothing_on_a_slope():
    """A bowl 100 m deep inside a rim: its cells deeper than 1 % of the
    relief count; a tilted plane (drains off its low edge) holds none."""
    pytest.importorskip("richdem")
    rr, cc = np.mgrid[0:80, 0:80].astype(float)
    r = np.hypot(rr - 40, cc - 40)
    bowl = np.where(r < 30, r / 30 * 100.0, 100.0 - 2 * (r - 30))  # floor 0 m, rim 100 m, falling outside
    share = fm.closed_depressions(bowl)
    inside = np.mean(100.0 - bowl[r < 30] > 0.01 * fm.relief(bowl)) * np.mean(r < 30)
    assert share == pytest.approx(inside, abs=0.02) and share > 0.3  # (the rim is 100 m only to a cell)
    assert fm.closed_depressions(rr * 2.0 + cc) == 0.0
