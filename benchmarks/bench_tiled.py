"""Time tiled runs on Dask: time, speed-up over one worker, peak memory per
worker and of the whole process tree, and the tile-border measure.

Usage::

    python benchmarks/bench_tiled.py                          # 2048^2 and 4096^2, 1 and 2 workers
    python benchmarks/bench_tiled.py --sizes 8192 --workers 2 --json out.json
    python benchmarks/bench_tiled.py --sizes 2048 --workers 1 --baseline   # + a whole-map run's border figure

Each run is a child process (``run_tiled`` on a fresh local cluster); this
process samples the resident memory of the child and all its descendants
(coordinator, nannies, workers) with psutil every 0.2 s, and measures the
borders on the written GeoTIFF after the child has ended.  The examples'
analysis cache is kept between runs (TERRASYNTH_CACHE_DIR, as a user's).
The machine is shared: compare the ratios, not the seconds.

The border measure is noisy where there are few borders (a sketch stroke
crossing one dominates its top 0.1 %): ``--baseline`` also synthesizes the
same problem as one whole map (no tiles, one process) and measures it on
the same grid, which says what the measure gives without any tile.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np
import psutil

from terrasynth_core.tiled.measure import border_ratio
from terrasynth_core.tiled.plan import plan_tiles


def _inputs(sketch: str | None = None):
    """The White Mountains and a built-in sketch (default: the app's)."""
    from terrasynth_core.examples import DEFAULT_EXAMPLE, DEFAULT_SKETCH, builtin_example, resource_path
    from terrasynth_core.features import read_sketch

    return builtin_example(DEFAULT_EXAMPLE).load(), read_sketch(resource_path("sketches", sketch or DEFAULT_SKETCH))


def _library(n: int) -> list:
    """``n`` example DEMs, a stand-in for a large library of real ones: the
    two large built-ins (White Mountains, Gabon plateau) in their eight
    rotations and mirror images, then so turned their central crops (100
    cells off each side), then crops without their last and without their
    first 150 rows and columns: up to 64.  (The other built-ins, at the
    common cell size, are too small for the landform pass, which would then
    be left out for all.)"""
    from terrasynth_core.examples import builtin_example

    fields = [builtin_example(key).load() for key in ("white-mountains", "gabon-plateau")]
    turns = [lambda h, k=k, m=m: np.rot90(h[:, ::-1] if m else h, k) for m in (False, True) for k in range(4)]
    crops = [np.s_[:, :], np.s_[100:-100, 100:-100], np.s_[:-150, :-150], np.s_[150:, 150:]]
    variants = [(f, t, crop) for crop in crops for t in turns for f in fields]
    if n > len(variants):
        raise SystemExit(f"--library: at most {len(variants)} examples, not {n}")
    out = []
    for field, turn, crop in variants[:n]:
        out.append(field.with_heights(np.ascontiguousarray(turn(field.heights[crop]))))
    return out


def _baseline(size: int, tile: int, patch: int, seed: int, sketch: str | None) -> float:
    """The border measure of a whole-map run (no tiles) on the tile grid."""
    from terrasynth_core.synthesis import Session, SynthesisParams

    example, sketch = _inputs(sketch)
    params = SynthesisParams(patch_size=patch, seed=seed, workers=1)  # drained, as the tiled run
    heights = Session([example], sketch, shape=(size, size), params=params).run().heights
    return border_ratio(heights, plan_tiles((size, size), tile, patch_size=patch, seed=seed))


def _child(args) -> int:
    """Run one tiled synthesis and print its figures as JSON."""
    from terrasynth_core.synthesis import SynthesisParams
    from terrasynth_core.tiled import run_tiled

    example, sketch = _inputs(args.sketch)
    examples = [example] if args.library == 1 else _library(args.library)
    # Examples are resampled to one cell size: the Gabon plateau's, so a
    # library's examples are not enlarged.
    params = SynthesisParams(patch_size=args.patch, seed=args.seed, cell_size=None if args.library == 1 else 92.66)
    result = run_tiled(examples, sketch, shape=(args.size, args.size), tile=args.tile, out=args.out,
                       params=params, workers=args.n)
    print(json.dumps({"seconds": result.seconds, "timings": result.timings, "workers": result.workers}))
    return 0


class _TreeMemory:
    """Peak resident memory of a process and its descendants, sampled."""

    def __init__(self, pid: int, every: float = 0.2):
        self.root = psutil.Process(pid)
        self.peak_tree = 0
        self.peak_each: dict[int, int] = {}
        #: Peak resident memory less its file-backed part (mapped files the
        #: kernel can drop and read again: the memory-mapped example library).
        self.peak_private: dict[int, int] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, args=(every,), daemon=True)
        self._thread.start()

    def _watch(self, every: float) -> None:
        while not self._stop.is_set():
            try:
                procs = [self.root, *self.root.children(recursive=True)]
            except psutil.NoSuchProcess:
                return
            total = 0
            for p in procs:
                try:
                    info = p.memory_info()
                except psutil.NoSuchProcess:
                    continue
                total += info.rss
                self.peak_each[p.pid] = max(self.peak_each.get(p.pid, 0), info.rss)
                private = info.rss - getattr(info, "shared", 0)
                self.peak_private[p.pid] = max(self.peak_private.get(p.pid, 0), private)
            self.peak_tree = max(self.peak_tree, total)
            self._stop.wait(every)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()


