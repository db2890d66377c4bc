"""Measure how well synthesized terrain follows its sketch and hides its seams.

Usage::

    python benchmarks/eval_synthesis.py [--part follow|seams|all] [--max-side N] [--seeds N] [--seed S]
                                        [--json OUT]

The measures look only at the output heights, the sketch and the example,
never at how the engine works, so any synthesis method can be scored alike.

Following the sketch (``--part follow``)
-----------------------------------------
Each shared sketch is synthesized from three built-in examples
(white-mountains, big-tujunga, st-helens) at the sketch's own size (or
scaled so its longer side is at most ``--max-side``), once with the paper's
breadth-first placement order and once in raster order, with the same seed
(seeds 0 to ``--seeds`` - 1).  A third row, ``none``, is the chance level: a
synthesis of the same size, example and seed *without* the sketch, scored
against the same strokes.

* ``TPI r/v``: topographic position index along the sketch's ridge and
  valley centre lines (the sketch's own feature graphs), in standard
  deviations of the output's TPI, radius 15 cells
  (:func:`~terrasynth_core.measures.feature_tpi_score`).  Ridges should be
  clearly positive, valleys clearly negative; chance is about 0.
* ``recall r/v``: PPA (default :class:`PPAParams`) on the output; the share
  of sketch centre-line cells with an output feature of the same kind
  within 8 cells.
* precision: the share of output feature cells within 8 cells of a sketch
  stroke of the same kind, over *long* output features only.  PPA on any
  real terrain also finds the many small natural ridges and valleys between
  the sketched ones, and the engine fills the space between strokes with
  real terrain, which has them too; precision over all features
  (``prec.all``, given for reference) mostly counts those and says little
  about the sketch.  A feature longer than a patch side (80 cells) cannot
  come from one unguided fill patch, so the long features show whether the
  large-scale structure is the sketch's.  "Long" is measured two ways:
  ``prec.path`` keeps PPA paths of at least 80 cells, but PPA splits a ridge
  line at every side spur, so such paths are few (often none: ``-``) and
  the figure is noisy; ``prec.trunk`` keeps the trunk of each output
  network (the longest route through the tree, its main ridge or valley
  line) when it is at least 80 cells long, which is what a person would
  call a long ridge.

The summary gives each measure's mean per order and the paired difference
BFS minus raster (valley TPI negated, so positive always favours BFS) with
its standard error over the (sketch, example, seed, kind) pairs.

A run that fails with :class:`ParamsError` (example too small or too poor in
features for the automatic patch size) is repeated with 48-cell patches;
its patch column then reads ``48*``.

Seams (``--part seams``)
------------------------
``s_valley_1000.png`` scaled to 512x512, on white-mountains and big-tujunga,
with four merge settings: ``paste`` (the new patch covers the overlap),
``cut`` (graph-cut seam, no blending), ``cut+poisson`` (the paper: Poisson
solve with zero gradient across the seam) and ``cut+c1`` (the default:
slope carried across the seam).

* ``HF``: the 99.9th percentile of ``|Laplacian|`` divided by the standard
  deviation of the slope (gradient magnitude), both in height units per
  cell, for the output and for the whole example.  Steps and creases at
  seams add rare large second differences, so ``HF out/ex`` above 1 shows
  them; it should stay within 0.7 to 1.3.
* ``seam/rest``: mean ``|Laplacian|`` on seam cells divided by its mean on
  all other cells; 1 means seams look like the rest of the terrain.  Seam
  cells are given twice: ``mask`` is the engine's own ``seam_mask`` (every
  graph-cut seam ever made, including ones later patches covered; empty for
  ``paste``) and ``bound`` is the boundary between different patches in the
  final ``patch_id`` map (the seams that survive), which applies to every
  setting alike.
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

from terrasynth_core.measures import feature_tpi_score
from terrasynth_core.errors import ParamsError
from terrasynth_core.examples import builtin_example
from terrasynth_core.features import FeatureGraph, extract_features, read_sketch
from terrasynth_core.features.network import graph_mask
from terrasynth_core.synthesis import Session, SynthesisParams

REPO = Path(__file__).resolve().parents[1]
SKETCH_DIR = REPO / "resources" / "sketches"
SKETCHES = ("y_junction_512.png", "ring_cross_512.png", "s_valley_1000.png")
FOLLOW_EXAMPLES = ("white-mountains", "big-tujunga", "st-helens")
SEAM_EXAMPLES = ("white-mountains", "big-tujunga")
SEAM_SKETCH = "s_valley_1000.png"
SEAM_SHAPE = (512, 512)
SEAM_SETTINGS = {
    "paste": {"seam": "paste", "blend": "none"},
    "cut": {"seam": "cut", "blend": "none"},
    "cut+poisson": {"seam": "cut", "blend": "poisson"},
    "cut+c1": {"seam": "cut", "blend": "c1"},
}
#: TPI radius in cells, independent of PPA's 7-cell profiles and the patch.
TPI_RADIUS = 15
#: Distance in cells within which an output feature matches a sketch stroke.
TOLERANCE = 8
#: Patch size to fall back to when an example is too small for the default.
SMALL_PATCH = 48
#: The seam statistic's acceptable band, output relative to example.
HF_BAND = (0.7, 1.3)


# -- runs ---------------------------------------------------------------------
def synthesize(example, sketch, shape, params: SynthesisParams):
    """Run a session; on :class:`ParamsError` retry with ``SMALL_PATCH``.

    Returns
    -------
    result : SynthesisResult
    seconds : float
        Wall time of the successful attempt (session and run).
    fallback : bool
        True when the smaller patch was needed.
    """
    try:
        t = time.perf_counter()
        result = Session([example], sketch, shape=shape, params=params).run()
        return result, time.perf_counter() - t, False
    except ParamsError:
        if params.patch_size == SMALL_PATCH:
            raise
    small = replace(params, patch_size=SMALL_PATCH)
    t = time.perf_counter()
    result = Session([example], sketch, shape=shape, params=small).run()
    return result, time.perf_counter() - t, True


def scaled_shape(shape: tuple[int, int], max_side: int | None) -> tuple[int, int]:
    """``shape`` shrunk (keeping its aspect) so its longer side is at most ``max_side``."""
    if max_side is None or max(shape) <= max_side:
        return tuple(shape)
    f = max_side / max(shape)
    return max(1, round(shape[0] * f)), max(1, round(shape[1] * f))


# -- following the sketch -----------------------------------------------------
def _long_paths(graph: FeatureGraph, min_length: float) -> FeatureGraph:
    """The graph with only its paths of at least ``min_length`` cells."""
    return FeatureGraph(graph.kind, graph.shape, graph.nodes,
                        tuple(p for p in graph.paths if p.length >= min_length))


def _farthest(adjacency: list, start: int) -> tuple[int, dict]:
    """The node farthest (along the paths) from ``start`` in its tree, and
    for every reached node the path index that led to it and its parent."""
    distance = {start: 0.0}
    via = {start: (None, None)}
    stack = [start]
    while stack:
        node = stack.pop()
        for path, other, length in adjacency[node]:
            if other not in distance:
                distance[other] = distance[node] + length
                via[other] = (path, node)
                stack.append(other)
    return max(distance, key=distance.get), via


def trunks(graph: FeatureGraph, min_length: float) -> FeatureGraph:
    """The trunk of every network: the longest route through each tree (its
    diameter, a main ridge or valley line), kept when at least ``min_length``
    cells long.  Returns the graph with only the trunks' paths."""
    adjacency = [[] for _ in graph.nodes]
    for i, p in enumerate(graph.paths):
        adjacency[p.start].append((i, p.end, p.length))
        adjacency[p.end].append((i, p.start, p.length))
    keep: set[int] = set()
    seen: set[int] = set()
    for root in range(len(graph.nodes)):
        if root in seen or not adjacency[root]:
            continue
        far, reached = _farthest(adjacency, root)
        seen.update(reached)
        end, via = _farthest(adjacency, far)
        route = []
        while via[end][0] is not None:
            route.append(via[end][0])
            end = via[end][1]
        if sum(graph.paths[i].length for i in route) >= min_length:
            keep.update(route)
    return FeatureGraph(graph.kind, graph.shape, graph.nodes, tuple(graph.paths[i] for i in sorted(keep)))


