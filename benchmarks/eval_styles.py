"""Measure the artist controls on the Middle-earth demo: styles, borders,
pins, water and local re-synthesis.

Usage::

    python benchmarks/eval_styles.py [--size ROWSxCOLS] [--patch N] [--seed S] [--json OUT]

The demo (``resources/sketches/middle_earth*``, drawn by
``scripts/make_middle_earth.py``: four painted styles, a sea, a lake and a
river, Mount St. Helens stamped in the volcanic land, three elevation pins)
is synthesized with ``Session([], sketch, controls=Controls(...))`` at
``--size`` (default the map's own 768x1024; maps, stamp and pins are scaled
to it, and the patch (automatic at the map's size) with them unless ``--patch`` is given).  Slopes and
curvatures are on the ground: the gradient magnitude (``np.gradient`` over
the run's cell size, metres per metre) and the 5-point Laplacian (per
metre), for the output and alike for every example DEM brought to the
run's square cell size as the engine sees it (``on_ground``): a DEM's slope
depends on the cell it is measured at, so that is the slope synthesis can
reproduce.

Tables
------
1. **Styles.**  Per painted region, over its *interior*: the region eroded
   by half a patch, without water and the land within a bank width (half a
   patch) of it, without the stamp's box grown by a quarter patch and
   without the pins' discs (the pin radius).  Median and 90th percentile of
   slope and of ``|curvature|``, with the same figures for the region's own
   example; then the 1-D Wasserstein distance
   (``scipy.stats.wasserstein_distance``, 20,000-value subsamples) from the
   region's slope (and ``|curvature|``) distribution to *each* example's.  ``*``
   marks the nearest example; ``own?`` says whether it is the region's own.
   Heights (p5/p50/p95) of the region beside its example's show whether the
   terrain sits where its example does.
2. **Borders.**  Per pair of touching regions, a band of ``BORDER_BAND``
   cells either side of their common border (same exclusions, and half a
   patch away from any third region) against the two regions' interiors:
   the high-frequency statistic of ``eval_synthesis.py`` (p99.9
   ``|Laplacian|`` / std slope) on each, and their ratio (above 1.3 =
   visible seams), then a cliff measure: the 99.9th percentile slope in the
   band against the larger of the two interiors' (above 1 = steeper at the
   border than anywhere inside either region).
3. **Pins.**  Wanted height, result, error (metres and % of the output's
   height range), and the *lift*: wanted height minus the height the same
   run gives without pins (the correction the pin had to make), with the
   area the correction touched (cells within the pin radius changed by more
   than 1 m).
4. **Water.**  Land cells below the water level away from painted water,
   the height step between neighbours across the shoreline, and the bank:
   slope median and HF on land within the bank width of water against the
   lowland interior, and the 99.9th percentile slope on the shoreline
   (land within 2 cells of water).
5. **Local re-synthesis.**  A rectangle across the hills, the range's
   western flank and the river's source (``RESYNTH_BOX``, fractions of the
   map) is synthesized again with seed + 1: cells changed outside it (must
   be 0), share changed inside, and along its edge (``EDGE_BAND`` cells
   either side) HF and p99.9 slope after the re-synthesis against the same
   band before it (the terrain there is steep or flat in its own right),
   with the whole output's HF.
6. **Run time** of each synthesis (session construction and run).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy import ndimage
from scipy.stats import wasserstein_distance

from eval_synthesis import _json_ready, high_frequency
from terrasynth_core.cli.main import parse_size
from terrasynth_core.examples import resolve_dem
from terrasynth_core.exemplars.ground import on_ground
from terrasynth_core.synthesis import Controls, Session

REPO = Path(__file__).resolve().parents[1]
# The demo's reader lives with the script that draws it.
sys.path.insert(0, str(REPO / "scripts"))
from make_middle_earth import LOWLAND, STYLES, demo_params, load_demo  # noqa: E402

#: Values drawn from each distribution for the Wasserstein distances.
SUBSAMPLE = 20_000
#: Cells either side of a region border counted as the border band.
BORDER_BAND = 8
#: Cells either side of the re-synthesis rectangle's edge.
EDGE_BAND = 4
#: Re-synthesized rectangle (row0, row1, col0, col1) as fractions of the map.
RESYNTH_BOX = (0.36, 0.56, 0.40, 0.60)
#: Least band cells for a border pair to be reported.
MIN_BAND_CELLS = 200


# -- measures -------------------------------------------------------------------
def slope_and_curvature(heights: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Gradient magnitude (m/m) and 5-point Laplacian (1/m) on square
    cells of ``cell`` metres."""
    h = np.asarray(heights, dtype=np.float64)
    dr, dc = np.gradient(h, cell)
    return np.hypot(dr, dc), ndimage.laplace(h) / cell**2


