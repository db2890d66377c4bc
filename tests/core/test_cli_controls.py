"""``terrasynth-cli synth`` with style regions, water, stamps, pins, a height
range and variations; and the errors bad control options give."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from terrasynth_core.cli.main import EXIT_BAD_INPUT, EXIT_OK, main
from terrasynth_core.cli.controls import parse_stamp, parse_style
from terrasynth_core.errors import ParamsError
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import load_dem, save_dem

SHAPE = (128, 192)


@pytest.fixture(scope="module")
def maps(dems_dir, tmp_path_factory):
    """Two example crops, a two-colour style map and a water mask."""
    folder = tmp_path_factory.mktemp("controls")
    n44 = load_dem(dems_dir / "N44W072.hgt")
    gabon = load_dem(dems_dir / "N00E010.hgt")
    save_dem(HeightField(n44.heights[300:560, 300:560], cell_size=n44.cell_size), folder / "hills.npy")
    save_dem(HeightField(gabon.heights[400:660, 400:660], cell_size=gabon.cell_size), folder / "plain.npy")
    styles = np.zeros(SHAPE + (3,), np.uint8)
    styles[:, :96] = (0, 128, 0)
    styles[:, 96:] = (128, 64, 0)
    Image.fromarray(styles).save(folder / "styles.png")
    water = np.full(SHAPE, 255, np.uint8)
    water[:, :16] = 0
    Image.fromarray(water).save(folder / "water.png")
    return folder


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_styles_water_stamp_and_pins_from_the_command_line(capsys, maps, dems_dir):
    out = maps / "out.tif"
    code, _, err = run(
        capsys, "synth", "--styles", maps / "styles.png",
        "--style", f"#008000={maps / 'plain.npy'}", "--style", f"#804000={maps / 'hills.npy'},relief=0.8",
        "--water", maps / "water.png", "--water-level", "150",
        "--stamp", f"{dems_dir / 'SainteHelens.dem'}[100:300,60:260]@64,140,30,0.3",
        "--pin", "60,60,700", "--pin", "100,170,1500",
        "--patch-size", "32", "--out", out, "--report", maps / "report.json",
    )
    assert code == EXIT_OK, err
    field = load_dem(out)
    assert field.shape == SHAPE
    assert (field.heights[:, :16] < 150).all()
    report = json.loads((maps / "report.json").read_text())
    span = report["height_range"][1] - report["height_range"][0]
    assert len(report["pins"]) == 2
    for pin in report["pins"]:
        assert abs(pin["error"]) < 0.01 * span
    assert report["patch_counts"]["stamp"] == 1
    assert "pin (60, 60): wanted 700.0 m" in err


def test_variations_write_one_file_per_seed(capsys, maps):
    out = maps / "var.npy"
    code, _, err = run(capsys, "synth", "--example", maps / "hills.npy", "--size", "96x96", "--patch-size", "32",
                       "--seed", "7", "--variations", "2", "--out", out)
    assert code == EXIT_OK, err
    a, b = np.load(maps / "var_v1.npy"), np.load(maps / "var_v2.npy")
    assert a.shape == b.shape == (96, 96) and not np.array_equal(a, b)
    assert "seeds 7-8" in err


@pytest.mark.parametrize("args, message", [
    (["--style", "#008000=x.npy"], "--style needs --styles"),
    (["--styles", "STYLES", "--style", "green=x.npy"], "not #RRGGBB"),
    (["--water", "WATER"], "--water-level"),
    (["--pin", "1,2"], "3 comma-separated numbers"),
    (["--pin", "999,2,5"], "outside"),
    (["--stamp", "PLAIN@1"], "position"),
    (["--stamp", "PLAIN@60,60,0,-1"], "scale -1 must be a positive number"),
    (["--height-range", "5,1"], "LO < HI"),
    (["--styles", "STYLES", "--style", "#008000=PLAIN,relief=-1", "--style", "#804000=PLAIN"], "relief"),
    # A mistyped colour paints nothing; no --style at all: the map's colours are named.
    (["--styles", "STYLES", "--style", "#123456=PLAIN"], "no pixel of style colour #123456; its colours are #008000"),
    (["--styles", "STYLES"], 'give a --style "#RRGGBB=DEM" for each colour; it holds #008000 (50 %), #804000 (50 %)'),
])
def test_bad_control_options_are_one_line_errors(capsys, maps, args, message):
    subst = {"STYLES": maps / "styles.png", "WATER": maps / "water.png"}
    argv = [str(subst.get(a, a)).replace("PLAIN", str(maps / "plain.npy")) for a in args]
    code, out, err = run(capsys, "synth", "--example", maps / "plain.npy", "--size", "128x192",
                         "--patch-size", "32", "--out", maps / "bad.tif", *argv)
    assert code == EXIT_BAD_INPUT
    assert message in err and "Traceback" not in err
    assert not (maps / "bad.tif").exists()


def test_unlisted_style_colour_without_a_default_example(capsys, maps):
    code, _, err = run(capsys, "synth", "--styles", maps / "styles.png", "--style", f"#008000={maps / 'plain.npy'}",
                       "--patch-size", "32", "--out", maps / "bad.tif")
    assert code == EXIT_BAD_INPUT
    assert "#804000" in err and "default --example" in err


def test_option_parsers():
    assert parse_style("#AABBCC=builtin:himalaya,relief=0.5,base=100") == ("#AABBCC", "builtin:himalaya", 0.5, 100.0)
    assert parse_stamp("a/b.dem[1:20,3:40]@10,20,45,2") == ("a/b.dem", (1, 20, 3, 40), (10.0, 20.0), 45.0, 2.0)
    assert parse_stamp("x@5,6") == ("x", None, (5.0, 6.0), 0.0, 1.0)
    with pytest.raises(ParamsError, match="relief=NUMBER"):
        parse_style("#AABBCC=x,depth=3")


def test_middle_earth_demo_meets_its_pins_and_water(capsys, tmp_path):
    """The built-in multi-style map end to end: four styles, water, a stamp, pins."""
    from terrasynth_core.presets import load_preset

    preset = load_preset("middle-earth")
    assert len(preset.controls.styles) >= 3 and preset.controls.water is not None
    assert preset.controls.stamps and preset.controls.pins
    code, _, err = run(capsys, "demo", "--map", "middle-earth", "--out", tmp_path / "me.tif",
                       "--report", tmp_path / "me.json")
    assert code == EXIT_OK, err
    h = load_dem(tmp_path / "me.tif").heights
    assert h.shape == preset.shape
    report = json.loads((tmp_path / "me.json").read_text())
    span = float(h.max() - h.min())
    assert all(abs(p["error"]) < 0.01 * span for p in report["pins"])
    water = preset.controls.water
    assert (h[water.mask] < water.level).all()
    # Each painted region sits at its own style's level: the high range is
    # the highest region, the lowland the lowest (medians, metres).
    labels = preset.controls.style_map
    medians = {s.name: float(np.median(h[(labels == i) & ~water.mask])) for i, s in enumerate(preset.controls.styles)}
    assert max(medians, key=medians.get) == "high mountains"


def test_unknown_preset_is_an_error():
    from terrasynth_core.presets import load_preset

    with pytest.raises(ParamsError, match="middle-earth"):
        load_preset("narnia")
