"""``terrasynth-cli``: info, convert, features, synth, bad input and the
installed entry point.

Most tests call :func:`terrasynth_core.cli.main` in-process and read its
output with ``capsys``; one runs the installed console script.
"""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from terrasynth_core.cli.main import EXIT_BAD_INPUT, EXIT_OK, main
from terrasynth_core.pictures import RIDGE_COLOUR, VALLEY_COLOUR
from terrasynth_core.heightfield import HeightField
from terrasynth_core.io import load_dem, save_dem

N44 = "N44W072.hgt"
#: Sketch maps used below (resources/sketches).
Y_JUNCTION = "y_junction_512.png"
RING_CROSS = "ring_cross_512.png"


def run(capsys, *argv) -> tuple[int, str, str]:
    """``main(argv)`` -> (exit code, stdout, stderr)."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def info_json(capsys, path, *extra) -> dict:
    code, out, err = run(capsys, "info", path, "--json", *extra)
    assert code == EXIT_OK, err
    return json.loads(out)


def has_colour(png: Path, colour) -> bool:
    """True when the PNG, decoded to RGB, has a pixel of exactly ``colour``."""
    with Image.open(png) as image:
        rgb = np.asarray(image.convert("RGB"))
    return bool(np.all(rgb == np.asarray(colour, np.uint8), axis=2).any())


@pytest.fixture(scope="module")
def n44(dems_dir) -> HeightField:
    return load_dem(dems_dir / N44)


@pytest.fixture(scope="module")
def crop_256(n44, tmp_path_factory) -> Path:
    """A 256x256 crop of N44W072 as .npy (small enough for a quick PPA)."""
    path = tmp_path_factory.mktemp("crop") / "n44_crop.npy"
    save_dem(HeightField(n44.heights[300:556, 300:556], cell_size=n44.cell_size), path)
    return path


@pytest.fixture(scope="module")
def example_200(n44, tmp_path_factory) -> Path:
    """A 200x200 crop of N44W072 as .npy: the synthesis example."""
    path = tmp_path_factory.mktemp("example") / "n44_example.npy"
    save_dem(HeightField(n44.heights[300:500, 300:500], cell_size=n44.cell_size), path)
    return path


# -- info ---------------------------------------------------------------------
#: name -> (format, shape, min, max, nodata, cell size (dy, dx) in metres)
DEM_FACTS = {
    "N44W072.hgt": ("hgt", [1201, 1201], 115.0, 1908.0, 0, (92.66, 66.09)),
    "N00E010.hgt": ("hgt", [1201, 1201], 1.0, 1005.0, 0, (92.66, 92.66)),
    "bigtujunga.tif": ("geotiff", [643, 1197], 315.0, 2295.0, 0, (30.0, 30.0)),
    "Mandakini.bil": ("envi", [648, 587], 644.0, 6741.0, 172089, (88.81, 88.81)),
    "SainteHelens.dem": ("usgs-dem", [466, 327], 682.0, 2543.0, 3497, (30.0, 30.0)),
}


@pytest.mark.parametrize("name", sorted(DEM_FACTS))
def test_info_json_on_every_dem(capsys, dems_dir, name):
    fmt, shape, lo, hi, nodata, cell = DEM_FACTS[name]
    info = info_json(capsys, dems_dir / name)
    assert {"shape", "min", "max", "nodata", "cell_size", "format"} <= set(info)
    assert info["format"] == fmt
    assert info["shape"] == shape
    assert (info["min"], info["max"]) == (lo, hi)
    assert info["nodata"] == nodata
    assert info["cell_size"] == pytest.approx(cell, rel=1e-3)


def test_info_mandakini_is_about_45_percent_nodata(capsys, dems_dir):
    info = info_json(capsys, dems_dir / "Mandakini.bil")
    assert info["nodata_value"] == -9999.0  # the value; "nodata" counts the cells
    rows, cols = info["shape"]
    assert info["nodata"] / (rows * cols) == pytest.approx(0.45, abs=0.01)


def test_info_json_is_strict_json_with_a_nan_nodata_value(capsys, tmp_path):
    """A float GeoTIFF's NaN nodata value is written as GDAL's JSON writes
    it, the string "nan": Python's json.dumps would write a bare NaN,
    which strict JSON readers refuse."""
    import rasterio
    from rasterio.transform import Affine

    path = tmp_path / "nan_nodata.tif"
    heights = np.arange(600, dtype=np.float32).reshape(20, 30)
    heights[0, 0] = np.nan
    with rasterio.open(path, "w", driver="GTiff", height=20, width=30, count=1, dtype="float32",
                       nodata=float("nan"), transform=Affine(30.0, 0.0, 0.0, 0.0, -30.0, 0.0), crs="EPSG:32611") as dst:
        dst.write(heights, 1)
    assert main(["info", str(path), "--json"]) == 0
    text = capsys.readouterr().out
    info = json.loads(text, parse_constant=lambda name: pytest.fail(f"non-standard JSON constant {name}"))
    assert info["nodata_value"] == "nan" and info["nodata"] == 1


def test_info_builtin_is_trimmed_to_valid_cells(capsys):
    """St. Helens' ragged quadrangle is cropped; the Himalayan basin keeps
    every valid cell, its surroundings nodata."""
    info = info_json(capsys, "builtin:st-helens")
    assert info["nodata"] == 0 and info["shape"] == [460, 317]
    info = info_json(capsys, "builtin:himalaya")
    assert info["format"] == "envi"
    assert info["nodata"] == 172089 and info["shape"] == [648, 587]
    assert info["min"] == 644.0 and info["max"] <= 6741.0


def test_info_text_mentions_format_shape_and_nodata(capsys, dems_dir):
    code, out, err = run(capsys, "info", dems_dir / "Mandakini.bil")
    assert code == EXIT_OK
    assert "envi" in out and "648 x 587" in out and "45.2 %" in out
    assert not err


# -- convert ------------------------------------------------------------------
@pytest.mark.parametrize("ext, levels", [
    ("tif", None), ("asc", None), ("npy", None), ("r32", None),
    ("png", 65535), ("r16", 65535), ("ter", 30000),
])
def test_convert_hgt_round_trip(capsys, dems_dir, tmp_path, ext, levels):
    src = info_json(capsys, dems_dir / N44)
    # A stem per format: .png/.npy/.r16/.r32 share the sidecar name <stem>.json.
    out = tmp_path / f"n44_{ext}.{ext}"
    code, _, err = run(capsys, "convert", dems_dir / N44, out)
    assert code == EXIT_OK, err
    assert out.stat().st_size > 0
    got = info_json(capsys, out)
    assert got["shape"] == src["shape"]
    # Quantised formats keep heights to a fraction of the range; info rounds to 1e-3.
    tol = 1e-3 if levels is None else (src["max"] - src["min"]) / levels + 1e-3
    assert got["min"] == pytest.approx(src["min"], abs=tol)
    assert got["max"] == pytest.approx(src["max"], abs=tol)
    assert got["nodata"] == 0
    assert got["cell_size"] == pytest.approx(src["cell_size"], rel=1e-3)


def test_convert_r32_with_sidecar_keeps_non_square_shape(capsys, n44, tmp_path):
    src = tmp_path / "strip.npy"
    save_dem(HeightField(n44.heights[:120, :200]), src)
    raw = tmp_path / "strip_raw.r32"
    assert run(capsys, "convert", src, raw)[0] == EXIT_OK
    assert (tmp_path / "strip_raw.json").is_file()
    out = tmp_path / "strip_back.tif"
    assert run(capsys, "convert", raw, out)[0] == EXIT_OK
    np.testing.assert_array_equal(load_dem(out).heights, n44.heights[:120, :200])


def test_convert_headerless_r32_needs_size(capsys, tmp_path):
    heights = np.linspace(-50.0, 3000.0, 100 * 150, dtype=np.float32).reshape(100, 150)
    raw = tmp_path / "bare.r32"
    heights.astype("<f4").tofile(raw)
    out = tmp_path / "bare.tif"

    code, _, err = run(capsys, "convert", raw, out)
    assert code == EXIT_BAD_INPUT
    assert "bare.r32" in err and "square" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()

    code, _, err = run(capsys, "convert", raw, out, "--size", "100x150")
    assert code == EXIT_OK, err
    np.testing.assert_array_equal(load_dem(out).heights, heights)
    info = info_json(capsys, out)
    assert info["shape"] == [100, 150] and info["cell_size"] is None



def test_convert_says_what_cell_size_a_format_states_for_heights_without_one(capsys, tmp_path):
    heights = np.linspace(0.0, 900.0, 60 * 80, dtype=np.float32).reshape(60, 80)
    bare = tmp_path / "bare.npy"
    np.save(bare, heights)
    code, _, err = run(capsys, "convert", bare, tmp_path / "bare.asc")
    assert code == EXIT_OK, err
    assert "no cell size" in err and "cells of 1 m" in err
    code, _, err = run(capsys, "convert", bare, tmp_path / "bare.ter")
    assert code == EXIT_OK and "cells of 30 m" in err
    code, _, err = run(capsys, "convert", bare, tmp_path / "bare.tif")
    assert code == EXIT_OK and "no cell size" not in err
    # --cell-size states it ...
    code, _, err = run(capsys, "convert", bare, tmp_path / "stated.ter", "--cell-size", "25")
    assert code == EXIT_OK and "no cell size" not in err
    assert info_json(capsys, tmp_path / "stated.ter")["cell_size"] == pytest.approx([25.0, 25.0], abs=0.01)
    # ... for an input without one only.
    code, _, err = run(capsys, "convert", tmp_path / "stated.ter", tmp_path / "again.asc", "--cell-size", "10")
    assert code == EXIT_BAD_INPUT and "already" in err and not (tmp_path / "again.asc").exists()

def test_convert_to_ply_mesh(capsys, crop_256, tmp_path):
    out = tmp_path / "crop.ply"
    code, _, err = run(capsys, "convert", crop_256, out, "--vertical-scale", "2")
    assert code == EXIT_OK, err
    data = out.read_bytes()
    assert data.startswith(b"ply\n")
    header = data[: data.index(b"end_header")].decode("ascii")
    assert f"element vertex {256 * 256}" in header
    assert f"element face {2 * 255 * 255}" in header


# -- features -----------------------------------------------------------------
def check_graph_json(graph: dict, shape: tuple[int, int]) -> list[int]:
    """Assert the CLI's graph schema and that the graph is a forest; return
    the degree of every node."""
    nodes, paths = graph["nodes"], graph["paths"]
    assert [n["id"] for n in nodes] == list(range(len(nodes)))
    degree = [0] * len(nodes)
    parent = list(range(len(nodes)))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for p in paths:
        a, b = p["from"], p["to"]
        assert 0 <= a < len(nodes) and 0 <= b < len(nodes)
        points = np.asarray(p["points"], dtype=float)
        assert points.ndim == 2 and points.shape[1] == 2 and len(points) >= 2
        assert (points >= 0).all() and (points[:, 0] <= shape[0] - 1).all() and (points[:, 1] <= shape[1] - 1).all()
        assert points[0] == pytest.approx([nodes[a]["row"], nodes[a]["col"]], abs=0.02)
        assert points[-1] == pytest.approx([nodes[b]["row"], nodes[b]["col"]], abs=0.02)
        degree[a] += 1
        degree[b] += 1
        ra, rb = find(a), find(b)
        assert ra != rb, "feature graph has a cycle"
        parent[ra] = rb
    for n, d in zip(nodes, degree):
        assert n["type"] in ("branch", "end")
        assert (d == 1) if n["type"] == "end" else (d >= 3)
    return degree


@pytest.fixture(scope="module")
def crop_features(crop_256, tmp_path_factory):
    """``features`` on the DEM crop: (JSON dict, overlay path)."""
    folder = tmp_path_factory.mktemp("features")
    code = main(["features", str(crop_256), "--json", str(folder / "f.json"), "--overlay", str(folder / "f.png")])
    assert code == EXIT_OK
    return json.loads((folder / "f.json").read_text()), folder / "f.png"


def test_features_of_dem_crop_are_forests(crop_features):
    data, _ = crop_features
    assert set(data) == {"ridges", "valleys"}
    for kind in ("ridges", "valleys"):
        assert data[kind]["paths"], f"no {kind} in a 256x256 mountain crop"
        check_graph_json(data[kind], (256, 256))


def test_features_overlay_is_hillshade_with_red_ridges_blue_valleys(crop_features):
    _, png = crop_features
    with Image.open(png) as image:
        assert image.format == "PNG" and image.size == (256, 256)
        grey = np.asarray(image.convert("RGB")).astype(int)
    assert has_colour(png, RIDGE_COLOUR) and has_colour(png, VALLEY_COLOUR)
    assert (np.ptp(grey, axis=2) == 0).mean() > 0.5, "expected a mostly grey hillshade under the lines"


def test_features_of_y_junction_sketch(capsys, sketch_dir, tmp_path):
    out = tmp_path / "y.json"
    code, _, err = run(capsys, "features", sketch_dir / Y_JUNCTION, "--sketch", "--json", out)
    assert code == EXIT_OK, err
    data = json.loads(out.read_text())
    degree = check_graph_json(data["ridges"], (512, 512))
    types = [n["type"] for n in data["ridges"]["nodes"]]
    assert types.count("branch") == 1 and types.count("end") == 3
    assert degree[types.index("branch")] == 3
    assert data["valleys"] == {"nodes": [], "paths": []}
    assert "ridges: 1 branch points, 3 endpoints, 3 paths" in err


def test_features_kind_ridge_leaves_valleys_empty(capsys, crop_256, tmp_path):
    out = tmp_path / "ridges.json"
    code, _, err = run(capsys, "features", crop_256, "--kind", "ridge", "--json", out)
    assert code == EXIT_OK, err
    data = json.loads(out.read_text())
    assert data["ridges"]["paths"]
    assert data["valleys"] == {"nodes": [], "paths": []}
    assert "valleys:" not in err


def test_features_overlay_of_sketch_with_valleys(capsys, sketch_dir, tmp_path):
    png = tmp_path / "ring.png"
    code, _, err = run(capsys, "features", sketch_dir / RING_CROSS, "--sketch", "--overlay", png)
    assert code == EXIT_OK, err
    with Image.open(png) as image:
        assert image.size == (512, 512)
    assert has_colour(png, RIDGE_COLOUR) and has_colour(png, VALLEY_COLOUR)


# -- synth ----------------------------------------------------------------------
def synth_args(example, sketch, out, *extra):
    return ("synth", "--example", example, "--sketch", sketch, "--out", out,
            "--size", "128x128", "--patch-size", "32", *extra)


@pytest.fixture(scope="module")
def synth_run(example_200, sketch_dir, tmp_path_factory):
    """One small synthesis with report and debug products: the folder."""
    folder = tmp_path_factory.mktemp("synth")
    argv = synth_args(example_200, sketch_dir / Y_JUNCTION, folder / "out.tif",
                      "--report", folder / "report.json", "--debug-dir", folder / "debug")
    assert main([str(a) for a in argv]) == EXIT_OK
    return folder


def test_synth_writes_output_of_requested_shape(synth_run, example_200):
    field = load_dem(synth_run / "out.tif")
    assert field.shape == (128, 128)
    assert field.nodata_count == 0
    example = load_dem(example_200)
    # Patches are copied from the example, so the heights stay near its range.
    relief = example.max - example.min
    assert example.min - relief <= field.min < field.max <= example.max + relief
    # Square cells at the example's finer side (66 m), not its 93 x 66 m.
    assert field.cell_size == pytest.approx((min(example.cell_size),) * 2)


def test_synth_never_writes_over_its_inputs_and_replaces_an_output_only_when_asked(capsys, example_200, sketch_dir,
                                                                                  tmp_path, synth_run):
    """An output that is one of the run's inputs (the sketch, an example DEM,
    a style's DEM) is refused even with --overwrite; an existing output is
    refused without it; both before any work, the files untouched."""
    sketch = tmp_path / "my_sketch.png"
    shutil.copy(sketch_dir / Y_JUNCTION, sketch)
    dem = tmp_path / "my_dem.npy"
    shutil.copy(example_200, dem)
    before = {p: p.read_bytes() for p in (sketch, dem)}
    for out, extra in ((sketch, ()), (dem, ("--overwrite",)), (sketch, ("--overwrite",))):
        code, _, err = run(capsys, *synth_args(dem, sketch, out, *extra))
        assert code == EXIT_BAD_INPUT and f"{out} is an input of this command" in err, err
    code, _, err = run(capsys, "convert", dem, dem, "--overwrite")
    assert code == EXIT_BAD_INPUT and "is an input of this command" in err
    assert all(p.read_bytes() == b for p, b in before.items())

    existing = synth_run / "out.tif"
    kept = existing.read_bytes()
    code, _, err = run(capsys, *synth_args(dem, sketch, existing))
    assert code == EXIT_BAD_INPUT and f"{existing} exists; give --overwrite" in err
    assert err.count("\n") == 1 and existing.read_bytes() == kept
    report = tmp_path / "report.json"
    report.write_text("{}")
    code, _, err = run(capsys, *synth_args(dem, sketch, tmp_path / "new.tif", "--report", report))
    assert code == EXIT_BAD_INPUT and f"{report} exists" in err and not (tmp_path / "new.tif").exists()
    code, _, err = run(capsys, *synth_args(dem, sketch, report.with_suffix(".tif"), "--overwrite"))
    assert code == EXIT_OK, err
    code, _, err = run(capsys, "convert", report.with_suffix(".tif"), existing, "--overwrite")
    assert code == EXIT_OK and existing.read_bytes() != kept


def test_synth_report_counts_and_timings(synth_run):
    report = json.loads((synth_run / "report.json").read_text())
    assert {"params", "patch_counts", "timings", "total_seconds"} <= set(report)
    assert report["params"]["patch_size"] == 32 and report["params"]["seed"] == 0
    assert report["params"]["order"] == "bfs"
    counts = report["patch_counts"]
    assert set(counts) == {"stamp", "branch", "end", "path", "fill"}
    assert counts["branch"] >= 1 and counts["end"] >= 3 and counts["fill"] >= 1
    patches = json.loads((synth_run / "debug" / "patches.json").read_text())["patches"]
    assert sum(counts.values()) == len(patches)
    for kind, n in counts.items():
        assert sum(p["kind"] == kind for p in patches) == n
    assert {"analyse", "features", "fill", "finish"} <= set(report["timings"])
    assert all(v >= 0 for v in report["timings"].values())
    assert report["total_seconds"] > 0
    assert report["total_seconds"] >= max(report["timings"].values())


def test_synth_report_lists_every_patch_and_the_reuse(synth_run, example_200):
    report = json.loads((synth_run / "report.json").read_text())
    rows = report["patches"]
    assert len(rows) == sum(report["patch_counts"].values())
    keys = {"kind", "feature", "example", "source_row", "source_col", "mirrored", "bbox", "deformation", "ssd",
            "seam_cost", "cost"}
    assert all(keys <= set(r) for r in rows)
    features = [r for r in rows if r["kind"] in ("branch", "end", "path")]
    assert all(r["example_name"] == str(example_200) for r in features)
    # Recount from the listed rows: the most feature patches whose sources lie
    # within 20 cells of one of them (same example), over all feature patches.
    src = np.array([(r["source_row"], r["source_col"]) for r in features], dtype=float)
    near = np.hypot(*(src[:, None, :] - src[None, :, :]).transpose(2, 0, 1)) <= 20
    assert report["source_reuse"] == pytest.approx(near.sum(axis=1).max() / len(features), abs=1e-4)  # rounded


def test_synth_debug_dir(synth_run):
    debug = synth_run / "debug"
    for name in ("patch_id.npy", "seam_mask.npy", "patch_id.png", "seams.png", "sketch_features.png",
                 "patches.json"):
        assert (debug / name).is_file(), name
    patch_id = np.load(debug / "patch_id.npy")
    seams = np.load(debug / "seam_mask.npy")
    n_patches = len(json.loads((debug / "patches.json").read_text())["patches"])
    assert patch_id.shape == seams.shape == (128, 128)
    assert seams.dtype == bool and seams.any()
    # Every cell comes from a placed patch, and every patch id is a real patch.
    assert patch_id.min() >= 0 and patch_id.max() < n_patches
    with Image.open(debug / "patch_id.png") as image:
        assert image.size == (128, 128)


def test_synth_same_seed_same_bytes(capsys, example_200, sketch_dir, tmp_path):
    outputs = []
    for name in ("first", "second"):
        out = tmp_path / f"{name}.npy"
        code, _, err = run(capsys, *synth_args(example_200, sketch_dir / Y_JUNCTION, out, "--seed", "7"))
        assert code == EXIT_OK, err
        assert "wrote" in err and "128x128" in err
        outputs.append(out.read_bytes())
    assert outputs[0] == outputs[1]


def test_synth_no_drainage_and_no_landform_reach_the_params(capsys, example_200, sketch_dir, tmp_path):
    """``--no-drainage`` turns the finish-stage drainage shaping off,
    ``--no-landform`` the coarse landform pass."""
    import json

    report = tmp_path / "r.json"
    args = synth_args(example_200, sketch_dir / Y_JUNCTION, tmp_path / "t.npy", "--no-drainage", "--no-landform",
                      "--report", str(report))
    code, _, err = run(capsys, *args)
    assert code == EXIT_OK, err
    params = json.loads(report.read_text())["params"]
    assert params["drainage"] is False and params["landform"] is False


def test_synth_workers_reach_the_params_and_zero_is_refused(capsys, example_200, sketch_dir, tmp_path):
    import json

    report = tmp_path / "r.json"
    code, _, err = run(capsys, *synth_args(example_200, sketch_dir / Y_JUNCTION, tmp_path / "t.npy", "--workers", "1",
                                           "--report", str(report)))
    assert code == EXIT_OK, err
    assert json.loads(report.read_text())["params"]["workers"] == 1
    code, _, err = run(capsys, *synth_args(example_200, sketch_dir / Y_JUNCTION, tmp_path / "u.npy", "--workers", "0"))
    assert code != EXIT_OK and "--workers must be at least 1, got 0" in err


# -- bad input ------------------------------------------------------------------
def _coloured_png_as_dem(tmp, sketches, example):
    return ("info", sketches / Y_JUNCTION), [Y_JUNCTION, "colour"]


def _missing(tmp, sketches, example):
    return ("info", tmp / "missing.hgt"), ["missing.hgt", "no such file"]


def _unknown_extension(tmp, sketches, example):
    (tmp / "points.xyz").write_text("1 2 3\n")
    return ("info", tmp / "points.xyz"), ["points.xyz", ".xyz"]


def _truncated_hgt(tmp, sketches, example):
    (tmp / "N44W072.hgt").write_bytes(bytes(1000))
    return ("info", tmp / "N44W072.hgt"), ["N44W072.hgt", "1000 bytes"]


def _corrupt_tif(tmp, sketches, example):
    (tmp / "broken.tif").write_bytes(b"II*\x00" + bytes(range(256)) * 4)
    return ("info", tmp / "broken.tif"), ["broken.tif"]


def _truncated_tif(tmp, sketches, example):
    source = Path(__file__).parents[2] / "resources" / "dems" / "bigtujunga.tif"
    (tmp / "cut.tif").write_bytes(source.read_bytes()[:3000])
    return ("convert", tmp / "cut.tif", tmp / "cut.npy"), ["cut.tif", "damaged or cut short", "IReadBlock failed"]


def _sketch_not_an_image(tmp, sketches, example):
    (tmp / "notes.png").write_text("not an image")
    return ("features", tmp / "notes.png", "--sketch"), ["notes.png", "image"]


def _synth_sketch_not_an_image(tmp, sketches, example):
    (tmp / "notes.png").write_text("not an image")
    return synth_args(example, tmp / "notes.png", tmp / "out.tif"), ["notes.png", "image"]


def _example_smaller_than_patch(tmp, sketches, example):
    save_dem(HeightField(np.linspace(0, 100, 400, dtype=np.float32).reshape(20, 20)), tmp / "tiny.npy")
    return synth_args(tmp / "tiny.npy", sketches / Y_JUNCTION, tmp / "out.tif"), ["tiny.npy", "patch"]


def _unknown_output_extension(tmp, sketches, example):
    return synth_args(example, sketches / Y_JUNCTION, tmp / "out.xyz"), ["out.xyz", ".xyz"]


def _missing_output_folder(tmp, sketches, example):
    return synth_args(example, sketches / Y_JUNCTION, tmp / "nowhere" / "out.tif"), ["nowhere", "does not exist"]


def _all_nodata(tmp, sketches, example):
    np.save(tmp / "void.npy", np.full((64, 64), np.nan, np.float32))
    return ("info", tmp / "void.npy"), ["void.npy", "no valid cell"]


def _synth_all_nodata_example(tmp, sketches, example):
    np.save(tmp / "void.npy", np.full((64, 64), np.nan, np.float32))
    return synth_args(tmp / "void.npy", sketches / Y_JUNCTION, tmp / "out.tif"), ["void.npy"]


def _unknown_builtin(tmp, sketches, example):
    return ("info", "builtin:nope"), ["'nope'", "white-mountains", "himalaya"]


def _patch_size_out_of_range(tmp, sketches, example):
    return synth_args(example, sketches / Y_JUNCTION, tmp / "out.tif", "--patch-size", "8"), ["patch_size=8",
                                                                                            "(--patch-size)"]


def _band_of_a_builtin(tmp, sketches, example):
    return ("info", "builtin:white-mountains", "--band", "2"), ["builtin:white-mountains", "band 2 does not exist"]


def _a_cell_size_too_fine(tmp, sketches, example):
    return (synth_args("builtin:white-mountains", sketches / Y_JUNCTION, tmp / "out.tif", "--cell-size", "1"),
            ["N44W072.hgt", "over the 64 million", "(--cell-size)"])


def _a_debug_dir_that_is_a_file(tmp, sketches, example):
    (tmp / "notes.txt").write_text("mine")
    return (synth_args(example, sketches / Y_JUNCTION, tmp / "out.tif", "--debug-dir", tmp / "notes.txt"),
            ["--debug-dir", "notes.txt is a file"])


def _export_into_a_missing_folder(tmp, sketches, example):
    return ("export", example, "--preset", "unity", "--out", tmp / "nowhere" / "unity"), ["nowhere", "does not exist"]


def _report_named_as_the_output(tmp, sketches, example):
    return (synth_args(example, sketches / Y_JUNCTION, tmp / "out.tif", "--report", tmp / "out.tif"),
            ["same file", "out.tif"])


def _output_that_is_a_folder(tmp, sketches, example):
    (tmp / "terrain.tif").mkdir()
    return synth_args(example, sketches / Y_JUNCTION, tmp / "terrain.tif", "--overwrite"), ["terrain.tif", "folder"]


def _convert_into_a_missing_folder(tmp, sketches, example):
    return ("convert", example, tmp / "nowhere" / "a.exr"), ["nowhere", "does not exist"]


def _export_name_with_folders(tmp, sketches, example):
    return ("export", example, "--preset", "godot", "--out", tmp / "godot", "--name", "../../evil"), ["'../../evil'",
                                                                                                    "without folders"]


def _masks_name_with_folders(tmp, sketches, example):
    return ("masks", example, "--out", tmp / "masks", "--name", "/tmp/abs"), ["'/tmp/abs'", "without folders"]


def _masks_sea_level_nan(tmp, sketches, example):
    return ("masks", example, "--out", tmp / "masks", "--sea-level", "nan"), ["sea level", "nan"]


def _export_too_many_tiles(tmp, sketches, example):
    return ("export", example, "--preset", "unity", "--out", tmp / "unity", "--tiles", "1000"), ["1 to 32", "1000"]


def _features_overlay_not_a_png(tmp, sketches, example):
    return ("features", example, "--overlay", tmp / "over.tif"), ["--overlay", ".png", "over.tif"]


def _features_json_into_a_missing_folder(tmp, sketches, example):
    return ("features", example, "--json", tmp / "nowhere" / "f.json"), ["nowhere", "does not exist"]


def _features_json_and_overlay_one_file(tmp, sketches, example):
    return ("features", example, "--json", tmp / "f.png", "--overlay", tmp / "f.png"), ["same file", "f.png"]


def _bank_wider_than_the_map(tmp, sketches, example):
    Image.fromarray(np.full((64, 64), 255, np.uint8)).save(tmp / "water.png")
    return (synth_args(example, sketches / Y_JUNCTION, tmp / "out.tif", "--size", "64x64", "--water", tmp / "water.png",
                       "--water-level", "0", "--bank-width", "1e9"), ["bank width", "64x64", "at most 64"])


def _style_relief_beyond_any_height(tmp, sketches, example):
    Image.fromarray(np.full((64, 64, 3), (230, 217, 140), np.uint8)).save(tmp / "styles.png")
    return (synth_args(example, sketches / Y_JUNCTION, tmp / "out.tif", "--size", "64x64", "--styles",
                       tmp / "styles.png", "--style", f"#e6d98c={example},relief=1e30"),
            ["relief scale 1e+30", "+-100000 m"])


@pytest.mark.parametrize("case", [
    _missing, _unknown_extension, _truncated_hgt, _corrupt_tif, _truncated_tif, _sketch_not_an_image,
    _synth_sketch_not_an_image, _coloured_png_as_dem, _example_smaller_than_patch, _unknown_output_extension,
    _missing_output_folder, _all_nodata, _synth_all_nodata_example, _unknown_builtin, _patch_size_out_of_range,
    _band_of_a_builtin, _a_cell_size_too_fine, _a_debug_dir_that_is_a_file, _export_into_a_missing_folder,
    _report_named_as_the_output, _output_that_is_a_folder, _convert_into_a_missing_folder,
    _export_name_with_folders, _masks_name_with_folders, _masks_sea_level_nan, _export_too_many_tiles,
    _features_overlay_not_a_png, _features_json_into_a_missing_folder, _features_json_and_overlay_one_file,
    _bank_wider_than_the_map, _style_relief_beyond_any_height,
], ids=lambda f: f.__name__.strip("_"))
def test_bad_input_exits_2_with_one_line(capsys, tmp_path, sketch_dir, example_200, case):
    argv, words = case(tmp_path, sketch_dir, example_200)
    code, out, err = run(capsys, *argv)
    assert code == EXIT_BAD_INPUT
    assert not out
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("terrasynth-cli: error: ")
    assert "Traceback" not in err
    for word in words:
        assert word in lines[0]
    assert not (tmp_path / "out.tif").exists()


def test_features_never_writes_over_its_input_and_replaces_an_output_only_when_asked(capsys, tmp_path, sketch_dir):
    sketch = tmp_path / "sketch.png"
    shutil.copy(sketch_dir / Y_JUNCTION, sketch)
    before = sketch.read_bytes()
    for option in ("--json", "--overlay"):
        code, _, err = run(capsys, "features", sketch, "--sketch", option, sketch, "--overwrite")
        assert code == EXIT_BAD_INPUT and "is an input of this command" in err
    assert sketch.read_bytes() == before
    mine = tmp_path / "mine.json"
    mine.write_text("my notes")
    code, _, err = run(capsys, "features", sketch, "--sketch", "--json", mine)
    assert code == EXIT_BAD_INPUT and "exists; give --overwrite" in err and mine.read_text() == "my notes"
    code, _, err = run(capsys, "features", sketch, "--sketch", "--json", mine, "--overwrite")
    assert code == EXIT_OK, err
    assert json.loads(mine.read_text())["ridges"]


def test_unwritable_output_folder_is_refused_before_the_run(capsys, monkeypatch, tmp_path, sketch_dir,
                                                            example_200):
    """A folder that takes no new file is said before the synthesis (found
    when the result was written, it cost the whole run), naming the output
    and the folder, not the writer's temporary file.  Root writes through
    permission bits, so the file creation fails here as a read-only mount
    fails it."""
    import errno
    import tempfile

    def read_only(*args, **kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    def no_run(*args, **kwargs):
        raise AssertionError("the synthesis started")

    monkeypatch.setattr(tempfile, "mkstemp", read_only)
    monkeypatch.setattr("terrasynth_core.synthesis.Session.iter_run", no_run)
    code, out, err = run(capsys, *synth_args(example_200, sketch_dir / Y_JUNCTION, tmp_path / "out.tif"))
    assert code == EXIT_BAD_INPUT and not out
    assert err.strip().splitlines() == [f"terrasynth-cli: error: cannot write {tmp_path / 'out.tif'}: folder "
                                        f"{tmp_path} takes no new file (Read-only file system)"]


@pytest.mark.parametrize("size", ["12by3", "1x100", "axb", "3x4x5"])
def test_malformed_size_is_an_argparse_error(capsys, example_200, size):
    with pytest.raises(SystemExit) as exc:
        main(["info", str(example_200), "--size", size])
    assert exc.value.code == EXIT_BAD_INPUT
    err = capsys.readouterr().err
    assert "--size" in err and repr(size) in err and "Traceback" not in err


# -- installed entry point --------------------------------------------------------
def test_console_script_is_installed_and_works(tmp_path):
    script = shutil.which("terrasynth-cli", path=str(Path(sys.executable).parent))
    assert script is not None, f"terrasynth-cli not installed beside {sys.executable}"

    done = subprocess.run([script, "info", "--json", "builtin:himalaya"], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == EXIT_OK, done.stderr
    info = json.loads(done.stdout)
    assert info["format"] == "envi" and info["nodata"] == 172089

    done = subprocess.run([script, "info", str(tmp_path / "missing.hgt")], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == EXIT_BAD_INPUT
    assert done.stdout == ""
    assert done.stderr.strip().splitlines() == [f"terrasynth-cli: error: {tmp_path / 'missing.hgt'}: no such file"]


# -- demo -----------------------------------------------------------------------
def test_demo_synthesizes_builtin_example_with_builtin_sketch(capsys, tmp_path):
    # (The report is not demo.json: that is demo.npy's sidecar, refused since issue 13.)
    out, report = tmp_path / "demo.npy", tmp_path / "demo_report.json"
    code, _, err = run(capsys, "demo", "--out", out, "--report", report)
    assert code == EXIT_OK, err
    field = load_dem(out)
    assert field.metadata["sidecar"] and field.cell_size is not None
    # The default sketch is 512x512 and the demo keeps its size.
    assert field.shape == (512, 512) and field.nodata_count == 0
    summary = json.loads(report.read_text())
    assert len(summary["examples"]) == 1 and summary["examples"][0].endswith("N44W072.hgt")
    assert summary["params"]["patch_size"] == 80
    assert summary["patch_counts"]["branch"] >= 1


def test_a_reader_that_leaves_early_ends_the_command_quietly(monkeypatch, capsys):
    """``terrasynth-cli examples | head -1``: the pipe's reader closes it, and
    the command stops with exit 0 and no error line (it said ': Broken pipe')."""
    import os

    read_end, write_end = os.pipe()
    os.close(read_end)
    with os.fdopen(write_end, "w") as closed_pipe:
        monkeypatch.setattr(sys, "stdout", closed_pipe)
        code = main(["examples"])
        monkeypatch.undo()
    assert code == EXIT_OK
    assert capsys.readouterr().err == ""


def test_a_bad_option_is_one_line_without_the_usage_block(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["synth", "--example", "builtin:white-mountains", "--out", "x.tif", "--size", "-512"])
    err = capsys.readouterr().err
    assert exit_.value.code == EXIT_BAD_INPUT
    assert err.count("\n") == 1 and "usage:" not in err and "size '-512'" in err and "--help" in err


def test_builtin_files_sidecars_and_the_demo_s_sketch_are_inputs_or_outputs_too(capsys, example_200, sketch_dir,
                                                                                tmp_path):
    """A built-in's own file and the demo's sketch are refused as outputs
    even with --overwrite; a user's JSON where a heightmap's sidecar would
    go is refused before the run, not after it."""
    from terrasynth_core.examples import DEFAULT_SKETCH, builtin_example, resource_path

    builtin_file = Path(builtin_example("st-helens").load().source)
    kept = builtin_file.read_bytes()
    code, _, err = run(capsys, "convert", "builtin:st-helens", builtin_file, "--overwrite")
    assert code == EXIT_BAD_INPUT and "is an input of this command" in err and builtin_file.read_bytes() == kept
    demo_sketch = Path(resource_path("sketches", DEFAULT_SKETCH))
    kept = demo_sketch.read_bytes()
    code, _, err = run(capsys, "demo", "--out", demo_sketch, "--overwrite")
    assert code == EXIT_BAD_INPUT and "is an input of this command" in err and demo_sketch.read_bytes() == kept

    (tmp_path / "user.json").write_text('{"mine": true}')
    code, _, err = run(capsys, *synth_args(example_200, sketch_dir / Y_JUNCTION, tmp_path / "user.png", "--overwrite"))
    assert code == EXIT_BAD_INPUT and "user.json would replace an existing file that is not a TerraSynth" in err
    assert "patches" not in err and not (tmp_path / "user.png").exists()  # (refused before the run)


def test_a_run_whose_progress_pipe_closes_does_not_report_success(monkeypatch, capsys, example_200, sketch_dir,
                                                                  tmp_path):
    """``synth ... 2>&1 | head -1``: the run stops at its first note with
    nowhere to go, and exits 141 (as a shell shows SIGPIPE), not 0."""
    import os

    from terrasynth_core.cli.main import EXIT_BROKEN_PIPE

    import contextlib

    read_end, write_end = os.pipe()
    os.close(read_end)
    closed_pipe = os.fdopen(write_end, "w", buffering=1)
    monkeypatch.setattr(sys, "stderr", closed_pipe)
    try:
        code = main([str(a) for a in synth_args(example_200, sketch_dir / Y_JUNCTION, tmp_path / "t.tif")])
    finally:
        monkeypatch.undo()
        with contextlib.suppress(BrokenPipeError):
            closed_pipe.close()
    assert code == EXIT_BROKEN_PIPE