def masked_high_frequency(slope: np.ndarray, curvature: np.ndarray, mask: np.ndarray) -> float:
    """:func:`eval_synthesis.high_frequency` restricted to ``mask``: p99.9
    ``|Laplacian|`` over std of the slope, both over the masked cells (the
    derivatives are taken on the whole grid, so no false edges)."""
    if mask.sum() < 50:
        return float("nan")
    return float(np.percentile(np.abs(curvature[mask]), 99.9) / slope[mask].std())


def subsample(values: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    values = np.ravel(values)
    if values.size <= SUBSAMPLE:
        return values
    return values[rng.choice(values.size, SUBSAMPLE, replace=False)]


def _p(values: np.ndarray, q: float) -> float:
    return float(np.percentile(values, q)) if values.size else float("nan")


def example_statistics(keys: list[str], rng: np.random.Generator, cell: float) -> list[dict]:
    """Slope and |curvature| samples, percentiles and HF of each example DEM
    at square cells of ``cell`` metres (its valid crop, less a one-cell rim
    where differences are one-sided)."""
    out = []
    for key in keys:
        field, _ = on_ground(resolve_dem(key), cell, name=key)
        h = np.asarray(field.heights if hasattr(field, "heights") else field, dtype=np.float64)
        slope, curv = (a[1:-1, 1:-1] for a in slope_and_curvature(h, cell))
        out.append({
            "example": key,
            "slope": subsample(slope, rng), "curv": subsample(np.abs(curv), rng),
            "slope_p50": _p(slope, 50), "slope_p90": _p(slope, 90),
            "curv_p50": _p(np.abs(curv), 50), "curv_p90": _p(np.abs(curv), 90),
            "height_p5": _p(h, 5), "height_p50": _p(h, 50), "height_p95": _p(h, 95),
            "hf": high_frequency(h),
        })
    return out


# -- masks ----------------------------------------------------------------------
def excluded_cells(result, controls: Controls, patch: int) -> np.ndarray:
    """Water with its banks, the stamp's box grown by a quarter patch and
    the pins' discs: cells the controls reshape after synthesis."""
    shape = result.heights.shape
    water = controls.water.mask if controls.water is not None else np.zeros(shape, bool)
    out = ndimage.distance_transform_edt(~water) <= patch / 2 if water.any() else np.zeros(shape, bool)
    grow = patch // 4
    for rec in result.patches:
        if rec.kind == "stamp":
            r0, r1, c0, c1 = rec.bbox
            out[max(r0 - grow, 0):r1 + grow, max(c0 - grow, 0):c1 + grow] = True
    if controls.pins:
        seeds = np.zeros(shape, bool)
        for p in controls.pins:
            seeds[p.row, p.col] = True
        radius = patch if controls.pin_radius is None else controls.pin_radius
        out |= ndimage.distance_transform_edt(~seeds) <= radius
    return out


def interiors(labels: np.ndarray, excluded: np.ndarray, patch: int) -> list[np.ndarray]:
    """Each label's cells farther than half a patch from any other label
    (and the map's edge), minus ``excluded``."""
    out = []
    for i in range(int(labels.max()) + 1):
        region = np.pad(labels == i, 1)
        inner = ndimage.distance_transform_edt(region)[1:-1, 1:-1] > patch / 2
        out.append(inner & ~excluded)
    return out


def border_bands(labels: np.ndarray, excluded: np.ndarray, patch: int) -> dict[tuple[int, int], np.ndarray]:
    """For each pair (a, b) of 4-touching labels, the cells within
    ``BORDER_BAND`` of their common border (on either side), minus
    ``excluded`` and minus cells within half a patch of a third label (so
    a pair's band is not the terrain of a region next to it)."""
    bands = {}
    n = int(labels.max()) + 1
    for a in range(n):
        for b in range(a + 1, n):
            ma, mb = labels == a, labels == b
            edge = np.zeros(labels.shape, bool)
            down = (ma[1:, :] & mb[:-1, :]) | (mb[1:, :] & ma[:-1, :])
            right = (ma[:, 1:] & mb[:, :-1]) | (mb[:, 1:] & ma[:, :-1])
            edge[1:, :] |= down
            edge[:, 1:] |= right
            if not edge.any():
                continue
            others = ~(ma | mb)
            far = ndimage.distance_transform_edt(~others) > patch / 2 if others.any() else np.ones(labels.shape, bool)
            band = ndimage.distance_transform_edt(~edge) <= BORDER_BAND
            band &= (ma | mb) & far & ~excluded
            if band.sum() >= MIN_BAND_CELLS:
                bands[(a, b)] = band
    return bands


# -- tables ---------------------------------------------------------------------
def style_table(slope, curv, heights, labels, inner, names, examples, rng) -> list[dict]:
    rows = []
    for i, name in enumerate(names):
        m = inner[i]
        s, c = slope[m], np.abs(curv[m])
        s_sub, c_sub = subsample(s, rng), subsample(c, rng)
        w_slope = [wasserstein_distance(s_sub, ex["slope"]) if s.size else float("nan") for ex in examples]
        w_curv = [wasserstein_distance(c_sub, ex["curv"]) if c.size else float("nan") for ex in examples]
        rows.append({
            "region": name, "example": examples[i]["example"], "cells": int(m.sum()),
            "slope_p50": _p(s, 50), "slope_p90": _p(s, 90), "curv_p50": _p(c, 50), "curv_p90": _p(c, 90),
            "height_p5": _p(heights[m], 5), "height_p50": _p(heights[m], 50), "height_p95": _p(heights[m], 95),
            "w1_slope": w_slope, "w1_curv": w_curv,
            "nearest_slope": int(np.nanargmin(w_slope)) if s.size else -1,
            "nearest_curv": int(np.nanargmin(w_curv)) if c.size else -1,
        })
    return rows


def border_table(slope, curv, bands, inner, names) -> list[dict]:
    rows = []
    for (a, b), band in bands.items():
        both = inner[a] | inner[b]
        hf_band = masked_high_frequency(slope, curv, band)
        hf_in = masked_high_frequency(slope, curv, both)
        p_band = _p(slope[band], 99.9)
        p_a, p_b = _p(slope[inner[a]], 99.9), _p(slope[inner[b]], 99.9)
        rows.append({
            "pair": f"{names[a]} / {names[b]}", "band_cells": int(band.sum()),
            "hf_band": hf_band, "hf_interiors": hf_in, "hf_ratio": hf_band / hf_in,
            "slope999_band": p_band, "slope999_a": p_a, "slope999_b": p_b,
            "cliff_ratio": p_band / np.nanmax([p_a, p_b]),
        })
    return rows


def pin_table(result, unpinned: np.ndarray, radius: float) -> list[dict]:
    """Each pin's error and lift, and the cells within ``radius`` of it that
    moved by more than 1 m."""
    span = float(np.ptp(result.heights))
    changed = np.abs(result.heights.astype(np.float64) - unpinned) > 1.0
    rr, cc = np.indices(changed.shape)
    rows = []
    for e in result.pin_errors:
        near = (rr - e.row) ** 2 + (cc - e.col) ** 2 <= radius ** 2
        rows.append({
            "row": e.row, "col": e.col, "target": e.target, "height": e.height, "error": e.error,
            "error_pct": 100 * abs(e.error) / span, "lift": e.target - float(unpinned[e.row, e.col]),
            "changed_cells": int((changed & near).sum()),
        })
    return rows


def water_table(slope, curv, heights, controls, inner_lowland, patch) -> dict:
    water = controls.water.mask
    d_out = ndimage.distance_transform_edt(~water)
    bank = ~water & (d_out <= patch / 2)
    shore = ~water & (d_out <= 2)
    flooded = ~water & (heights < controls.water.level)
    # Height steps between 4-neighbours on either side of the shoreline.
    steps = np.concatenate([np.abs(heights[1:, :] - heights[:-1, :])[water[1:, :] != water[:-1, :]],
                            np.abs(heights[:, 1:] - heights[:, :-1])[water[:, 1:] != water[:, :-1]]])
    return {
        "level": controls.water.level,
        "flooded_land": int(flooded.sum()),
        "flooded_far": int((flooded & (d_out > patch / 2)).sum()),
        "bank_slope_p50": _p(slope[bank], 50), "lowland_slope_p50": _p(slope[inner_lowland], 50),
        "bank_hf": masked_high_frequency(slope, curv, bank),
        "lowland_hf": masked_high_frequency(slope, curv, inner_lowland),
        "shore_slope999": _p(slope[shore], 99.9), "lowland_slope999": _p(slope[inner_lowland], 99.9),
        "water_height_max": float(heights[water].max()),
        "shore_step_p50": _p(steps, 50), "shore_step_p99": _p(steps, 99),
    }


def resynthesis_check(before, after, selection) -> dict:
    """Cells changed outside and inside ``selection``, and HF and p99.9
    slope on the band along its edge, after and (same band) before."""
    changed = after.heights != before.heights
    edge = selection & ~ndimage.binary_erosion(selection)
    band = ndimage.distance_transform_edt(~edge) <= EDGE_BAND
    out = {
        "box_cells": int(selection.sum()),
        "changed_outside": int((changed & ~selection).sum()),
        "changed_inside_pct": 100 * float(changed[selection].mean()),
    }
    for name, result in (("before", before), ("after", after)):
        slope, curv = slope_and_curvature(result.heights, result.cell_size)
        out[f"hf_edge_{name}"] = masked_high_frequency(slope, curv, band)
        out[f"slope999_edge_{name}"] = _p(slope[band], 99.9)
    out["hf_all"] = masked_high_frequency(slope, curv, np.ones(selection.shape, bool))
    return out


# -- running --------------------------------------------------------------------
def timed_run(sketch, controls, shape, params) -> tuple[object, float, float]:
    t = time.perf_counter()
    session = Session([], sketch, shape=shape, params=params, controls=controls)
    t_session = time.perf_counter() - t
    result = session.run()
    return result, t_session, time.perf_counter() - t


def evaluate(*, shape, patch: int | None, seed: int, log=print) -> dict:
    t0 = time.perf_counter()
    sketch, controls, scale = load_demo(shape=shape)
    shape = sketch.shape
    params = demo_params(seed=seed, scale=scale)
    if patch:
        params = replace(params, patch_size=patch)
    names = [name for name, _, _ in STYLES]
    rng = np.random.default_rng(0)
    result, t_session, t_total = timed_run(sketch, controls, shape, params)
    patch = result.params.patch_size  # (the automatic size as chosen)
    params = result.params
    examples = example_statistics([dem for _, _, dem in STYLES], rng, result.cell_size)
    unpinned, _, t_unpinned = timed_run(sketch, replace(controls, pins=()), shape, params)
    box = np.zeros(shape, bool)
    r0, r1, c0, c1 = (round(f * n) for f, n in zip(RESYNTH_BOX, (shape[0], shape[0], shape[1], shape[1])))
    box[r0:r1, c0:c1] = True
    again, _, t_again = timed_run(sketch, replace(controls, previous=result.heights, selection=box), shape,
                                  replace(params, seed=seed + 1))

    heights = result.heights.astype(np.float64)
    slope, curv = slope_and_curvature(heights, result.cell_size)
    labels = result.style_map
    excluded = excluded_cells(result, controls, patch)
    inner = interiors(labels, excluded, patch)
    report = {
        "shape": list(shape), "patch": patch, "seed": seed, "cell_size": result.cell_size,
        "examples": [{k: v for k, v in ex.items() if k not in ("slope", "curv")} for ex in examples],
        "styles": style_table(slope, curv, heights, labels, inner, names, examples, rng),
        "borders": border_table(slope, curv, border_bands(labels, excluded, patch), inner, names),
        "pins": pin_table(result, unpinned.heights.astype(np.float64),
                          patch if controls.pin_radius is None else controls.pin_radius),
        "water": water_table(slope, curv, heights, controls, inner[LOWLAND], patch),
        "resynthesis": {"box": [r0, r1, c0, c1], **resynthesis_check(result, again, box)},
        "timings": {"session": t_session, "run": t_total, "run_without_pins": t_unpinned,
                    "resynthesis": t_again, "stages": result.timings},
        "warnings": list(result.warnings),
        "resynthesis_warnings": list(again.warnings),
    }
    report["timings"]["script"] = time.perf_counter() - t0
    return report


# -- Markdown -------------------------------------------------------------------
def _f(v, fmt: str = ".1f") -> str:
    return "-" if v is None or (isinstance(v, float) and np.isnan(v)) else format(v, fmt)


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


#: Format of slopes (m/m).
S = ".3f"


def _km(v) -> str:
    """A curvature in 1/m, shown per km."""
    return _f(None if v is None else v * 1000.0, ".2f")


def markdown(report: dict) -> str:
    ex = report["examples"]
    short = [e["example"].removeprefix("builtin:") for e in ex]
    out = [f"Middle-earth demo at {report['shape'][0]}x{report['shape'][1]}, patch {report['patch']}, "
           f"seed {report['seed']}; cells of {report['cell_size']:g} m; slope in m/m, abs curv = |Laplacian| "
           "in 1/km; the examples at the same cell size.", ""]

    out.append("**Styles** (region interiors; example figures in brackets; W1 to each example, * = nearest)")
    out.append("")
    header = ["region", "cells", "slope p50", "slope p90", "abs curv p50", "abs curv p90"]
    header += [f"W1 slope {k}" for k in short] + ["own?"]
    rows = []
    for i, r in enumerate(report["styles"]):
        e = ex[i]
        w = [_f(v, S) + ("*" if j == r["nearest_slope"] else "") for j, v in enumerate(r["w1_slope"])]
        rows.append([r["region"], str(r["cells"]),
                     f"{_f(r['slope_p50'], S)} ({_f(e['slope_p50'], S)})",
                     f"{_f(r['slope_p90'], S)} ({_f(e['slope_p90'], S)})",
                     f"{_km(r['curv_p50'])} ({_km(e['curv_p50'])})", f"{_km(r['curv_p90'])} ({_km(e['curv_p90'])})",
                     *w, "yes" if r["nearest_slope"] == i else "**no**"])
    out += [_table(header, rows), ""]
    header = ["region"] + [f"W1 curv {k}" for k in short] + ["own?", "height p5/p50/p95 (example)"]
    rows = []
    for i, r in enumerate(report["styles"]):
        e = ex[i]
        w = [_km(v) + ("*" if j == r["nearest_curv"] else "") for j, v in enumerate(r["w1_curv"])]
        rows.append([r["region"], *w, "yes" if r["nearest_curv"] == i else "**no**",
                     f"{_f(r['height_p5'], '.0f')}/{_f(r['height_p50'], '.0f')}/{_f(r['height_p95'], '.0f')} "
                     f"({_f(e['height_p5'], '.0f')}/{_f(e['height_p50'], '.0f')}/{_f(e['height_p95'], '.0f')})"])
    out += [_table(header, rows), ""]

    out.append(f"**Borders** (band {BORDER_BAND} cells either side vs the two interiors; HF = p99.9|Lap| / std "
               "slope; cliff = p99.9 slope band / larger interior p99.9)")
    out.append("")
    header = ["border", "band cells", "HF band", "HF interiors", "HF ratio", "p99.9 slope band",
              "p99.9 slope a / b", "cliff ratio"]
    rows = [[r["pair"], str(r["band_cells"]), _f(r["hf_band"], ".2f"), _f(r["hf_interiors"], ".2f"),
             _f(r["hf_ratio"], ".2f"), _f(r["slope999_band"], S),
             f"{_f(r['slope999_a'], S)} / {_f(r['slope999_b'], S)}", _f(r["cliff_ratio"], ".2f")]
            for r in report["borders"]]
    out += [_table(header, rows), ""]

    out.append("**Pins** (lift = wanted height - height without pins; touched = cells within the pin radius "
               "moved > 1 m)")
    out.append("")
    header = ["pin (row, col)", "wanted m", "result m", "error m", "error % of range", "lift m", "touched cells"]
    rows = [[f"({r['row']}, {r['col']})", _f(r["target"], ".0f"), _f(r["height"], ".1f"), _f(r["error"], ".3f"),
             _f(r["error_pct"], ".4f"), _f(r["lift"], ".0f"), str(r["changed_cells"])] for r in report["pins"]]
    out += [_table(header, rows), ""]

    w = report["water"]
    out.append(f"**Water** (level {w['level']:g} m; bank = land within half a patch of water)")
    out.append("")
    header = ["land below level", "of which beyond the bank", "highest water cell m", "shore step p50 / p99 m",
              "slope p50 bank / lowland", "HF bank / lowland", "p99.9 slope shore / lowland"]
    rows = [[str(w["flooded_land"]), str(w["flooded_far"]), _f(w["water_height_max"]),
             f"{_f(w['shore_step_p50'])} / {_f(w['shore_step_p99'])}",
             f"{_f(w['bank_slope_p50'], S)} / {_f(w['lowland_slope_p50'], S)}",
             f"{_f(w['bank_hf'], '.2f')} / {_f(w['lowland_hf'], '.2f')}",
             f"{_f(w['shore_slope999'], S)} / {_f(w['lowland_slope999'], S)}"]]
    out += [_table(header, rows), ""]

    r = report["resynthesis"]
    out.append(f"**Local re-synthesis** (rows {r['box'][0]}-{r['box'][1]}, cols {r['box'][2]}-{r['box'][3]}, "
               f"seed {report['seed'] + 1}; edge band {EDGE_BAND} cells either side)")
    out.append("")
    header = ["box cells", "changed outside", "changed inside %", "HF edge after / before", "HF all after",
              "p99.9 slope edge after / before"]
    rows = [[str(r["box_cells"]), str(r["changed_outside"]), _f(r["changed_inside_pct"]),
             f"{_f(r['hf_edge_after'], '.2f')} / {_f(r['hf_edge_before'], '.2f')}", _f(r["hf_all"], ".2f"),
             f"{_f(r['slope999_edge_after'], S)} / {_f(r['slope999_edge_before'], S)}"]]
    out += [_table(header, rows), ""]

    t = report["timings"]
    out.append("**Run time** (seconds)")
    out.append("")
    header = ["session", "run (with session)", "stages", "run without pins", "re-synthesis", "whole script"]
    stages = ", ".join(f"{k} {v:.1f}" for k, v in t["stages"].items())
    out += [_table(header, [[_f(t["session"]), _f(t["run"]), stages, _f(t["run_without_pins"]),
                             _f(t["resynthesis"]), _f(t["script"])]]), ""]
    if report["warnings"] or report["resynthesis_warnings"]:
        out.append("Warnings: " + "; ".join(report["warnings"] + [f"(re-synthesis) {w}"
                                                                  for w in report["resynthesis_warnings"]]))
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=parse_size, default=None, metavar="ROWSxCOLS",
                        help="output size (default the map's 768x1024; keep the 3:4 aspect)")
    parser.add_argument("--patch", type=int, default=None, metavar="N",
                        help="patch size (default: automatic at the map's own size, 80 scaled at any other, at least 32)")
    parser.add_argument("--seed", type=int, default=0, help="synthesis seed (default 0)")
    parser.add_argument("--json", type=Path, default=None, metavar="OUT", help="also write the figures as JSON")
    args = parser.parse_args(argv)
    report = evaluate(shape=args.size, patch=args.patch, seed=args.seed)
    print(markdown(report), flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps(_json_ready(report), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
