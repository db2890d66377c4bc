"""Benchmark PPA ridge/valley extraction on the bundled DEMs.

Usage::

    python benchmarks/bench_ppa.py [--repeat N] [--overlays DIR]

For every DEM in ``resources/dems`` it times ``extract_features(kind="both")``
at the native resolution with default :class:`PPAParams` (best of
``--repeat`` runs after a warm-up) and prints one row: the node and path
counts and total length (ridges / valleys), whether both graphs are acyclic,
and the TPI score of ridges and valleys (mean topographic position index on
the paths in standard deviations of the grid's TPI, radius 12 cells, which
is independent of the 7-cell profile length; ridges should be clearly
positive, valleys clearly negative).

Nodata (Mandakini's basin mask, SainteHelens' ragged quadrangle edge) is
passed to PPA as NaN, not cropped: NaN cells are never targets and never
count as lower, and the TPI ignores them.

``--overlays DIR`` also writes ``features_<name>.png`` (hillshade, ridges
red, valleys blue, branch points yellow, endpoints white; at most 800 px
wide) for N44W072, bigtujunga and SainteHelens.

``--baseline DIR`` compares with another checkout of the project (e.g.
``git worktree add /tmp/base <commit>``) instead: for every DEM it times
one ``extract_features`` call in fresh processes, the baseline's and this
tree's in turn, ``--repeat`` times each, and prints the medians of wall and
CPU time (CPU time is steadier on a shared machine), their ratios, whether both
gave the same graphs (a digest of every node and path point), and in how
many of this tree's runs PPA could use two threads (it does only with a
core to spare, :func:`terrasynth_core.features.ppa.spare_core`, unless
``--threads on`` or ``off`` says otherwise).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from terrasynth_core.measures import feature_tpi_score
from terrasynth_core.features import extract_features
from terrasynth_core.pictures import render_overlay, save_png
from terrasynth_core.io import load_dem

DEMS_DIR = Path(__file__).resolve().parents[1] / "resources" / "dems"
DEM_FILES = ("N44W072.hgt", "N00E010.hgt", "bigtujunga.tif", "Mandakini.bil", "SainteHelens.dem")
OVERLAY_DEMS = ("N44W072", "bigtujunga", "SainteHelens")
TPI_RADIUS = 12


def _pair(ridge, valley) -> str:
    return f"{ridge}/{valley}"


#: Run in a fresh process by ``--baseline``: one timed PPA of a DEM, as JSON.
_ONE_RUN = """
import hashlib, json, sys, time
from terrasynth_core.features import extract_features
from terrasynth_core.io import load_dem
field = load_dem(sys.argv[1])
extract_features(field.heights[:64, :64])  # warm-up (imports, caches)
import terrasynth_core.features.ppa as ppa
if sys.argv[2] != "auto" and hasattr(ppa, "spare_core"):
    ppa.spare_core = lambda: sys.argv[2] == "on"
# Whether this run could use two threads (trees from before them: no).
threads = field.heights.size >= getattr(ppa, "THREADED_CELLS", float("inf")) and ppa.spare_core()
wall, cpu = time.perf_counter(), time.process_time()
maps = extract_features(field)
wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
digest = hashlib.sha1()
for graph in (maps.ridges, maps.valleys):
    digest.update(repr((graph.kind, graph.shape, [(n.id, n.row, n.col, n.type, n.degree) for n in graph.nodes],
                        [(p.start, p.end) for p in graph.paths])).encode())
    for path in graph.paths:
        digest.update(path.points.tobytes())
import terrasynth_core
print(json.dumps({"wall": wall, "cpu": cpu, "digest": digest.hexdigest(), "module": terrasynth_core.__file__,
                  "threads": bool(threads)}))
