"""Benchmark what adding a DEM costs: a Session with an empty analysis cache.

Usage::

    python benchmarks/bench_analysis.py [--baseline DIR] [--repeat N] [--dems N00E010.hgt,N44W072.hgt]

For each DEM (``resources/dems``) a fresh process makes
``Session([dem], s_valley_1000.png)`` with ``TERRASYNTH_CACHE_DIR`` set to a
new empty folder, after a warm-up session on a 200x200 corner (imports), and
reports its CPU seconds, split into:

- ``PPA``: ``extract_features`` of the example (ridges and valleys);
- ``samples``: ``example_samples`` of both networks (feature patch centres);
- ``rectangle``: ``largest_valid_rectangle`` (the square-cell resampling
  leaves NaN edges to crop);
- ``resample``: ``to_square_cells``, the rest of putting the example on
  square cells;
- ``sketch``: the sketch's graphs (every session pays them, whatever its
  examples);
- ``other``: everything else (TPI, the strong mask, relief, saving the
  cache).

CPU seconds count every thread of the process: with a core to spare the
analysis runs on two threads (PPA's ridges and valleys, the TPI beside
them), and a part's CPU then includes the work overlapping it; the last
column is the session's wall time.  With ``--baseline DIR`` (another checkout, e.g. ``git worktree add
/tmp/base <commit>``) the baseline's process and this tree's alternate,
``--repeat`` times each; the table shows medians and the new/base ratios,
and whether both made the same example analysis (a digest of the graphs,
samples, strong mask and relief).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEMS_DIR = ROOT / "resources" / "dems"
SKETCH = ROOT / "resources" / "sketches" / "s_valley_1000.png"
DEFAULT_DEMS = ("N00E010.hgt", "N44W072.hgt")
PARTS = ("PPA", "samples", "rectangle", "resample", "sketch", "other")

#: Run in a fresh process: one Session with an empty cache, timed by part, as JSON.
_ONE_RUN = r"""
import hashlib, json, os, sys, tempfile, time
import numpy as np
dem_path, sketch_path = sys.argv[1], sys.argv[2]
os.environ["TERRASYNTH_CACHE_DIR"] = tempfile.mkdtemp(prefix="bench-analysis-")
import terrasynth_core
from terrasynth_core import heightfield
from terrasynth_core.exemplars import ground, prepare
from terrasynth_core.features import read_sketch
from terrasynth_core.io import load_dem
from terrasynth_core.synthesis import Session
from terrasynth_core.synthesis import session as session_module

spent = {}
inner_time = [[0.0, 0.0]]  # per open timed call: time of the timed calls inside it

def timed(module, name, part):
    # Each call's own time (less that of the timed calls inside it) goes to part.
    inner = getattr(module, name)
    def wrapper(*args, **kwargs):
        wall, cpu = time.perf_counter(), time.process_time()
        inner_time.append([0.0, 0.0])
        try:
            return inner(*args, **kwargs)
        finally:
            w, c = time.perf_counter() - wall, time.process_time() - cpu
            nested = inner_time.pop()
            inner_time[-1][0] += w
            inner_time[-1][1] += c
            before = spent.get(part, (0.0, 0.0))
            spent[part] = (before[0] + w - nested[0], before[1] + c - nested[1])
    setattr(module, name, wrapper)

dem = load_dem(dem_path)
sketch = read_sketch(sketch_path)
Session([dem.with_heights(dem.heights[:200, :200].copy())], sketch)  # warm-up: imports
os.environ["TERRASYNTH_CACHE_DIR"] = tempfile.mkdtemp(prefix="bench-analysis-")
prepare._CACHE.clear()
ground._MEMO.clear()
timed(prepare, "extract_features", "PPA")
timed(prepare, "example_samples", "samples")
timed(heightfield, "largest_valid_rectangle", "rectangle")
if hasattr(prepare, "largest_valid_rectangle"):  # (a baseline from before examples kept their voids)
    timed(prepare, "largest_valid_rectangle", "rectangle")