def _run(size: int, tile: int, n: int, patch: int, seed: int, folder: Path, library: int = 1,
         sketch: str | None = None) -> dict:
    import rasterio

    out = folder / f"tiled_{size}_{n}.tif"
    cmd = [sys.executable, __file__, "--child", "--size", str(size), "--tile", str(tile), "--n", str(n),
           "--patch", str(patch), "--seed", str(seed), "--out", str(out), "--library", str(library),
           *(["--sketch", sketch] if sketch else [])]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    memory = _TreeMemory(proc.pid)
    stdout, _ = proc.communicate()
    memory.stop()
    if proc.returncode:
        raise SystemExit(f"the run {size}x{size} with {n} worker(s) failed (exit {proc.returncode})")
    figures = json.loads(stdout.strip().splitlines()[-1])
    with rasterio.open(out) as ds:
        heights = ds.read(1)
    plan = plan_tiles((size, size), tile, patch_size=patch, seed=seed)
    # The largest processes but the coordinator (the child itself) are the
    # workers (nannies are small).
    others = sorted((v for pid, v in memory.peak_each.items() if pid != proc.pid), reverse=True)
    private = sorted((v for pid, v in memory.peak_private.items() if pid != proc.pid), reverse=True)
    out.unlink()
    return dict(size=size, tile=tile, workers=n, library=library, seconds=figures["seconds"], timings=figures["timings"],
                peak_tree_mb=memory.peak_tree / 2**20, peak_worker_mb=(others[0] if others else 0) / 2**20,
                peak_worker_private_mb=(private[0] if private else 0) / 2**20,
                peak_coordinator_mb=memory.peak_each.get(proc.pid, 0) / 2**20,
                border_ratio=border_ratio(heights, plan))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="2048,4096", help="output sides, comma-separated (default 2048,4096)")
    ap.add_argument("--tile", type=int, default=1024, help="tile side (default 1024)")
    ap.add_argument("--workers", default="1,2", help="worker counts, comma-separated (default 1,2)")
    ap.add_argument("--patch", type=int, default=80)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", metavar="OUT", help="also write the rows as JSON")
    ap.add_argument("--baseline", action="store_true",
                    help="also measure the borders of a whole-map run of each size (slow: one process)")
    ap.add_argument("--library", type=int, default=1,
                    help="example DEMs: 1 (White Mountains) or N (two built-ins rotated and mirrored, then their "
                         "crops; cells of 92.66 m)")
    ap.add_argument("--sketch", help="a built-in sketch file (default: the app's Y-junction, ridges only; "
                                     "s_valley_1000.png has valleys for the drainage)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--size", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--out", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        return _child(args)
    sizes = [int(s) for s in args.sizes.split(",")]
    counts = [int(n) for n in args.workers.split(",")]
    rows = []
    print(f"{'size':>6} {'tile':>5} {'workers':>7} {'time s':>8} {'speed-up':>8} {'worker MB':>9} "
          f"{'private':>8} {'tree MB':>8} {'border':>7} {'drain s':>7}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for size in sizes:
            first = None
            for n in counts:
                row = _run(size, args.tile, n, args.patch, args.seed, Path(tmp), args.library, args.sketch)
                first = first or (row["seconds"] if n == 1 else None)
                row["speed_up"] = None if first is None else first / row["seconds"]
                rows.append(row)
                speed = "-" if row["speed_up"] is None else f"{row['speed_up']:.2f}x"
                print(f"{size:>6} {args.tile:>5} {n:>7} {row['seconds']:>8.1f} {speed:>8} "
                      f"{row['peak_worker_mb']:>9.0f} {row['peak_worker_private_mb']:>8.0f} "
                      f"{row['peak_tree_mb']:>8.0f} {row['border_ratio']:>7.3f} "
                      f"{row['timings'].get('drainage', float('nan')):>7.1f}",
                      flush=True)
    by_size = {}
    for r in rows:
        by_size.setdefault(r["workers"], {})[r["size"]] = r["peak_tree_mb"]
    if args.baseline:
        for size in sizes:
            print(f"whole-map run {size}x{size} (no tiles) on the same grid: border "
                  f"{_baseline(size, args.tile, args.patch, args.seed, args.sketch):.3f}", flush=True)
    for n, peaks in by_size.items():
        if 2048 in peaks and 4096 in peaks:
            print(f"tree memory 4096^2 / 2048^2 with {n} worker(s): {peaks[4096] / peaks[2048]:.2f}x")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    sys.exit(main())
