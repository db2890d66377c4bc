"""Benchmark feature-guided synthesis: time per stage, latency, memory, scaling.

Usage::

    python benchmarks/bench_synth.py [--sizes 1000x1000,2000x2000,4000x2000] [--quick] [--json OUT]
                                     [--baseline REV [--repeats N]]

With ``--baseline REV`` the engine of commit ``REV`` (checked out in a
temporary ``git worktree``) and this tree's are first timed side by side on
the first size, alternating fresh processes (``compare_engines.py``): the
ratio is the figure to trust on a shared machine.

Each row synthesizes ``s_valley_1000.png`` (scaled to the row's size by
``Session(shape=...)``) from the SRTM tile ``N44W072.hgt`` with default
:class:`SynthesisParams`, in a fresh child process (``--one SIZE``) so that
the peak resident memory it reports (``ru_maxrss`` of the child, read after
the run) covers that run alone: loading, analysis, synthesis and result.
Each row starts with an empty example-analysis disk cache (its own
``TERRASYNTH_CACHE_DIR``), so ``load+analyse`` is a cold start; the first
row is then repeated in another process that finds its analysis on disk
(the warm start of a second CLI run or a restarted app).

Columns:

* ``load+analyse``: from before reading the DEM and sketch to the end of the
  run's ``analyse`` stage (constructing the :class:`Session` is nearly all
  of it: PPA on the example, candidate samples, sketch graphs);
* ``landform``, ``features``, ``fill``, ``finish``: the run's stages, as
  its ``StageFinished`` events report them (``landform``: the coarse pass);
* ``total``: wall seconds from before loading to the result;
* ``1st shown``: seconds from calling ``iter_run`` to the first event a
  viewer paints (a landform preview or a patch);
* ``1st patch``: the same to the first full-resolution ``PatchPlaced``;
* ``patches``: placed patches as branch/end/path/fill;
* ``peak MB``: peak resident set size of the child process;
* ``s/Mcell``: total seconds per million output cells; flat means the cost
  grows linearly with the area.

Then two checks in this process: cancel latency (a 1000x1000 run is stopped
after 20 feature patches, and again after 20 fill patches, once by closing
the ``iter_run`` generator and once through ``run(cancel=...)``; the time
from the request to control coming back must stay under 0.5 s) and
determinism (two fresh sessions on a 512x512 output with the same seed must
give the same bytes, compared by SHA-256).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DEM_PATH = REPO / "resources" / "dems" / "N44W072.hgt"
SKETCH_PATH = REPO / "resources" / "sketches" / "s_valley_1000.png"
ALL_SIZES = ("1000x1000", "2000x2000", "4000x2000")
#: Cancellation must hand control back within this many seconds.
CANCEL_LIMIT = 0.5
#: Patches placed (in the stage being tested) before cancelling.
CANCEL_AFTER = 20


def parse_size(text: str) -> tuple[int, int]:
    """``"ROWSxCOLS"`` as ``(rows, cols)``."""
    try:
        rows, cols = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size {text!r}: expected ROWSxCOLS, e.g. 1000x1000") from None
    if rows < 1 or cols < 1:
        raise argparse.ArgumentTypeError(f"size {text!r}: rows and cols must be positive")
    return rows, cols


def _load_session(shape: tuple[int, int], params=None):
    """Read the DEM and sketch and build a session of ``shape``."""
    from terrasynth_core.features import read_sketch
    from terrasynth_core.io import load_dem
    from terrasynth_core.synthesis import Session, SynthesisParams

    dem = load_dem(DEM_PATH)
    sketch = read_sketch(SKETCH_PATH)
    return Session([dem], sketch, shape=shape, params=params or SynthesisParams())


def measure_one(shape: tuple[int, int]) -> dict:
    """Run one synthesis of ``shape`` and measure it (meant for a fresh process).

    Returns
    -------
    dict
        ``shape``, ``stages`` (seconds: ``load+analyse``, ``features``,
        ``fill``, ``finish``), ``total``, ``first_patch``, ``counts``,
        ``peak_mb`` and ``s_per_mcell``.
    """
    from terrasynth_core.synthesis import LandformProgress, PatchPlaced, StageFinished, SynthesisFinished

    t_start = time.perf_counter()
    session = _load_session(shape)
    t_session = time.perf_counter()
    stages: dict[str, float] = {}
    first_patch = first_shown = None
    result = None
    t_iter = time.perf_counter()
    for event in session.iter_run():
        if isinstance(event, (PatchPlaced, LandformProgress)) and first_shown is None:
            first_shown = time.perf_counter() - t_iter
        if isinstance(event, PatchPlaced) and first_patch is None:
            first_patch = time.perf_counter() - t_iter
        elif isinstance(event, StageFinished):
            stages[event.stage] = event.seconds
        elif isinstance(event, SynthesisFinished):
            result = event.result
    total = time.perf_counter() - t_start
    # ru_maxrss is in KiB on Linux (bytes on macOS).
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    peak_mb = rss / 2**20 if sys.platform == "darwin" else rss / 2**10
    cells = shape[0] * shape[1]
    return {
        "shape": list(shape),
        "stages": {
            "load+analyse": (t_session - t_start) + stages.get("analyse", 0.0),
            "landform": stages.get("landform", 0.0),
            "features": stages.get("features", 0.0),
            "fill": stages.get("fill", 0.0),
            "finish": stages.get("finish", 0.0),
        },
        "total": total,
        "first_patch": first_patch,
        "first_shown": first_shown,
        "counts": result.counts(),
        "peak_mb": peak_mb,
        "s_per_mcell": total / (cells / 1e6),
    }


def measure_in_child(size: str, cache_dir: str) -> dict:
    """:func:`measure_one` in a fresh interpreter, so peak memory is its own,
    with the example-analysis disk cache in ``cache_dir``."""
    proc = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), "--one", size],
        capture_output=True, text=True, check=False, env={**os.environ, "TERRASYNTH_CACHE_DIR": cache_dir},
    )
    if proc.returncode != 0:
        raise RuntimeError(f"benchmark child for {size} failed:\n{proc.stderr.strip()}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _stop_point(session, stage: str):
    """Events of a fresh run up to the ``CANCEL_AFTER``-th patch of ``stage``;
    returns the still-open generator."""
    from terrasynth_core.synthesis import PatchPlaced, StageStarted

    events = session.iter_run()
    current = None
    placed = 0
    for event in events:
        if isinstance(event, StageStarted):
            current = event.stage
        elif isinstance(event, PatchPlaced) and current == stage:
            placed += 1
            if placed == CANCEL_AFTER:
                return events
    raise RuntimeError(f"the run placed fewer than {CANCEL_AFTER} {stage} patches: nothing to cancel")


def measure_cancel() -> list[dict]:
    """Seconds from a cancel request to control coming back, for both ways
    of cancelling, in the feature and in the fill stage of a 1000x1000 run."""
    from terrasynth_core.errors import SynthesisCancelled
    from terrasynth_core.synthesis import PatchPlaced, StageStarted

    session = _load_session((1000, 1000))
    rows = []
    for stage in ("features", "fill"):
        events = _stop_point(session, stage)
        t0 = time.perf_counter()
        events.close()
        rows.append({"how": "generator.close()", "stage": stage, "seconds": time.perf_counter() - t0})

        state = {"stage": None, "placed": 0, "asked": None}

        def progress(event, state=state, stage=stage):
            if isinstance(event, StageStarted):
                state["stage"] = event.stage
            elif isinstance(event, PatchPlaced) and state["stage"] == stage:
                state["placed"] += 1

        def cancel(state=state):
            if state["placed"] >= CANCEL_AFTER and state["asked"] is None:
                state["asked"] = time.perf_counter()
            return state["asked"] is not None

        try:
            session.run(progress=progress, cancel=cancel)
        except SynthesisCancelled:
            rows.append({"how": "run(cancel=...)", "stage": stage, "seconds": time.perf_counter() - state["asked"]})
        else:
            raise RuntimeError("run(cancel=...) finished although cancel() returned True")
    return rows


def measure_determinism() -> dict:
    """SHA-256 of the heights of two fresh 512x512 sessions with seed 0."""
    digests = []
    for _ in range(2):
        result = _load_session((512, 512)).run()
        digests.append(hashlib.sha256(result.heights.tobytes()).hexdigest())
    return {"sha256": digests, "same": digests[0] == digests[1]}


def format_table(rows: list[dict]) -> str:
    header = (
        f"{'output':>10} {'load+analyse':>12} {'landform':>8} {'features':>9} {'fill':>8} {'finish':>7} "
        f"{'total':>8} {'1st shown':>9} {'1st patch':>9} {'patches b/e/p/f':>16} {'peak MB':>8} {'s/Mcell':>8}"
    )
    lines = [header, "-" * len(header)]
    for r in rows:
        s, c = r["stages"], r["counts"]
        kinds = f"{c['branch']}/{c['end']}/{c['path']}/{c['fill']}"
        lines.append(
            f"{'x'.join(map(str, r['shape'])):>10} {s['load+analyse']:>12.2f} {s['landform']:>8.2f} "
            f"{s['features']:>9.2f} {s['fill']:>8.2f} {s['finish']:>7.2f} {r['total']:>8.2f} "
            f"{r['first_shown']:>9.2f} {r['first_patch']:>9.2f} "
            f"{kinds:>16} {r['peak_mb']:>8.0f} {r['s_per_mcell']:>8.2f}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default=",".join(ALL_SIZES),
                        help="comma-separated ROWSxCOLS outputs (default: %(default)s)")
    parser.add_argument("--quick", action="store_true", help="only the 1000x1000 row (and the checks)")
    parser.add_argument("--json", type=Path, default=None, metavar="OUT", help="also write the figures as JSON")
    parser.add_argument("--baseline", default=None, metavar="REV",
                        help="first time the engine of commit REV against this one, side by side in the same run "
                             "(benchmarks/compare_engines.py on the first size), e.g. the commit before a speed-up")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each engine with --baseline (default 3)")
    parser.add_argument("--one", type=parse_size, default=None, metavar="SIZE",
                        help="internal: measure one size and print it as JSON")
    args = parser.parse_args(argv)

    if args.one is not None:
        print(json.dumps(measure_one(args.one)))
        return 0

    sizes = ["1000x1000"] if args.quick else [s.strip() for s in args.sizes.split(",") if s.strip()]
    for s in sizes:
        parse_size(s)
    if args.baseline:
        # Absolute seconds drift by up to 2x on a shared machine; the ratio
        # of two engines timed alternately in one run does not.
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from compare_engines import main as compare

        print(f"Engine of {args.baseline} (old) against this tree (new), {sizes[0]}, "
              f"median of {args.repeats} alternating fresh processes")
        compare(["--baseline", args.baseline, "--sizes", sizes[0], "--repeats", str(args.repeats)])
        print()
    print(f"Synthesis of {SKETCH_PATH.name} (scaled) from {DEM_PATH.name}, default SynthesisParams; "
          "seconds unless stated, one fresh process per row")
    rows = []
    with tempfile.TemporaryDirectory(prefix="terrasynth-bench-") as tmp:
        for i, size in enumerate(sizes):
            cache = Path(tmp) / f"cache{i}"
            cache.mkdir()
            rows.append(measure_in_child(size, str(cache)))
            print(format_table(rows).splitlines()[-1] if len(rows) > 1 else format_table(rows), flush=True)
        # The same run again in a new process that finds the first row's
        # analysis on disk: what a second CLI run or a restarted app pays.
        warm = measure_in_child(sizes[0], str(Path(tmp) / "cache0"))
    print(f"\nWith a warm disk cache ({sizes[0]}, new process, analysis of the first row on disk): "
          f"load+analyse {warm['stages']['load+analyse']:.2f} s (cold {rows[0]['stages']['load+analyse']:.2f} s), "
          f"total {warm['total']:.2f} s, peak {warm['peak_mb']:.0f} MB")

    cancel = measure_cancel()
    print(f"\nCancel latency (1000x1000, after {CANCEL_AFTER} patches of the stage; limit {CANCEL_LIMIT} s)")
    print(f"{'how':<18} {'stage':<9} {'seconds':>8} {'ok':>4}")
    for r in cancel:
        print(f"{r['how']:<18} {r['stage']:<9} {r['seconds']:>8.3f} {str(r['seconds'] < CANCEL_LIMIT):>4}")

    same = measure_determinism()
    print("\nSame seed, same bytes (512x512, two fresh sessions, seed 0)")
    for i, digest in enumerate(same["sha256"], 1):
        print(f"run {i}: sha256 {digest}")
    print(f"identical: {same['same']}")

    if args.json is not None:
        args.json.write_text(json.dumps({"runs": rows, "warm_cache": warm, "cancel": cancel, "determinism": same},
                                        indent=2))
    ok = same["same"] and all(r["seconds"] < CANCEL_LIMIT for r in cancel)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