def _share_within(cells: np.ndarray, targets: np.ndarray, tol: float) -> float:
    """Share of the True cells of ``cells`` within ``tol`` of a True cell of
    ``targets``; NaN when ``cells`` is empty, 0 when ``targets`` is."""
    if not cells.any():
        return float("nan")
    if not targets.any():
        return 0.0
    distance = ndimage.distance_transform_edt(~targets)
    return float(np.mean(distance[cells] <= tol))


def stroke_following(heights: np.ndarray, sketch_maps, *, long_length: float) -> dict:
    """TPI on the strokes and PPA recall/precision of one output.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
    sketch_maps : FeatureMaps
        The sketch's feature graphs at the output's size.
    long_length : float
        Least length in cells of an output path counted by ``precision_long``.

    Returns
    -------
    dict
        Per kind (``ridge``, ``valley``): ``tpi``, ``recall``,
        ``precision_long``, ``precision_all``; NaN where the sketch has no
        stroke of that kind.
    """
    found = extract_features(heights)
    out = {}
    for kind, wanted, got in (("ridge", sketch_maps.ridges, found.ridges),
                              ("valley", sketch_maps.valleys, found.valleys)):
        if not wanted.paths:
            out[kind] = dict.fromkeys(("tpi", "recall", "precision_long", "precision_trunk", "precision_all"),
                                      float("nan"))
            continue
        sketch_cells = graph_mask(wanted)
        out_cells = graph_mask(got)
        out[kind] = {
            "tpi": feature_tpi_score(heights, wanted, radius=TPI_RADIUS),
            "recall": _share_within(sketch_cells, out_cells, TOLERANCE),
            "precision_long": _share_within(graph_mask(_long_paths(got, long_length)), sketch_cells, TOLERANCE),
            "precision_trunk": _share_within(graph_mask(trunks(got, long_length)), sketch_cells, TOLERANCE),
            "precision_all": _share_within(out_cells, sketch_cells, TOLERANCE),
        }
    return out


