"""CLI: the output's square cell size and map placement (--cell-size),
Cloud-Optimized GeoTIFF (--cog) and band choice (--band), read back with
rasterio."""

from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio
from rasterio.transform import Affine

from terrasynth_core.cli.main import EXIT_BAD_INPUT, EXIT_OK, main
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import load_dem, save_dem

SMALL = ("--size", "96x96", "--patch-size", "32")


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def geo_example(dems_dir, tmp_path_factory):
    """A 200x200 corner of N44W072 as a geographic GeoTIFF (93 x 66 m cells)."""
    field = load_dem(dems_dir / "N44W072.hgt")
    path = tmp_path_factory.mktemp("geo") / "n44.tif"
    save_dem(field.window(300, 500, 300, 500), path)
    return path


@pytest.fixture(scope="module")
def two_band(tmp_path_factory):
    """A projected two-band GeoTIFF at 30 m: band 2 is terrain, band 1 flat."""
    rng = np.random.default_rng(0)
    from scipy import ndimage

    terrain = ndimage.gaussian_filter(rng.normal(size=(160, 160)), 4)
    terrain = (terrain / terrain.std() * 200 + 800).astype(np.float32)
    path = tmp_path_factory.mktemp("bands") / "two.tif"
    with rasterio.open(path, "w", driver="GTiff", width=160, height=160, count=2, dtype="float32",
                       crs="EPSG:32611", transform=Affine(30.0, 0.0, 380000.0, 0.0, -30.0, 3800000.0)) as ds:
        ds.write(np.zeros((160, 160), np.float32), 1)
        ds.write(terrain, 2)
    return path


def _read(path):
    with rasterio.open(path) as ds:
        return ds.crs, ds.res, ds.transform, ds.profile


@pytest.mark.parametrize("cell", [None, 120.0])
def test_synth_writes_square_cells_and_a_local_projection(capsys, geo_example, tmp_path, cell):
    out = tmp_path / "out.tif"
    extra = () if cell is None else ("--cell-size", cell)
    code, _, err = run(capsys, "synth", "--example", geo_example, "--out", out, "--report", tmp_path / "r.json",
                       *SMALL, *extra)
    assert code == EXIT_OK, err
    crs, res, transform, _ = _read(out)
    want = cell or load_dem(geo_example).cell_size[1]  # the finer side, 66 m
    assert res == pytest.approx((want, want))
    assert crs is not None and crs.is_projected and "Transverse" in crs.to_wkt()
    # Centred on the example window: 71.667 W, 44.667 N.
    lon = crs.to_dict()["lon_0"]
    lat = crs.to_dict()["lat_0"]
    assert lon == pytest.approx(-71.667, abs=1e-3) and lat == pytest.approx(44.667, abs=1e-3)
    assert (transform.c, transform.f) == pytest.approx((-48 * want, 48 * want))
    assert json.loads((tmp_path / "r.json").read_text())["cell_size"] == pytest.approx(want)
    assert load_dem(out).cell_size == pytest.approx((want, want))
    assert f"cells of {want:g} m" in err


def test_synth_cog_and_band_of_the_examples(capsys, two_band, tmp_path):
    out = tmp_path / "out.tif"
    code, _, err = run(capsys, "synth", "--example", two_band, "--band", "2", "--out", out, "--cog", *SMALL)
    assert code == EXIT_OK, err
    crs, res, _, profile = _read(out)
    assert res == pytest.approx((30.0, 30.0)) and crs is not None
    with rasterio.open(out) as ds:
        assert ds.overviews(1) or min(ds.shape) < 512  # small COGs need no overview
        heights = ds.read(1)
    assert heights.std() > 10  # band 2's terrain, not band 1's flat zeros
    assert profile["tiled"]


def test_convert_cog_and_band_round_trip(capsys, two_band, tmp_path):
    out = tmp_path / "b2.tif"
    code, _, err = run(capsys, "convert", two_band, out, "--band", "2", "--cog")
    assert code == EXIT_OK, err
    crs, res, _, _ = _read(out)
    assert crs.to_epsg() == 32611 and res == (30.0, 30.0)
    with rasterio.open(two_band) as ds:
        np.testing.assert_array_equal(load_dem(out).heights, ds.read(2))


def test_info_and_features_take_a_band(capsys, two_band, tmp_path):
    code, out, err = run(capsys, "info", two_band, "--band", "2", "--json")
    assert code == EXIT_OK, err
    assert json.loads(out)["epsg"] == 32611 and json.loads(out)["max"] > 900
    code, _, err = run(capsys, "features", two_band, "--band", "2", "--json", tmp_path / "f.json")
    assert code == EXIT_OK, err


def test_info_names_a_crs_without_epsg(capsys, tmp_path, geo_example):
    out = tmp_path / "local.tif"
    assert run(capsys, "synth", "--example", geo_example, "--out", out, *SMALL)[0] == EXIT_OK
    code, text, _ = run(capsys, "info", out)
    assert code == EXIT_OK and "CRS       Local Transverse Mercator" in text


def test_an_ungeoreferenced_example_is_placed_at_0_0(capsys, tmp_path):
    rng = np.random.default_rng(1)
    from scipy import ndimage

    h = ndimage.gaussian_filter(rng.normal(size=(150, 150)), 4) * 3000
    save_dem(HeightField(h.astype(np.float32), cell_size=(25.0, 25.0)), tmp_path / "plain.npy")
    out = tmp_path / "out.tif"
    assert run(capsys, "synth", "--example", tmp_path / "plain.npy", "--out", out, *SMALL)[0] == EXIT_OK
    crs, res, _, _ = _read(out)
    assert res == (25.0, 25.0) and crs.to_dict()["lon_0"] == 0 and crs.to_dict()["lat_0"] == 0


@pytest.mark.parametrize("argv, words", [
    (("synth", "--cell-size", "-3"), ["--cell-size", "'-3'"]),
    (("synth", "--cell-size", "abc"), ["--cell-size", "'abc'"]),
    (("info", "--band", "0"), ["--band", "'0'"]),
])
def test_bad_values_are_one_line_errors(capsys, geo_example, tmp_path, argv, words):
    full = [argv[0], *((geo_example,) if argv[0] == "info" else ("--example", geo_example, "--out",
                                                                   tmp_path / "o.tif")), *argv[1:]]
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in full])
    assert exc.value.code == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert all(w in err for w in words) and "Traceback" not in err


def test_cog_refuses_other_formats_and_a_missing_band_is_named(capsys, geo_example, two_band, tmp_path):
    code, _, err = run(capsys, "convert", geo_example, tmp_path / "o.asc", "--cog")
    assert code == EXIT_BAD_INPUT and "--cog" in err and "o.asc" in err and len(err.strip().splitlines()) == 1
    code, _, err = run(capsys, "info", two_band, "--band", "5")
    assert code == EXIT_BAD_INPUT and "band 5" in err and len(err.strip().splitlines()) == 1
