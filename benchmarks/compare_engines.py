"""Time this tree's engine against an earlier commit's, side by side in one run.

Usage::

    python benchmarks/compare_engines.py --baseline HEAD~3 [--sizes 1000x1000,2000x2000] [--repeats 3]

This machine is shared and its timings drift by up to 2x between runs, so
absolute seconds from different runs do not compare.  Here the baseline
commit is checked out in a temporary ``git worktree`` and both engines run
the same case in fresh child processes, alternating old and new, each with
its own warmed example-analysis cache; the table gives the median wall
seconds of each and their ratio, and whether both produced the same bytes:
``old s``/``new s`` for the whole child process from before its imports
(a cold process, as ``terrasynth-cli synth`` is), ``old run``/``new run``
for the synthesis alone once the DEM and sketch are read (warm).

Each case synthesizes ``s_valley_1000.png`` scaled to the size from the
SRTM tile ``N44W072.hgt`` with default parameters and seed 0, through the
public API only (``load_dem``, ``read_sketch``, ``Session``), so any two
commits of the project can be compared.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: Runs in the child: one synthesis, then a JSON line with seconds and digest.
CHILD = r"""
import hashlib, json, sys, time
t0 = time.perf_counter()
from terrasynth_core.features import read_sketch
from terrasynth_core.io import load_dem
from terrasynth_core.synthesis import Session, SynthesisParams
root, rows, cols = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
dem = load_dem(root + "/resources/dems/N44W072.hgt")
sketch = read_sketch(root + "/resources/sketches/s_valley_1000.png")
t1 = time.perf_counter()
result = Session([dem], sketch, shape=(rows, cols), params=SynthesisParams(seed=0)).run()
t2 = time.perf_counter()
print(json.dumps({"total": t2 - t0, "run": t2 - t1,
                  "digest": hashlib.sha256(result.heights.tobytes()).hexdigest()[:16]}))
"""


def _run(tree: Path, size: tuple[int, int], cache: str) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "TERRASYNTH_CACHE_DIR": cache}
    proc = subprocess.run([sys.executable, "-c", CHILD, str(tree), str(size[0]), str(size[1])],
                          cwd=tree, env=env, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"engine in {tree} failed on {size}:\n{proc.stderr.strip()}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


@contextmanager
def baseline_worktree(rev: str, tmp: Path):
    """``rev`` checked out in a temporary detached ``git worktree`` under
    ``tmp`` (its path), removed afterwards."""
    old = Path(tmp) / "baseline"
    subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(old), rev],
                   check=True, capture_output=True)
    try:
        yield old
    finally:
        subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(old)],
                       check=False, capture_output=True)


def _size(text: str) -> tuple[int, int]:
    """``"1000x800"`` (rows x columns) or ``"1000"`` (square)."""
    parts = text.lower().split("x")
    if len(parts) not in (1, 2) or not all(p.strip().isdigit() for p in parts):
        raise SystemExit(f"compare_engines: size {text!r}: expected ROWSxCOLS or N (cells), e.g. 1000x1000")
    rows, cols = int(parts[0]), int(parts[-1])
    return rows, cols


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", required=True, metavar="REV", help="the commit to compare with")
    ap.add_argument("--sizes", default="1000x1000", help="comma-separated ROWSxCOLS (default 1000x1000)")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each engine per size (default 3)")
    args = ap.parse_args(argv)
    sizes = [_size(s) for s in args.sizes.split(",")]

    with tempfile.TemporaryDirectory(prefix="terrasynth-compare-") as tmp, \
            baseline_worktree(args.baseline, tmp) as old:
        trees = {"old": old, "new": REPO}
        caches = {k: tempfile.mkdtemp(dir=tmp) for k in trees}
        for k, tree in trees.items():  # warm each engine's analysis cache
            _run(tree, sizes[0], caches[k])
        print(f"{'size':>11s} {'old s':>7s} {'new s':>7s} {'new/old':>8s} {'old run':>8s} {'new run':>8s} "
              f"{'new/old':>8s}  same bytes")
        for size in sizes:
            times = {"old": [], "new": []}
            runs = {"old": [], "new": []}
            digests = {}
            for _ in range(args.repeats):
                for k, tree in trees.items():
                    out = _run(tree, size, caches[k])
                    times[k].append(out["total"])
                    runs[k].append(out["run"])
                    digests[k] = out["digest"]
            t_old, t_new = (statistics.median(times[k]) for k in ("old", "new"))
            r_old, r_new = (statistics.median(runs[k]) for k in ("old", "new"))
            same = "yes" if digests["old"] == digests["new"] else "no"
            print(f"{size[0]:>5d}x{size[1]:<5d} {t_old:7.2f} {t_new:7.2f} {t_new / t_old:8.2f} {r_old:8.2f} "
                  f"{r_new:8.2f} {r_new / r_old:8.2f}  {same}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