def evaluate_following(*, max_side: int | None, seeds: list[int], log=print) -> list[dict]:
    """Score BFS order, raster order and no sketch for every sketch, example and seed."""
    rows = []
    log(_follow_header())
    for sketch_file in SKETCHES:
        sketch = read_sketch(SKETCH_DIR / sketch_file)
        shape = scaled_shape(sketch.shape, max_side)
        for key in FOLLOW_EXAMPLES:
            example = builtin_example(key).load()
            for seed in seeds:
                sketch_maps = None
                for order in ORDERS:
                    params = SynthesisParams(seed=seed, order="bfs" if order == "none" else order)
                    result, seconds, fallback = synthesize(example, None if order == "none" else sketch, shape,
                                                           params)
                    if sketch_maps is None:
                        sketch_maps = result.sketch_features
                    row = {
                        "sketch": sketch_file, "example": key, "seed": seed, "order": order, "shape": list(shape),
                        "patch_size": result.params.patch_size, "fallback": fallback, "seconds": seconds,
                        "warnings": list(result.warnings),
                        **stroke_following(result.heights, sketch_maps, long_length=result.params.patch_size),
                    }
                    rows.append(row)
                    log(_follow_line(row))
    return rows


#: Placement orders compared; "none" is the run without a sketch (chance).
ORDERS = ("bfs", "raster", "none")
#: Measures of the follow table: key, column title, number format.
FOLLOW_MEASURES = (
    ("tpi", "TPI r/v", "+.2f"),
    ("recall", "recall r/v", ".2f"),
    ("precision_trunk", "prec.trunk r/v", ".2f"),
    ("precision_long", "prec.path r/v", ".2f"),
    ("precision_all", "prec.all r/v", ".2f"),
)


def _pair(a: float, b: float, fmt: str) -> str:
    def one(v):
        return "-" if np.isnan(v) else format(v, fmt)

    return f"{one(a)}/{one(b)}"


def _follow_header() -> str:
    h = (f"{'sketch':<18} {'example':<15} {'seed':>4} {'order':<6} {'size':>9} {'patch':>5} {'sec':>5} "
         + " ".join(f"{title:>14}" for _, title, _ in FOLLOW_MEASURES))
    return h + "\n" + "-" * len(h)


def _follow_line(row: dict) -> str:
    r, v = row["ridge"], row["valley"]
    patch = f"{row['patch_size']}{'*' if row['fallback'] else ''}"
    return (
        f"{row['sketch']:<18} {row['example']:<15} {row['seed']:>4} {row['order']:<6} "
        f"{'x'.join(map(str, row['shape'])):>9} {patch:>5} {row['seconds']:>5.1f} "
        + " ".join(f"{_pair(r[key], v[key], fmt):>14}" for key, _, fmt in FOLLOW_MEASURES)
    )