timed(ground, "to_square_cells", "resample")
timed(session_module, "sketch_features", "sketch")
wall, cpu = time.perf_counter(), time.process_time()
session = Session([dem], sketch)
wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
spent["other"] = (wall - sum(w for w, _ in spent.values()), cpu - sum(c for _, c in spent.values()))
spent["total"] = (wall, cpu)
analysis = session.examples[0]
digest = hashlib.sha1(analysis.strong_mask.tobytes() + repr(analysis.relief).encode())
for graph in (analysis.features.ridges, analysis.features.valleys):
    digest.update(repr([(n.id, n.row, n.col, n.type, n.degree) for n in graph.nodes]).encode())
    for path in graph.paths:
        digest.update(repr((path.start, path.end)).encode() + path.points.tobytes())
for kind in ("ridge", "valley"):
    for sample in analysis.samples[kind]:
        digest.update(sample.kind.encode() + sample.center.tobytes() + sample.crossings.tobytes())
print(json.dumps({"spent": spent, "digest": digest.hexdigest(), "module": terrasynth_core.__file__,
                  "shape": list(analysis.heights.shape)}))
"""


def _one_run(tree: Path, dem: Path) -> dict:
    """One Session with an empty cache, with the project in ``tree``, in a fresh process."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    # -P: "python -c" would otherwise put the current directory ahead of PYTHONPATH.
    done = subprocess.run([sys.executable, "-P", "-c", _ONE_RUN, str(dem), str(SKETCH)], env=env,
                          capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"bench_analysis: the run in {tree} failed:\n{done.stderr}")
    run = json.loads(done.stdout)
    if not Path(run["module"]).resolve().is_relative_to(tree.resolve()):
        raise SystemExit(f"bench_analysis: {tree} did not provide terrasynth_core ({run['module']} did)")
    return run


def _row(label: str, values: list[float], total_wall: float) -> str:
    return f"{label:<16}" + "".join(f"{v:>10.2f}" for v in values) + f"{total_wall:>10.2f}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, default=None, metavar="DIR",
                        help="compare with the project checked out in DIR")
    parser.add_argument("--repeat", type=int, default=3, help="fresh processes per tree and DEM (medians)")
    parser.add_argument("--dems", default=",".join(DEFAULT_DEMS), help="comma-separated files in resources/dems")
    args = parser.parse_args(argv)
    trees = {"new": ROOT} if args.baseline is None else {"base": args.baseline, "new": ROOT}
    print(f"Adding a DEM: Session([dem], {SKETCH.name}) with an empty analysis cache; CPU seconds by part "
          f"(all threads), medians of {max(1, args.repeat)} fresh processes per tree" +
          (", alternating" if len(trees) == 2 else ""))
    header = f"{'DEM / tree':<16}" + "".join(f"{p:>10}" for p in (*PARTS, "total")) + f"{'wall':>10}"
    print(header)
    print("-" * len(header))
    differ = False
    for name in args.dems.split(","):
        runs = {k: [] for k in trees}
        for _ in range(max(1, args.repeat)):
            for key, tree in trees.items():
                runs[key].append(_one_run(tree, DEMS_DIR / name))
        cpu = {k: [statistics.median(r["spent"].get(p, (0.0, 0.0))[1] for r in runs[k]) for p in (*PARTS, "total")]
               for k in trees}
        wall = {k: statistics.median(r["spent"]["total"][0] for r in runs[k]) for k in trees}
        shape = "x".join(str(v) for v in runs["new"][0]["shape"])
        for key in trees:
            print(_row(f"{Path(name).stem} {key}", cpu[key], wall[key]))
        if len(trees) == 2:
            ratios = [n / b if b > 0.005 else float("nan") for n, b in zip(cpu["new"], cpu["base"])]
            same = len({r["digest"] for k in trees for r in runs[k]}) == 1
            differ |= not same
            print(_row("  new/base", ratios, wall["new"] / wall["base"]) +
                  f"   same analysis: {'yes' if same else 'NO'} ({shape} cells)")
        print(flush=True)
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
