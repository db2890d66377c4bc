"""Benchmark live sketching: stroke-to-result latency and GUI stalls.

Usage::

    python benchmarks/bench_live.py [--quick] [--no-app] [--fresh-cache] [--json OUT]
    python benchmarks/bench_live.py --baseline REV [--quick] [--repeats N] [--json OUT]

One 1000x1000 terrain (``s_valley_1000.png`` on the built-in
``white-mountains``, default :class:`SynthesisParams` with seed 1) is
synthesized first.  Then each of six 200-cell strokes (three ridges, three
valleys, at different places, drawn with the app's default 9-cell brush)
is added to the sketch and the terrain is brought up to date by two paths,
alternately (the machine is shared, so old and new are compared in the
same run):

* ``old``: today's whole-map local re-synthesis, ``Session(...,
  controls=Controls(previous=, selection=))``, a session built for the
  whole map each time;
* ``crop``: :func:`~terrasynth_core.synthesis.resynthesize_region`, the
  same selection on a crop of two patches' context (no landform pass).

``--picture PATH`` also writes the terrain around two of the strokes
before them, after the whole-map re-synthesis and after the crop's.

Both start from the same terrain and the same selection (the cells within
one patch of the stroke's changed pixels, :func:`stroke_selection`); the
latency counts from the stroke's end (finding the changed pixels and the
selection included) to the whole map's result.  ``follow`` says how well
the new stroke is followed (:func:`follow_score`: about 0 before it, the
larger the clearer its ridge or valley).  Then ``--no-app`` aside,
the same strokes are drawn in the app (offscreen Qt, the main window, Live
on): latency from the stroke's end to the 2D view showing the new terrain
(``shown``, the debounce included), to the update reaching the GUI thread
(``landed``), the engine's own seconds (``engine``: the crop run, from the
examples' snapshot to the pasted result), and the largest gap of a 10 ms heartbeat timer on
the GUI thread during each update (from the stroke's end until a few ticks
after the new terrain is shown): the longest the GUI stalled.

``--baseline REV`` instead times the crop re-synthesis of the engine of
commit ``REV`` (checked out in a temporary ``git worktree``) against this
tree's, in the same run: each engine works in its own long-lived child
process, as in the app (imports, the example's analysis and a warm-up
stroke first, not timed), and the two take turns stroke by stroke (which
goes first alternates).  Every repeat starts two fresh processes, so no
stroke is timed twice in one process (a process keeps what it made for a
stroke, such as seam solvers, and a repeated stroke would find them).
Both engines start from the same terrain (this tree's whole-map run) and
the same strokes; the table gives each stroke's median seconds from the
stroke's end to the whole map's result, the ratio new/old, and whether
both gave the same bytes (when not, ``follow`` of each).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from terrasynth_core.examples import builtin_example, resource_path
from terrasynth_core.features import read_sketch
from terrasynth_core.measures import topographic_position_index
from terrasynth_core.synthesis import (Controls, Session, SynthesisParams, changed_cells, resynthesize_region,
                                       stroke_selection)

PARAMS = SynthesisParams(seed=1)
#: (kind, polyline) of each stroke, 200 cells long, in 1000x1000 cells.
STROKES = (
    ("ridge", [(150, 200), (150, 400)]),
    ("valley", [(820, 120), (820, 320)]),
    ("ridge", [(620, 620), (761, 761)]),
    ("valley", [(300, 800), (500, 800)]),
    ("ridge", [(450, 420), (600, 552)]),  # across the painted valley
    ("valley", [(80, 600), (221, 741)]),
)
BRUSH_RADIUS = 4.5  # the app's default 9-cell brush
#: A stroke apart from :data:`STROKES`: each engine's warm-up with ``--baseline``.
WARM_UP_STROKE = ("valley", [(700, 150), (700, 350)])


def _stroked(base_sketch, kind, points):
    """The app's sketch model with one more stroke, as the core's stroke map."""
    from terrasynth_app.model import Sketch

    sketch = Sketch.from_sketch_map(base_sketch)
    sketch.draw_polyline(points, kind, radius=BRUSH_RADIUS)
    return sketch.to_sketch_map()


def follow_score(heights, stroke, kind) -> float:
    """How well a stroke is followed: the mean topographic position index
    (radius 40 cells) over its pixels in units of the map's TPI spread,
    positive when a ridge stands above / a valley lies below its surroundings."""
    tpi = topographic_position_index(heights, radius=40)
    score = float(np.nanmean(tpi[stroke]) / np.nanstd(tpi))
    return score if kind == "ridge" else -score


def core_rows(example, sketch, previous, strokes, repeats, params):
    rows = []
    for kind, points in strokes:
        after = _stroked(sketch, kind, points)
        new_pixels = (after.ridge_mask & ~sketch.ridge_mask) if kind == "ridge" else \
            (after.valley_mask & ~sketch.valley_mask)
        times = {"old": [], "crop": []}
        results = {}
        cells = 0
        for _ in range(repeats):
            for path in ("old", "crop"):  # alternate: same load for both
                t = time.perf_counter()
                selection = stroke_selection(changed_cells(sketch, after), patch_size=params.patch_size)
                if path == "old":
                    result = Session([example], after, params=params,
                                     controls=Controls(previous=previous, selection=selection)).run()
                else:
                    result = resynthesize_region([example], after, previous=previous, selection=selection,
                                                 params=params)
                times[path].append(time.perf_counter() - t)
                assert np.array_equal(result.heights[~selection], previous[~selection])
                cells = int(selection.sum())
                results[path] = result
        row = {"stroke": f"{kind} {points[0]}->{points[-1]}", "cells": cells,
               "old": statistics.median(times["old"]), "crop": statistics.median(times["crop"]),
               "follow_before": follow_score(previous, new_pixels, kind),
               "follow_old": follow_score(results["old"].heights, new_pixels, kind),
               "follow_crop": follow_score(results["crop"].heights, new_pixels, kind),
               "crop_timings": {k: round(v, 3) for k, v in results["crop"].timings.items()}}
        rows.append(row)
        print(f"  {row['stroke']:<34} {cells:>7} {row['old']:7.2f} {row['crop']:7.2f} {row['old'] / row['crop']:6.1f}x"
              f" {row['follow_before']:14.2f} {row['follow_old']:6.2f} {row['follow_crop']:6.2f}", flush=True)
    return rows


def app_rows(sketch, strokes):
    """Each stroke drawn in the main window with Live on: latency to the 2D
    view showing it, and the largest heartbeat gap meanwhile."""
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from PySide6.QtCore import QEventLoop, QTimer
    from PySide6.QtWidgets import QApplication

    from terrasynth_app.model import Document, ExampleRef, Sketch
    from terrasynth_app.views.main_window import MainWindow

    app = QApplication.instance() or QApplication([])
    doc = Document(Sketch.from_sketch_map(sketch), [ExampleRef(builtin="white-mountains")], params=PARAMS)
    win = MainWindow(doc, recovery=None)
    win.show()
    shown = []
    win.heightmap.result_shown.connect(lambda: shown.append(time.perf_counter()))
    updated = []
    win.live.updated.connect(lambda result: updated.append((time.perf_counter(), result.total_seconds)))
    failed = []
    win.live.failed.connect(failed.append)
    win.synthesis.failed.connect(failed.append)

    def wait(condition, timeout=600.0):
        # Qt's own event loop, in 20 ms slices: it sleeps between events
        # (a processEvents spin would hold the interpreter lock the worker needs).
        end = time.perf_counter() + timeout
        while not condition():
            if failed:
                raise RuntimeError(failed[-1])
            if time.perf_counter() > end:
                raise TimeoutError("the app did not finish in time")
            loop = QEventLoop()
            QTimer.singleShot(20, loop.quit)
            loop.exec()

    win.synthesize()
    wait(lambda: win.document.result is not None and not win.synthesis.running and shown)
    prepared = []
    if hasattr(win.live, "prepared"):  # (an engine from before session 21 prepares nothing)
        win.live.prepared.connect(lambda: prepared.append(True))
    win.live.set_enabled(True)
    if hasattr(win.live, "prepared"):
        # An artist looks at the terrain before the first stroke: Live
        # prepares what that stroke's update reads meanwhile.
        wait(lambda: prepared)
    ticks = []
    heartbeat = QTimer(interval=10)
    heartbeat.timeout.connect(lambda: ticks.append(time.perf_counter()))
    heartbeat.start()
    rows = []
    for kind, points in strokes:
        n_shown = len(shown)
        app.processEvents()
        t = time.perf_counter()
        win.document.sketch.draw_polyline(points, kind, radius=BRUSH_RADIUS)
        # The gaps from here on are the update's: the stroke drawn in one
        # call (a hand draws it over many mouse moves) is not.
        ticks.clear()
        wait(lambda: len(shown) > n_shown)
        latency = shown[-1] - t
        landed, engine = updated[-1]
        count = len(ticks)
        wait(lambda: len(ticks) >= count + 5)  # the frames after the result
        gaps = np.diff(ticks) * 1000 if len(ticks) > 1 else np.array([0.0])
        rows.append({"stroke": f"{kind} {points[0]}->{points[-1]}", "latency": latency, "engine": engine,
                     "landed": landed - t, "max_gap_ms": float(gaps.max())})
        print(f"  {rows[-1]['stroke']:<34} {latency:7.2f} {landed - t:7.2f} {engine:7.2f} "
              f"{rows[-1]['max_gap_ms']:9.0f}", flush=True)
    heartbeat.stop()
    # Threads stopped; the window is not closed (it would ask about saving).
    win.live.wait()
    win.synthesis.wait()
    return rows


def _core_table(sketch, strokes, repeats, picture=None) -> list:
    example = builtin_example("white-mountains").load()
    t = time.perf_counter()
    first = Session([example], sketch, params=PARAMS).run()
    # The strokes keep the size the terrain was made with, as the app's do.
    previous, params = first.heights, first.params
    if picture:
        _picture(picture, example, sketch, previous, params)
    print(f"whole 1000x1000 run first: {time.perf_counter() - t:.1f} s (analysis cached or not)\n")
    print(f"stroke-to-result, median of {repeats}, seconds (old: whole-map re-synthesis, crop: this)")
    print(f"  {'stroke':<34} {'cells':>7} {'old':>7} {'crop':>7} {'ratio':>6} {'follow: before':>14} "
          f"{'old':>6} {'crop':>6}")
    core = core_rows(example, sketch, previous, strokes, repeats, params)
    olds, crops = [r["old"] for r in core], [r["crop"] for r in core]
    ratios = [r["old"] / r["crop"] for r in core]
    follows = [statistics.median(r[k] for r in core) for k in ("follow_before", "follow_old", "follow_crop")]
    print(f"  {'median':<34} {'':>7} {statistics.median(olds):7.2f} {statistics.median(crops):7.2f} "
          f"{statistics.median(ratios):6.1f}x {follows[0]:14.2f} {follows[1]:6.2f} {follows[2]:6.2f}")
    print(f"  {'max':<34} {'':>7} {max(olds):7.2f} {max(crops):7.2f}")
    print("  crop path, last stroke's stages:", core[-1]["crop_timings"])
    return core


def _picture(path, example, sketch, previous, params, picked=(0, 2)) -> None:
    """The terrain around two strokes, one row each: before the stroke (in
    red), after the whole-map re-synthesis, after the crop's."""
    from terrasynth_core.pictures import save_png, shaded_relief

    rows_out = []
    for index in picked:
        kind, points = STROKES[index]
        after = _stroked(sketch, kind, points)
        selection = stroke_selection(changed_cells(sketch, after), patch_size=params.patch_size)
        old = Session([example], after, params=params,
                      controls=Controls(previous=previous, selection=selection)).run()
        new = resynthesize_region([example], after, previous=previous, selection=selection, params=params)
        (r0, c0), (r1, c1) = points[0], points[-1]
        rows, cols = previous.shape
        cr = min(max((r0 + r1) // 2, 190), rows - 190)
        cc = min(max((c0 + c1) // 2, 190), cols - 190)
        window = (slice(cr - 190, cr + 190), slice(cc - 190, cc + 190))
        vrange = (float(previous.min()), float(previous.max()))
        cell = None if old.cell_size is None else (old.cell_size, old.cell_size)
        tiles = [shaded_relief(h, cell_size=cell, vrange=vrange)[window][..., :3].copy()
                 for h in (previous, old.heights, new.heights)]
        tiles[0][(after.ridge_mask & ~sketch.ridge_mask)[window]] = (220, 30, 30)
        gap = np.full((tiles[0].shape[0], 8, 3), 255, np.uint8)
        rows_out.append(np.concatenate([tiles[0], gap, tiles[1], gap, tiles[2]], axis=1))
        rows_out.append(np.full((8, rows_out[-1].shape[1], 3), 255, np.uint8))
    save_png(np.concatenate(rows_out[:-1], axis=0), path)
    print(f"picture: {path} (before with the stroke, whole-map re-synthesis, crop re-synthesis)\n")


#: The engine's side of ``--baseline``, run in a child process with the
#: engine's tree first on ``sys.path`` (public API and the workers' warm-up where
#: it exists, so any commit with
#: ``resynthesize_region`` can be compared).  Reads the terrain and the
#: strokes from the file in ``argv[1]``, starts the worker processes (as
#: the app's whole-map run has), makes the warm-up stroke, then makes
#: the stroke whose number comes on each line of stdin and answers with one
#: line: ``RESULT {json}`` (seconds from the stroke's end, the crop run's
#: timings, the heights' digest; the heights go to the file in ``argv[2]``).
ENGINE_CHILD = r"""
import hashlib, json, sys, time
import numpy as np
from terrasynth_core.examples import builtin_example
from terrasynth_core.features import SketchMap
from terrasynth_core.synthesis import SynthesisParams, changed_cells, resynthesize_region, stroke_selection
data = np.load(sys.argv[1])
params = SynthesisParams(seed=int(data["seed"]), patch_size=int(data["patch_size"]))
example = builtin_example("white-mountains").load()
previous = data["previous"]
before = SketchMap(data["ridge_before"], data["valley_before"])
try:  # as in the app after its whole-map run: the run's worker processes up
    from terrasynth_core.synthesis.workers import wait_warm, warm_up
    warm_up(params.thread_count, params.patch_size)
    wait_warm()
except ImportError:  # (an engine from before wait_warm: its own warm-up list)
    try:
        from concurrent.futures import wait
        from terrasynth_core.synthesis.workers import _WARMING, warm_up
        warm_up(params.thread_count, params.patch_size)
        wait(list(_WARMING))
    except ImportError:
        pass
def stroke(i):
    after = SketchMap(data["ridge"][i], data["valley"][i])
    t = time.perf_counter()
    selection = stroke_selection(changed_cells(before, after), patch_size=params.patch_size)
    result = resynthesize_region([example], after, previous=previous, selection=selection, params=params)
    return time.perf_counter() - t, result
stroke(0)
for line in sys.stdin:
    seconds, result = stroke(int(line))
    np.save(sys.argv[2], result.heights)
    print("RESULT " + json.dumps({"seconds": seconds, "timings": dict(result.timings),
                                  "digest": hashlib.sha256(result.heights.tobytes()).hexdigest()[:16]}), flush=True)
"""


class _Engine:
    """One engine's child process (:data:`ENGINE_CHILD`)."""

    def __init__(self, tree: Path, data: Path, cache: str, heights: Path):
        env = {**os.environ, "PYTHONPATH": str(tree), "TERRASYNTH_CACHE_DIR": cache}
        self.heights = heights
        self.proc = subprocess.Popen([sys.executable, "-c", ENGINE_CHILD, str(data), str(heights)], cwd=tree,
                                     env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def stroke(self, i: int) -> dict:
        self.proc.stdin.write(f"{i}\n")
        self.proc.stdin.flush()
        for line in self.proc.stdout:
            if line.startswith("RESULT "):
                return json.loads(line[len("RESULT "):])
        raise RuntimeError(f"the engine's process ended (exit {self.proc.wait()}); its error is above")

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait()


def baseline_rows(rev: str, sketch, strokes, repeats: int) -> list[dict]:
    """The crop re-synthesis of commit ``rev`` (old) against this tree's
    (new), alternating stroke by stroke; see the module docstring."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from compare_engines import REPO, baseline_worktree

    example = builtin_example("white-mountains").load()
    t = time.perf_counter()
    first = Session([example], sketch, params=PARAMS).run()
    previous = first.heights
    print(f"whole 1000x1000 run first (this tree): {time.perf_counter() - t:.1f} s")
    after = [_stroked(sketch, kind, points) for kind, points in (WARM_UP_STROKE, *strokes)]
    rows = []
    with tempfile.TemporaryDirectory(prefix="terrasynth-live-") as tmp, baseline_worktree(rev, tmp) as old:
        tmp = Path(tmp)
        data = tmp / "strokes.npz"
        np.savez(data, seed=PARAMS.seed, patch_size=first.params.patch_size, previous=previous, ridge_before=sketch.ridge_mask,
                 valley_before=sketch.valley_mask, ridge=np.stack([a.ridge_mask for a in after]),
                 valley=np.stack([a.valley_mask for a in after]))
        trees = {"old": old, "new": REPO}
        caches = {k: str(tmp / f"cache-{k}") for k in trees}
        times = {k: [[] for _ in strokes] for k in trees}
        out = {k: [None] * len(strokes) for k in trees}
        follow = {k: [None] * len(strokes) for k in trees}
        print(f"crop re-synthesis, engine of {rev} (old) against this tree (new): stroke end to result, "
              f"median of {repeats} (fresh processes each), seconds")
        for rep in range(repeats):
            engines = {k: _Engine(tree, data, caches[k], tmp / f"heights-{k}.npy") for k, tree in trees.items()}
            try:
                for i in range(len(strokes)):
                    order = ("old", "new") if (rep + i) % 2 == 0 else ("new", "old")
                    for k in order:
                        res = engines[k].stroke(i + 1)
                        times[k][i].append(res["seconds"])
                        out[k][i] = res
                        if rep == 0:
                            kind = strokes[i][0]
                            mask = after[i + 1].ridge_mask & ~sketch.ridge_mask if kind == "ridge" else \
                                after[i + 1].valley_mask & ~sketch.valley_mask
                            follow[k][i] = follow_score(np.load(engines[k].heights), mask, kind)
            finally:
                for engine in engines.values():
                    engine.close()
        print(f"  {'stroke':<34} {'old':>7} {'new':>7} {'new/old':>8} {'same bytes':>11} {'follow old':>11} "
              f"{'new':>6}")
        for i, (kind, points) in enumerate(strokes):
            o, n = (statistics.median(times[k][i]) for k in ("old", "new"))
            same = out["old"][i]["digest"] == out["new"][i]["digest"]
            rows.append({"stroke": f"{kind} {points[0]}->{points[-1]}", "old": o, "new": n, "ratio": n / o,
                         "old_runs": times["old"][i], "new_runs": times["new"][i], "same_bytes": same,
                         "follow_old": follow["old"][i], "follow_new": follow["new"][i],
                         "new_timings": {k: round(v, 3) for k, v in out["new"][i]["timings"].items()},
                         "old_timings": {k: round(v, 3) for k, v in out["old"][i]["timings"].items()}})
            print(f"  {rows[-1]['stroke']:<34} {o:7.2f} {n:7.2f} {n / o:8.2f} {'yes' if same else 'no':>11} "
                  f"{follow['old'][i]:11.2f} {follow['new'][i]:6.2f}", flush=True)
    olds, news = [r["old"] for r in rows], [r["new"] for r in rows]
    print(f"  {'median':<34} {statistics.median(olds):7.2f} {statistics.median(news):7.2f} "
          f"{statistics.median(r['ratio'] for r in rows):8.2f}")
    print(f"  {'max':<34} {max(olds):7.2f} {max(news):7.2f}")
    print("  last stroke's stages, old:", rows[-1]["old_timings"])
    print("                        new:", rows[-1]["new_timings"])
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="two strokes, one repeat (default: six, three repeats)")
    parser.add_argument("--no-app", action="store_true", help="skip the app's latency and stalls")
    parser.add_argument("--app-only", action="store_true", help="only the app's latency and stalls")
    parser.add_argument("--json", help="also write the figures here")
    parser.add_argument("--picture", help="also write a PNG comparing both paths on one stroke")
    parser.add_argument("--baseline", metavar="REV",
                        help="only time the crop re-synthesis of commit REV against this tree's, side by side")
    parser.add_argument("--repeats", type=int, default=None,
                        help="repeats per stroke (default 3, 1 with --quick)")
    parser.add_argument("--fresh-cache", action="store_true",
                        help="an empty analysis cache (a temporary folder), as for an example the artist has just "
                             "added: its analyses and fill indexes are made in this run")
    args = parser.parse_args()
    if args.fresh_cache:
        # (Removed at exit: a 1000x1000 run and its strokes leave 400 MB there.)
        fresh = tempfile.TemporaryDirectory(prefix="bench-live-cache-")
        os.environ["TERRASYNTH_CACHE_DIR"] = fresh.name
    strokes = STROKES[:2] if args.quick else STROKES
    repeats = args.repeats or (1 if args.quick else 3)
    sketch = read_sketch(resource_path("sketches", "s_valley_1000.png"))
    out = {}
    if args.baseline:
        out["baseline"] = baseline_rows(args.baseline, sketch, strokes, repeats)
        if args.json:
            with open(args.json, "w") as fh:
                json.dump(out, fh, indent=1)
        return
    if not args.app_only:
        out["core"] = _core_table(sketch, strokes, repeats, args.picture)
    if not args.no_app:
        print("\nin the app (offscreen, Live on, 2D view): stroke end to the new terrain shown, largest GUI gap")
        print(f"  {'stroke':<34} {'shown':>7} {'landed':>7} {'engine':>7} {'gap (ms)':>9}")
        rows = app_rows(sketch, strokes)
        lat = [r["latency"] for r in rows]
        gap = [r["max_gap_ms"] for r in rows]
        print(f"  {'median':<34} {statistics.median(lat):7.2f} {'':>7} {'':>7} {statistics.median(gap):9.0f}")
        print(f"  {'max':<34} {max(lat):7.2f} {'':>7} {'':>7} {max(gap):9.0f}")
        print(f"  strokes shown within 1 s: {sum(t <= 1.0 for t in lat)} of {len(lat)}")
        out["app"] = rows
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