def _values(rows: list[dict], key: str, kinds=("ridge", "valley")) -> list[float]:
    return [r[k][key] for r in rows for k in kinds if not np.isnan(r[k][key])]


def follow_summary(rows: list[dict]) -> str:
    """Means per order over all runs, then the paired BFS - raster differences.

    In the differences the valley TPI is negated, so a positive difference
    always means BFS followed the sketch better.
    """
    lines = [f"{'order':<6} {'TPI ridge':>9} {'TPI valley':>10} {'recall':>7} {'prec.trunk':>10} "
             f"{'prec.path':>9} {'prec.all':>8}"]
    for order in ORDERS:
        sel = [r for r in rows if r["order"] == order]
        if not sel:
            continue

        def mean(key, kinds=("ridge", "valley"), sel=sel):
            vals = _values(sel, key, kinds)
            return float(np.mean(vals)) if vals else float("nan")

        lines.append(
            f"{order:<6} {mean('tpi', ('ridge',)):>+9.2f} {mean('tpi', ('valley',)):>+10.2f} {mean('recall'):>7.2f} "
            f"{mean('precision_trunk'):>10.2f} {mean('precision_long'):>9.2f} {mean('precision_all'):>8.2f}"
        )
    lines.append("")
    lines.append("Paired BFS - raster (same sketch, example, seed, kind): mean +- standard error (pairs)")
    by_run = {(r["sketch"], r["example"], r["seed"], r["order"]): r for r in rows}
    for key, title, _ in FOLLOW_MEASURES:
        diffs = []
        for (sketch, example, seed, order), bfs in by_run.items():
            raster = by_run.get((sketch, example, seed, "raster"))
            if order != "bfs" or raster is None:
                continue
            for kind, sign in (("ridge", 1.0), ("valley", -1.0 if key == "tpi" else 1.0)):
                d = sign * (bfs[kind][key] - raster[kind][key])
                if not np.isnan(d):
                    diffs.append(d)
        if diffs:
            se = np.std(diffs, ddof=1) / np.sqrt(len(diffs)) if len(diffs) > 1 else float("nan")
            lines.append(f"  {title.replace(' r/v', ''):<11} {np.mean(diffs):>+7.3f} +- {se:.3f} ({len(diffs)})")
    return "\n".join(lines)


# -- seams --------------------------------------------------------------------
def high_frequency(heights: np.ndarray) -> float:
    """99.9th percentile of ``|Laplacian|`` over the standard deviation of
    the gradient magnitude, both per cell (a unitless roughness of the
    finest scale relative to the slopes)."""
    h = np.asarray(heights, dtype=np.float64)
    lap = np.abs(ndimage.laplace(h))
    dr, dc = np.gradient(h)
    return float(np.percentile(lap, 99.9) / np.hypot(dr, dc).std())


def patch_boundaries(patch_id: np.ndarray) -> np.ndarray:
    """Cells whose 4-neighbour came from another patch (both sides)."""
    edge = np.zeros(patch_id.shape, dtype=bool)
    down = patch_id[1:, :] != patch_id[:-1, :]
    right = patch_id[:, 1:] != patch_id[:, :-1]
    edge[1:, :] |= down
    edge[:-1, :] |= down
    edge[:, 1:] |= right
    edge[:, :-1] |= right
    return edge


def seam_ratio(heights: np.ndarray, seams: np.ndarray) -> float:
    """Mean ``|Laplacian|`` on ``seams`` over its mean elsewhere (NaN without seams)."""
    if not seams.any() or seams.all():
        return float("nan")
    lap = np.abs(ndimage.laplace(np.asarray(heights, dtype=np.float64)))
    return float(lap[seams].mean() / lap[~seams].mean())


