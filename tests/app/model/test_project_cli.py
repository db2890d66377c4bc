"""``terrasynth-cli synth --project``: a project saved by the app renders
headless exactly as the app's Synthesize runs it (issue 13), and project
files keep what finding 9 found missing."""

import json
import zipfile

import numpy as np
import pytest

from terrasynth_core.cli.main import EXIT_BAD_INPUT, EXIT_OK, main
from terrasynth_core.io import load_dem
from terrasynth_core.project import read_project
from terrasynth_core.synthesis import SynthesisParams
from terrasynth_app.model import Document, ExampleRef, ProjectError, Sketch, StampSpec, load_project, save_project


def _styled_document() -> Document:
    """A 128x128 sketch with a ridge, a style region, water, a pin and a stamp."""
    sketch = Sketch.blank((128, 128))
    sketch.draw_polyline([(20, 64), (100, 64)], "ridge", radius=2, hardness=1.0)
    doc = Document(sketch, [ExampleRef(builtin="white-mountains", crop=(400, 700, 400, 700))],
                   params=SynthesisParams(patch_size=32, k=3, seed=5))
    style = doc.add_style(ExampleRef(builtin="gabon-plateau", crop=(0, 300, 0, 300)), relief_scale=0.5)
    sketch.draw_polyline([(0, 110), (127, 110)], "style", radius=12, style=style.id)
    sketch.draw_polyline([(120, 0), (120, 40)], "water", radius=4)
    doc.set_water_level(doc.water_level)
    doc.add_pin(40, 30, 700.0)
    doc.add_stamp(StampSpec(ExampleRef(builtin="st-helens"), (90.0, 30.0), (460, 317), scale=0.1))
    return doc


def test_the_cli_renders_a_project_as_the_app_runs_it(tmp_path, capsys):
    doc = _styled_document()
    path = save_project(doc, tmp_path / "design.tsproj")
    app_result = doc.synthesis_request().make_session().run()
    assert main(["synth", "--project", str(path), "--out", str(tmp_path / "t.npy")]) == EXIT_OK
    cli = load_dem(tmp_path / "t.npy")
    np.testing.assert_array_equal(cli.heights, app_result.heights)
    assert "pin (40, 30)" in capsys.readouterr().err


def test_a_project_at_another_size_and_seed_moves_its_pins(tmp_path, capsys):
    doc = _styled_document()
    path = save_project(doc, tmp_path / "design.tsproj")
    assert main(["synth", "--project", str(path), "--size", "192x192", "--seed", "8",
                 "--out", str(tmp_path / "big.tif"), "--report", str(tmp_path / "r.json")]) == EXIT_OK
    report = json.loads((tmp_path / "r.json").read_text())
    assert report["params"]["seed"] == 8 and report["params"]["patch_size"] == 32
    assert [(p["row"], p["col"]) for p in report["pins"]] == [(60, 45)]  # (40.5, 30.5) * 1.5 - 0.5
    assert load_dem(tmp_path / "big.tif").shape == (192, 192)


@pytest.mark.parametrize("option", [["--example", "builtin:himalaya"], ["--pin", "1,1,1"], ["--patch-size", "40"],
                                    ["--no-drainage"], ["--no-landform"]])
def test_run_options_contradicting_a_project_are_refused(tmp_path, capsys, option):
    path = save_project(_styled_document(), tmp_path / "design.tsproj")
    assert main(["synth", "--project", str(path), "--out", str(tmp_path / "t.tif"), *option]) == EXIT_BAD_INPUT
    [line] = capsys.readouterr().err.strip().splitlines()
    assert option[0] in line and "--project" in line and not (tmp_path / "t.tif").exists()


def test_a_project_keeps_the_result_georeference_and_the_selection(tmp_path):
    doc = _styled_document()
    session = doc.synthesis_request().make_session()
    from terrasynth_app.model import TerrainResult

    doc.set_result(TerrainResult.from_synthesis(session.run()))
    doc.select_rect(10, 30, 5, 25)
    path = save_project(doc, tmp_path / "p.tsproj")
    data = read_project(path)
    assert data.result.georef == session.georef and data.result.georef.crs_wkt == session.georef.crs_wkt
    again = load_project(path)
    assert again.result.georef == session.georef
    np.testing.assert_array_equal(again.selection, doc.selection)
    assert not again.dirty


def test_a_version_2_project_still_opens(tmp_path):
    path = save_project(_styled_document(), tmp_path / "old.tsproj")
    with zipfile.ZipFile(path) as zf:
        members = {name: zf.read(name) for name in zf.namelist()}
    meta = json.loads(members["project.json"])
    meta["version"] = 2
    members["project.json"] = json.dumps(meta).encode()
    with zipfile.ZipFile(path, "w") as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    doc = load_project(path)
    assert doc.selection is None and len(doc.pins) == 1 and len(doc.styles) == 1


def test_a_selection_of_another_size_is_a_damaged_project(tmp_path):
    import io

    path = save_project(_styled_document(), tmp_path / "p.tsproj")
    buf = io.BytesIO()
    np.save(buf, np.ones((10, 10), bool))
    with zipfile.ZipFile(path, "a") as zf:
        zf.writestr("selection.npy", buf.getvalue())
    with pytest.raises(ProjectError, match="p.tsproj is damaged: selection.npy is 10 x 10 cells"):
        load_project(path)


def test_a_project_s_own_dem_is_never_the_output(tmp_path, capsys):
    """The DEMs a project refers to are inputs too, though no option names
    them: refused as the output even with --overwrite, whole or tiled."""
    from terrasynth_core.heightfield import HeightField
    from terrasynth_core.io import save_dem

    dem = tmp_path / "mine.tif"  # (a tiled run writes GeoTIFF only)
    save_dem(HeightField(np.asarray(load_dem_crop(), np.float32), cell_size=(30.0, 30.0)), dem)
    sketch = Sketch.blank((128, 128))
    sketch.draw_polyline([(20, 64), (100, 64)], "ridge", radius=2, hardness=1.0)
    doc = Document(sketch, [ExampleRef(path=str(dem))], params=SynthesisParams(patch_size=32, seed=1))
    path = save_project(doc, tmp_path / "mine.tsproj")
    before = dem.read_bytes()
    for extra in ([], ["--tile", "64"]):
        code = main(["synth", "--project", str(path), "--out", str(dem), "--overwrite", *extra])
        err = capsys.readouterr().err
        assert code == EXIT_BAD_INPUT and "is an input of this command" in err, err
    assert dem.read_bytes() == before


def load_dem_crop():
    from terrasynth_core.examples import builtin_example

    return builtin_example("white-mountains").load().heights[400:700, 400:700]
