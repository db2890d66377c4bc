"""Source reuse and stroke TPI of this tree's engine against an earlier commit's.

Usage::

    python benchmarks/eval_variety.py --baseline main [--keep DIR] [--pictures DIR]
    python benchmarks/eval_variety.py --old-tree PATH     # a tree already checked out
    python benchmarks/eval_variety.py --saved DIR         # measure the runs a --keep DIR saved

Each case (a shared sketch on a built-in example at a size, seed 0, default
parameters) is synthesized by both engines in fresh child processes through
the public API only, so any two commits compare; the children save heights
and patch records, and this process measures them alike with this tree's
functions:

* ``reuse``: the largest share of a run's feature patches whose sources lie
  in one example window (:func:`terrasynth_core.matching.usage.source_reuse`);
* ``TPI r/v``: topographic position index along the sketch's ridge and
  valley strokes, radius 15 cells, in standard deviations (as
  ``eval_synthesis.py``);
* ``sec``: wall seconds of the run (this machine is shared: compare the
  ratio of the same case, not absolute seconds across runs).

``--pictures DIR`` also writes a shaded relief of every output.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from contextlib import ExitStack
from pathlib import Path

import numpy as np
from compare_engines import baseline_worktree

REPO = Path(__file__).resolve().parents[1]
CASES = (
    ("ring_cross_512.png", "white-mountains", (1000, 1000)),
    ("y_junction_512.png", "white-mountains", (512, 512)),
    ("s_valley_1000.png", "big-tujunga", (1000, 1000)),
)
TPI_RADIUS = 15

#: Runs in the child: one synthesis; heights to .npy, records and seconds to .json.
CHILD = r"""
import json, sys, time
from dataclasses import asdict
import numpy as np
from terrasynth_core.examples import builtin_example, resource_path
from terrasynth_core.features import read_sketch
from terrasynth_core.synthesis import Session, SynthesisParams
sketch_name, key, rows, cols, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
example = builtin_example(key).load()
sketch = read_sketch(resource_path("sketches") / sketch_name)
t = time.perf_counter()
result = Session([example], sketch, shape=(rows, cols), params=SynthesisParams(seed=0)).run()
seconds = time.perf_counter() - t
np.save(out + ".npy", result.heights)
with open(out + ".json", "w") as f:
    json.dump({"seconds": seconds, "patches": [asdict(p) for p in result.patches]}, f)
"""


def _child(tree: Path, case, out: Path, cache: str) -> None:
    sketch, key, (rows, cols) = case
    env = {**os.environ, "PYTHONPATH": str(tree), "TERRASYNTH_CACHE_DIR": cache}
    proc = subprocess.run([sys.executable, "-c", CHILD, sketch, key, str(rows), str(cols), str(out)],
                          cwd=tree, env=env, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"engine in {tree} failed on {case}:\n{proc.stderr.strip()}")


def _case_name(case) -> str:
    sketch, key, (rows, cols) = case
    return f"{Path(sketch).stem}_{key}_{rows}x{cols}"


def measure(out: Path, case) -> dict:
    """Reuse, stroke TPI and seconds of one saved run."""
    from terrasynth_core.examples import builtin_example, resource_path
    from terrasynth_core.features import read_sketch
    from terrasynth_core.matching.usage import source_reuse
    from terrasynth_core.measures import feature_tpi_score
    from terrasynth_core.synthesis import Session
    from terrasynth_core.synthesis.result import PatchRecord

    heights = np.load(str(out) + ".npy")
    saved = json.loads(Path(str(out) + ".json").read_text())
    records = [PatchRecord(**{k: tuple(v) if isinstance(v, list) else v for k, v in p.items()})
               for p in saved["patches"]]
    sketch = read_sketch(resource_path("sketches") / case[0])
    maps = Session([builtin_example(case[1]).load()], sketch, shape=heights.shape).sketch_maps
    tpi = {kind: feature_tpi_score(heights, graph, radius=TPI_RADIUS)
           for kind, graph in (("ridge", maps.ridges), ("valley", maps.valleys))}
    n_feat = sum(1 for p in records if p.kind in ("branch", "end", "path"))
    return {"reuse": source_reuse(records), "features": n_feat, "tpi": tpi, "seconds": saved["seconds"]}


def _fmt(v: float) -> str:
    return "-" if v != v else f"{v:+.2f}"


def shaded(out: Path, png: Path) -> None:
    from terrasynth_core.pictures import save_png, shaded_relief
    save_png(shaded_relief(np.load(str(out) + ".npy")), png)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--baseline", metavar="REV", help="the commit to compare with (checked out in a temporary worktree)")
    g.add_argument("--old-tree", type=Path, metavar="PATH", help="a checked-out tree of the old engine")
    g.add_argument("--saved", type=Path, metavar="DIR", help="only measure the runs saved in DIR (by --keep)")
    ap.add_argument("--keep", type=Path, default=None, metavar="DIR", help="keep the outputs here")
    ap.add_argument("--pictures", type=Path, default=None, metavar="DIR", help="shaded reliefs of the outputs")
    args = ap.parse_args(argv)

    with tempfile.TemporaryDirectory(prefix="terrasynth-variety-") as tmp, ExitStack() as stack:
        work = args.saved or args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        old = args.old_tree or args.saved
        if old is None:
            old = stack.enter_context(baseline_worktree(args.baseline, Path(tmp)))
        trees = {"old": old, "new": REPO}
        caches = {k: tempfile.mkdtemp(dir=tmp) for k in trees}
        print(f"{'case':44s} {'engine':6s} {'feat':>4s} {'reuse':>6s} {'TPI r':>6s} {'TPI v':>6s} {'sec':>6s}")
        for case in CASES:
            rows = {}
            for k, tree in trees.items():
                out = work / f"{_case_name(case)}_{k}"
                if args.saved is None:
                    _child(tree, case, out, caches[k])
                rows[k] = m = measure(out, case)
                if args.pictures:
                    args.pictures.mkdir(parents=True, exist_ok=True)
                    shaded(out, args.pictures / f"{out.name}.png")
                print(f"{_case_name(case):44s} {k:6s} {m['features']:4d} {m['reuse']:6.2f} "
                      f"{_fmt(m['tpi']['ridge']):>6s} {_fmt(m['tpi']['valley']):>6s} {m['seconds']:6.1f}",
                      flush=True)
            print(f"{'':44s} {'new/old time':>19s} {rows['new']['seconds'] / rows['old']['seconds']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
