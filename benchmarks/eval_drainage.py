"""Do painted valleys drain and painted ridges divide?  Before and after the
drainage step (:mod:`terrasynth_core.controls.drainage`).

Usage::

    python benchmarks/eval_drainage.py [--size 512] [--seed 0] [--pictures DIR]

Each case (``y_junction_512.png``, ``s_valley_1000.png`` and ``ring_cross_512.png`` on
``gabon-plateau`` and ``white-mountains``) is synthesized once with
``drainage=False`` (*before*); the drainage step is then applied to those
heights as the finish stage would (*after*: the same bytes as a run with
``drainage=True``, since these runs have no water or pins), and timed.

Measures (issue 10, point 4), on the depression-filled output:

* ``drain``: share of valley stroke cells (the sketch's valley graph,
  rasterized) within 5 cells of a D8 stream (accumulation >= area/2000);
* ``cross``: share of ridge stroke cells within 2 cells of a stream;
* ``lap near/rest``: 99.9th percentile of |Laplacian| within a valley
  half-width (a third of a patch) of the strokes over the rest of the map:
  a groove or step left by the correction would raise it;
* ``max dz``: largest change, metres; ``changed``: share of cells changed.

The filling is a priority flood with an epsilon gradient (Barnes, Lehman
and Mulla 2014), so every filled cell has a strictly lower D8 neighbour and
flats drain towards their spill point; the D8 receiver is the steepest
descent (drop over distance).  Written here rather than taken from a
hydrology library: pysheds 0.5 calls ``np.in1d``, which this numpy (2.4)
no longer has, and the measure needs only these two steps.
"""

from __future__ import annotations

import argparse
import heapq
import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

from terrasynth_core.controls.drainage import VALLEY_HALF_WIDTH, apply_drainage
from terrasynth_core.examples import builtin_example, resource_path
from terrasynth_core.features import read_sketch
from terrasynth_core.pictures import save_png, shaded_relief
from terrasynth_core.synthesis import Session, SynthesisParams

SKETCHES = ("y_junction_512.png", "s_valley_1000.png", "ring_cross_512.png")
EXAMPLES = ("gabon-plateau", "white-mountains")
_STEPS = [(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)]


def fill_depressions(heights: np.ndarray) -> np.ndarray:
    """Priority-flood fill from the border with an epsilon gradient: every
    interior cell ends strictly above the neighbour it was reached from."""
    h = np.asarray(heights, np.float64)
    rows, cols = h.shape
    filled = h.copy()
    done = np.zeros(h.shape, bool)
    heap = []
    for r in range(rows):
        for c in (0, cols - 1):
            if not done[r, c]:
                done[r, c] = True
                heap.append((h[r, c], r, c))
    for c in range(1, cols - 1):
        for r in (0, rows - 1):
            if not done[r, c]:
                done[r, c] = True
                heap.append((h[r, c], r, c))
    heapq.heapify(heap)
    tiny = 1e-6 * max(float(np.ptp(h)), 1.0)
    flat_filled = filled.ravel()
    flat_done = done.ravel()
    flat_h = h.ravel()
    while heap:
        z, r, c = heapq.heappop(heap)
        for dr, dc in _STEPS:
            rr, cc = r + dr, c + dc
            if 0 <= rr < rows and 0 <= cc < cols:
                i = rr * cols + cc
                if not flat_done[i]:
                    flat_done[i] = True
                    v = max(flat_h[i], z + tiny)
                    flat_filled[i] = v
                    heapq.heappush(heap, (v, rr, cc))
    return filled


def d8_accumulation(filled: np.ndarray) -> np.ndarray:
    """Cells draining through each cell (itself included), D8 steepest descent."""
    rows, cols = filled.shape
    padded = np.pad(filled, 1, constant_values=np.inf)
    best = np.zeros(filled.shape)
    receiver = np.arange(rows * cols).reshape(rows, cols)
    rr, cc = np.mgrid[0:rows, 0:cols]
    for dr, dc in _STEPS:
        nb = padded[1 + dr:1 + dr + rows, 1 + dc:1 + dc + cols]
        slope = (filled - nb) / np.hypot(dr, dc)
        better = slope > best
        best = np.where(better, slope, best)
        receiver = np.where(better, (rr + dr) * cols + (cc + dc), receiver)
    order = np.argsort(-filled, axis=None, kind="stable")
    rec = receiver.ravel().tolist()
    acc = [1.0] * (rows * cols)
    for i in order.tolist():
        j = rec[i]
        if j != i:
            acc[j] += acc[i]
    return np.asarray(acc).reshape(rows, cols)