def evaluate_seams(*, seed: int, log=print) -> list[dict]:
    """The four merge settings on each seam example."""
    rows = []
    sketch = read_sketch(SKETCH_DIR / SEAM_SKETCH)
    log(_seam_header())
    for key in SEAM_EXAMPLES:
        example = builtin_example(key).load()
        hf_example = high_frequency(example.heights)
        for name, options in SEAM_SETTINGS.items():
            params = SynthesisParams(seed=seed, **options)
            result, seconds, fallback = synthesize(example, sketch, SEAM_SHAPE, params)
            hf_out = high_frequency(result.heights)
            row = {
                "example": key, "setting": name, "seconds": seconds, "fallback": fallback,
                "hf_output": hf_out, "hf_example": hf_example, "hf_ratio": hf_out / hf_example,
                "seam_mask_ratio": seam_ratio(result.heights, result.seam_mask),
                "boundary_ratio": seam_ratio(result.heights, patch_boundaries(result.patch_id)),
                "seam_mask_share": float(result.seam_mask.mean()),
                "boundary_share": float(patch_boundaries(result.patch_id).mean()),
            }
            rows.append(row)
            log(_seam_line(row))
    return rows


def _seam_header() -> str:
    h = (f"{'example':<15} {'setting':<12} {'sec':>5} {'HF out':>7} {'HF ex':>6} {'out/ex':>7} {'in band':>7} "
         f"{'seam/rest mask':>14} {'seam/rest bound':>15} {'mask %':>6} {'bound %':>7}")
    return h + "\n" + "-" * len(h)


def _seam_line(row: dict) -> str:
    lo, hi = HF_BAND
    mask = "-" if np.isnan(row["seam_mask_ratio"]) else f"{row['seam_mask_ratio']:.2f}"
    return (
        f"{row['example']:<15} {row['setting']:<12} {row['seconds']:>5.1f} {row['hf_output']:>7.2f} "
        f"{row['hf_example']:>6.2f} {row['hf_ratio']:>7.2f} {str(lo <= row['hf_ratio'] <= hi):>7} "
        f"{mask:>14} {row['boundary_ratio']:>15.2f} {100 * row['seam_mask_share']:>6.1f} "
        f"{100 * row['boundary_share']:>7.1f}"
    )


# -- main ---------------------------------------------------------------------
def _json_ready(obj):
    if isinstance(obj, float) and np.isnan(obj):
        return None
    if isinstance(obj, dict):
        return {k: _json_ready(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_json_ready(v) for v in obj]
    return obj


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=["follow", "seams", "all"], default="all", help="which tables")
    parser.add_argument("--max-side", type=int, default=None, metavar="N",
                        help="scale sketches down so their longer side is at most N cells (default: native)")
    parser.add_argument("--seeds", type=int, default=1, metavar="N",
                        help="follow table: repeat every run with seeds 0..N-1 (default 1)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the seam runs (default 0)")
    parser.add_argument("--json", type=Path, default=None, metavar="OUT", help="also write the figures as JSON")
    args = parser.parse_args(argv)

    def log(line: str) -> None:
        print(line, flush=True)

    report = {}
    if args.part in ("follow", "all"):
        log(f"Following the sketch: TPI radius {TPI_RADIUS} cells (in std. dev.), PPA match tolerance "
            f"{TOLERANCE} cells, trunk/path counted when >= patch size; r/v = ridges/valleys, '-' = no such strokes; "
            f"seeds 0..{args.seeds - 1}")
        rows = evaluate_following(max_side=args.max_side, seeds=list(range(args.seeds)), log=log)
        log("\nMeans over all runs (recall and precisions pool ridges and valleys)")
        log(follow_summary(rows))
        notes = sorted({f"{r['example']}: {w}" for r in rows if r["order"] != "none" for w in r["warnings"]})
        if any(r["fallback"] for r in rows):
            notes.insert(0, "48* = the automatic patch raised ParamsError; "
                            f"run with {SMALL_PATCH}-cell patches")
        if notes:
            log("\nNotes and run warnings:\n" + "\n".join(f"  {n}" for n in notes))
        report["follow"] = rows
    if args.part in ("seams", "all"):
        if report:
            log("")
        log(f"Seams: {SEAM_SKETCH} at {SEAM_SHAPE[0]}x{SEAM_SHAPE[1]}, seed {args.seed}; HF = p99.9|Laplacian| / "
            f"std(slope), per cell; band {HF_BAND[0]}..{HF_BAND[1]}; seam/rest = mean |Laplacian| on seam "
            "cells / elsewhere")
        report["seams"] = evaluate_seams(seed=args.seed, log=log)
    if args.json is not None:
        args.json.write_text(json.dumps(_json_ready(report), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