"""


def _one_run(tree: Path, dem: Path, threads: str = "auto") -> dict:
    """Time one PPA of ``dem`` with the project in ``tree``, in a fresh process."""
    # -P: "python -c" would otherwise put the current directory (perhaps
    # this tree) ahead of PYTHONPATH.
    env = dict(os.environ, PYTHONPATH=str(tree))
    done = subprocess.run([sys.executable, "-P", "-c", _ONE_RUN, str(dem), threads], env=env, capture_output=True,
                          text=True, check=True)
    run = json.loads(done.stdout)
    if not Path(run["module"]).resolve().is_relative_to(tree.resolve()):
        raise SystemExit(f"bench_ppa: {tree} did not provide terrasynth_core ({run['module']} did)")
    return run


def compare(baseline: Path, repeat: int, threads: str = "auto") -> int:
    """Print the baseline's and this tree's PPA times side by side; 1 if any graph differs."""
    here = Path(__file__).resolve().parents[1]
    header = (f"{'DEM':<14} {'base wall':>9} {'new wall':>9} {'ratio':>6} {'base CPU':>9} {'new CPU':>8} "
              f"{'ratio':>6}  same graphs  new on 2 threads")
    print(f"PPA (extract_features, kind='both'), medians of {repeat} fresh processes each, alternating; seconds")
    print(header)
    print("-" * len(header))
    differ = False
    for file in DEM_FILES:
        runs = {"base": [], "new": []}
        for _ in range(max(1, repeat)):
            runs["base"].append(_one_run(baseline, DEMS_DIR / file))
            runs["new"].append(_one_run(here, DEMS_DIR / file, threads))
        med = {(k, m): statistics.median(r[m] for r in runs[k]) for k in runs for m in ("wall", "cpu")}
        same = {r["digest"] for r in runs["base"] + runs["new"]}
        differ |= len(same) != 1
        print(f"{Path(file).stem:<14} {med['base', 'wall']:>9.2f} {med['new', 'wall']:>9.2f} "
              f"{med['new', 'wall'] / med['base', 'wall']:>6.2f} {med['base', 'cpu']:>9.2f} "
              f"{med['new', 'cpu']:>8.2f} {med['new', 'cpu'] / med['base', 'cpu']:>6.2f}  "
              f"{'yes' if len(same) == 1 else 'NO':<11}  {sum(r['threads'] for r in runs['new'])}/{len(runs['new'])}",
              flush=True)
    return 1 if differ else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per DEM (best is shown)")
    parser.add_argument("--overlays", type=Path, default=None, help="directory for overlay PNGs")
    parser.add_argument("--baseline", type=Path, default=None, metavar="DIR",
                        help="compare with the project checked out in DIR (fresh processes, medians)")
    parser.add_argument("--threads", choices=("auto", "on", "off"), default="auto",
                        help="with --baseline: this tree's PPA on two threads when a core is spare (auto), "
                             "always (on) or never (off)")
    args = parser.parse_args(argv)
    if args.baseline is not None:
        return compare(args.baseline, args.repeat, args.threads)

    header = (
        f"{'DEM':<14} {'shape':>10} {'seconds':>8} {'#branch':>10} {'#end':>11} {'#paths':>11} "
        f"{'total length':>14} {'acyclic':>8} {'ridge TPI':>10} {'valley TPI':>11}"
    )
    print("PPA, default PPAParams, kind='both'; counts and lengths as ridges/valleys, lengths in cells")
    print(header)
    print("-" * len(header))
    for file in DEM_FILES:
        field = load_dem(DEMS_DIR / file)
        name = Path(file).stem
        extract_features(field.heights[:64, :64])  # warm-up (imports, caches)
        best = float("inf")
        for _ in range(max(1, args.repeat)):
            start = time.perf_counter()
            maps = extract_features(field)
            best = min(best, time.perf_counter() - start)
        r, v = maps.ridges, maps.valleys
        row = (
            f"{name:<14} {f'{field.shape[0]}x{field.shape[1]}':>10} {best:>8.2f} "
            f"{_pair(r.count('branch'), v.count('branch')):>10} {_pair(r.count('end'), v.count('end')):>11} "
            f"{_pair(len(r.paths), len(v.paths)):>11} "
            f"{_pair(round(r.total_length()), round(v.total_length())):>14} "
            f"{str(r.is_acyclic() and v.is_acyclic()):>8} "
            f"{feature_tpi_score(field, r, radius=TPI_RADIUS):>+10.2f} "
            f"{feature_tpi_score(field, v, radius=TPI_RADIUS):>+11.2f}"
        )
        print(row, flush=True)
        if args.overlays is not None and name in OVERLAY_DEMS:
            args.overlays.mkdir(parents=True, exist_ok=True)
            rgb = render_overlay(field, maps, line_width=2 if max(field.shape) > 800 else 1)
            save_png(rgb, args.overlays / f"features_{name}.png", max_width=800, colours=256)
    return 0


if __name__ == "__main__":
    sys.exit(main())