def streams(heights: np.ndarray) -> np.ndarray:
    """D8 streams (accumulation >= area/2000) of the depression-filled heights."""
    acc = d8_accumulation(fill_depressions(heights))
    return acc >= heights.size / 2000


def stroke_measures(heights: np.ndarray, sketch_maps) -> dict:
    """``drain`` and ``cross`` (module docstring) of one height field."""
    far = ndimage.distance_transform_edt(~streams(heights))
    out = {}
    for name, graph, tol in (("drain", sketch_maps.valleys, 5.0), ("cross", sketch_maps.ridges, 2.0)):
        cells = graph.rasterize() if graph.paths else np.zeros(heights.shape, bool)
        out[name] = float(np.mean(far[cells] <= tol)) if cells.any() else float("nan")
    return out


def laplacian_ratio(heights: np.ndarray, sketch_maps, width: float) -> float:
    """p99.9 |Laplacian| near the strokes over p99.9 elsewhere."""
    lap = np.abs(ndimage.laplace(heights.astype(np.float64)))[1:-1, 1:-1]
    strokes = sketch_maps.valleys.rasterize() | sketch_maps.ridges.rasterize()
    near = (ndimage.distance_transform_edt(~strokes) < width)[1:-1, 1:-1]
    return float(np.percentile(lap[near], 99.9) / np.percentile(lap[~near], 99.9))


def evaluate(size: int, seed: int, pictures: Path | None, log=print) -> list[dict]:
    rows = []
    for sketch_name in SKETCHES:
        sketch = read_sketch(resource_path("sketches") / sketch_name).resized((size, size))
        for key in EXAMPLES:
            example = builtin_example(key).load()
            params = SynthesisParams(seed=seed, drainage=False)
            t = time.perf_counter()
            res = Session([example], sketch, params=params).run()
            t_run = time.perf_counter() - t
            maps = res.sketch_features
            t = time.perf_counter()
            after = apply_drainage(res.heights, maps.valleys, maps.ridges, patch_size=res.params.patch_size)
            t_drain = time.perf_counter() - t
            width = VALLEY_HALF_WIDTH * res.params.patch_size
            row = {"sketch": sketch_name, "example": key, "run_s": t_run, "drain_s": t_drain,
                   "max_dz": float(np.abs(after - res.heights).max()),
                   "changed": float(np.mean(after != res.heights))}
            for tag, h in (("before", res.heights), ("after", after)):
                m = stroke_measures(h, maps)
                row[f"drain_{tag}"], row[f"cross_{tag}"] = m["drain"], m["cross"]
                row[f"lap_{tag}"] = laplacian_ratio(h, maps, width)
            rows.append(row)
            log(_line(row))
            if pictures is not None:
                pictures.mkdir(parents=True, exist_ok=True)
                lo, hi = float(min(res.heights.min(), after.min())), float(max(res.heights.max(), after.max()))
                left, right = (shaded_relief(h, vrange=(lo, hi)) for h in (res.heights, after))
                gap = np.full((size, 8, left.shape[2]), 255, np.uint8)
                pair = np.concatenate([left, gap, right], axis=1)
                save_png(pair, pictures / f"drainage_{Path(sketch_name).stem}_{key}.png")
    return rows


def _header() -> str:
    return (f"{'sketch':18} {'example':15} {'drain before/after':>18} {'cross before/after':>18} "
            f"{'lap near/rest b/a':>18} {'max dz m':>8} {'changed':>7} {'run s':>6} {'drain s':>7}\n" + "-" * 124)


def _line(r: dict) -> str:
    return (f"{r['sketch']:18} {r['example']:15} {r['drain_before']:8.2f} / {r['drain_after']:5.2f}   "
            f"{r['cross_before']:8.2f} / {r['cross_after']:5.2f}   {r['lap_before']:8.2f} / {r['lap_after']:5.2f}   "
            f"{r['max_dz']:8.1f} {r['changed']:7.3f} {r['run_s']:6.1f} {r['drain_s']:7.2f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pictures", type=Path, default=None, help="write before|after hillshades here")
    args = ap.parse_args(argv)
    print(_header())
    rows = evaluate(args.size, args.seed, args.pictures, log=lambda s: print(s, flush=True))
    print("-" * 124)
    mean = {k: float(np.nanmean([r[k] for r in rows])) for k in rows[0] if k not in ("sketch", "example")}
    print(f"{'mean':34} {mean['drain_before']:8.2f} / {mean['drain_after']:5.2f}   "
          f"{mean['cross_before']:8.2f} / {mean['cross_after']:5.2f}   {mean['lap_before']:8.2f} / "
          f"{mean['lap_after']:5.2f}   {mean['max_dz']:8.1f} {mean['changed']:7.3f} {mean['run_s']:6.1f} "
          f"{mean['drain_s']:7.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
