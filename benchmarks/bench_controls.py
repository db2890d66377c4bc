"""Time the artist controls on the Middle-earth map: the whole run, its
finishing steps (water, pins), a local re-synthesis, and variations in
parallel against one after another.

Usage::

    python benchmarks/bench_controls.py            # the table
    python benchmarks/bench_controls.py --json out.json

Run on a quiet machine.  The first row analyses the examples with an
empty cache (what a first start costs); the others use the analysis
cached in memory, as the app does run after run.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import tempfile
import time

import numpy as np

from terrasynth_core.presets import load_preset
from terrasynth_core.synthesis import Session, SynthesisParams, run_variations


def _timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variations", type=int, default=4, help="how many variations to time (default 4)")
    ap.add_argument("--json", metavar="OUT", help="also write the figures as JSON")
    args = ap.parse_args(argv)

    preset = load_preset("middle-earth")
    params = SynthesisParams(seed=0, cell_size=preset.cell_size)
    rows = []

    def session(controls, p=params):
        return Session([], preset.sketch, shape=preset.shape, params=p, controls=controls)

    # Cold: an empty disk cache for this first session (nothing in memory yet).
    with tempfile.TemporaryDirectory() as empty:
        saved = os.environ.get("TERRASYNTH_CACHE_DIR")
        os.environ["TERRASYNTH_CACHE_DIR"] = empty
        try:
            _, cold = _timed(lambda: session(preset.controls))
        finally:
            if saved is None:
                del os.environ["TERRASYNTH_CACHE_DIR"]
            else:
                os.environ["TERRASYNTH_CACHE_DIR"] = saved
    rows.append(("set-up: analyse 4 styles (empty cache)", cold, "PPA of each example, once; cached after"))
    result, full = _timed(lambda: session(preset.controls).run())
    rows.append((f"Middle-earth {preset.shape[0]}x{preset.shape[1]}, whole run", full,
                 ", ".join(f"{k} {v:.1f}" for k, v in result.timings.items())))
    plain, t_plain = _timed(lambda: session(dataclasses.replace(preset.controls, water=None, pins=())).run())
    rows.append(("same without water and pins", t_plain, ""))

    selection = np.zeros(preset.shape, bool)
    selection[200:400, 450:650] = True
    redo = dataclasses.replace(preset.controls, previous=result.heights, selection=selection)
    again, t_redo = _timed(lambda: session(redo, dataclasses.replace(params, seed=7)).run())
    changed_outside = int((again.heights[~selection] != result.heights[~selection]).sum())
    rows.append(("re-synthesize a 200x200 selection", t_redo, f"{changed_outside} cells changed outside"))

    seeds = list(range(1, args.variations + 1))
    _, t_par = _timed(lambda: run_variations([], preset.sketch, seeds=seeds, shape=preset.shape, params=params,
                                             controls=preset.controls))
    rows.append((f"{len(seeds)} variations in parallel processes", t_par, ""))
    _, t_seq = _timed(lambda: run_variations([], preset.sketch, seeds=seeds, shape=preset.shape, params=params,
                                             controls=preset.controls, workers=1))
    rows.append((f"{len(seeds)} variations one after another", t_seq, f"parallel speed-up {t_seq / t_par:.2f}x"))

    width = max(len(r[0]) for r in rows)
    print(f"{'what':<{width}}  seconds  notes")
    print("-" * (width + 30))
    for what, sec, note in rows:
        print(f"{what:<{width}}  {sec:7.1f}  {note}")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump([{"what": w, "seconds": s, "notes": n} for w, s, n in rows], f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
