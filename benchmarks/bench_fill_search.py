"""Time and check the indexed fill search against the FFT search it replaced.

Usage::

    python benchmarks/bench_fill_search.py [--queries N] [--repeats N] [--runs N] [--no-runs]

One 1000x1000 synthesis of ``s_valley_1000.png`` from the SRTM tile
``N44W072.hgt`` (White Mountains; the ``benchmarks/compare_engines.py``
case, seed 0) is run with the indexed search, and the fill windows it
searched (target heights and filled masks, as the engine passed them) are
kept.  On those same windows, for the example as the run prepared it (``1x``)
and for a library four times larger (``4x``: the example tiled 2x2 with
mirrored copies, same window spacing), the table gives:

* per-query time of the FFT search (:class:`FftFillSearch`, one thread)
  and of the indexed one (:class:`FillSearch`, zone indexes built
  beforehand), median of ``--repeats`` rounds, each timing all four
  (search x library) in turn, and their ratio;
* the indexes' build time (cold: every zone the windows use, built and
  stored in an empty cache) and load time (warm: the same zones read back);
* recall: how often the FFT search's best window (by the exact score) is
  within one grid step of a window on the index's shortlist, and the index
  search's best score over the FFT search's best score (median, p90; below
  1 when the index search finds a better window).

With ``--ann``, the nearest-neighbour libraries the index could use are
compared on the same vectors (the most used zone's, both libraries): build
seconds, milliseconds per query of the shortlist, and the share of the
exact 96 nearest that each returns.

Then (unless ``--no-runs``) the whole synthesis is run ``--runs`` times with
each search, alternating, with the index cache warm, and the fill stage's
seconds (and the landform stage's, which fills its coarse terrain the same
way) are compared.  Timings on this shared machine drift by up to 2x: read
the ratios.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def _case():
    from terrasynth_core.features import read_sketch
    from terrasynth_core.io import load_dem

    dem = load_dem(REPO / "resources" / "dems" / "N44W072.hgt")
    sketch = read_sketch(REPO / "resources" / "sketches" / "s_valley_1000.png")
    return dem, sketch


def _synthesize(dem, sketch, search_class):
    """One run with ``search_class`` as the fill search; its timings, and
    every fill search made and query asked (for the 80-cell windows)."""
    from terrasynth_core.matching.fill_search import FillSearch
    from terrasynth_core.synthesis import Session, SynthesisParams, fill_patches

    made, asked = [], []

    class Recording(search_class):
        def __init__(self, example, window, *, feature_mask=None, coarse_factor=2, overlap=None, void_mask=None):
            kw = {"overlap": overlap} if issubclass(search_class, FillSearch) else {}
            super().__init__(example, window, feature_mask=feature_mask, coarse_factor=coarse_factor,
                             void_mask=void_mask, **kw)
            made.append((self, example, window, feature_mask, coarse_factor, overlap))

        def best(self, target, filled, count, rng):
            asked.append((self, target.copy(), filled.copy(), count))
            return super().best(target, filled, count, rng)

    saved = fill_patches.FillSearch
    fill_patches.FillSearch = Recording
    try:
        # One process: the recording class is local (it cannot go to a worker
        # process), and every query is asked here, where it is recorded.
        result = Session([dem], sketch, shape=(1000, 1000), params=SynthesisParams(seed=0, workers=1)).run()
    finally:
        fill_patches.FillSearch = saved
    return result, made, asked


def _mirror_tiled(a: np.ndarray) -> np.ndarray:
    top = np.concatenate([a, a[:, ::-1]], axis=1)
    return np.ascontiguousarray(np.concatenate([top, top[::-1]], axis=0))


def _per_query(search, queries) -> float:
    t = time.perf_counter()
    for target, filled, count in queries:
        search.best(target, filled, count, None)
    return (time.perf_counter() - t) / len(queries)


def _time_queries(rows, queries, repeats) -> None:
    """Per-query milliseconds of both searches on every library, median of
    ``repeats`` rounds; each round times them all in turn, so a change in
    the machine's load hits every figure alike."""
    times = {(i, kind): [] for i in range(len(rows)) for kind in ("old", "new")}
    for _ in range(repeats):
        for i, row in enumerate(rows):
            for kind in ("old", "new"):
                times[i, kind].append(_per_query(row[kind], queries))
    for i, row in enumerate(rows):
        for kind in ("old", "new"):
            row[f"{kind}_ms"] = 1e3 * statistics.median(times[i, kind])


def _library(name, example, mask, window, f, overlap, queries, cache_root):
    from terrasynth_core.matching.fill_search import FftFillSearch, FillSearch
    from terrasynth_core.matching.window_index import zone_of

    os.environ["TERRASYNTH_CACHE_DIR"] = str(cache_root / name)
    zones = sorted({zone_of(filled, overlap) for _, filled, _ in queries})
    t = time.perf_counter()
    old = FftFillSearch(example, window, feature_mask=mask, coarse_factor=f, workers=1)
    old_setup = time.perf_counter() - t
    t = time.perf_counter()
    new = FillSearch(example, window, feature_mask=mask, coarse_factor=f, overlap=overlap)
    new_setup = time.perf_counter() - t
    t = time.perf_counter()
    for z in zones:
        new.indexes.get(z)
    cold = time.perf_counter() - t
    warm_search = FillSearch(example, window, feature_mask=mask, coarse_factor=f, overlap=overlap)
    t = time.perf_counter()
    for z in zones:
        warm_search.indexes.get(z)
    warm = time.perf_counter() - t
    hits, ratios = [], []
    for target, filled, count in queries:
        old_pos = np.array([p for p, *_ in old.best(target, filled, count, None)])
        new_pos = np.array([p for p, *_ in new.best(target, filled, count, None)])
        old_scores = new.scores(target, filled, old_pos)
        old_best = old_pos[int(np.argmin(old_scores))]
        shortlist = new.candidates(target, filled)
        hits.append(bool((np.abs(shortlist - old_best).max(axis=1) <= f - 1).any()))
        ratios.append(float(new.scores(target, filled, new_pos).min() / max(old_scores.min(), 1e-12)))
    return {
        "name": name, "shape": example.shape, "windows": int(new.positions.shape[0]), "zones": len(zones),
        "old": old, "new": new, "old_setup": old_setup, "new_setup": new_setup, "cold": cold, "warm": warm,
        "recall": float(np.mean(hits)), "ratio_med": float(np.median(ratios)),
        "ratio_p90": float(np.percentile(ratios, 90)), "better": float(np.mean(np.array(ratios) < 1 - 1e-9)),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--queries", type=int, default=60, help="fill windows replayed per library (default 60)")
    ap.add_argument("--repeats", type=int, default=3, help="timing rounds per search (default 3)")
    ap.add_argument("--runs", type=int, default=3, help="whole runs per search (default 3)")
    ap.add_argument("--no-runs", action="store_true", help="skip the whole-run comparison")
    ap.add_argument("--ann", action="store_true", help="also compare nearest-neighbour libraries")
    args = ap.parse_args(argv)

    from terrasynth_core.matching.fill_search import FftFillSearch, FillSearch

    with tempfile.TemporaryDirectory(prefix="bench-fill-") as tmp:
        cache_root = Path(tmp)
        os.environ["TERRASYNTH_CACHE_DIR"] = str(cache_root / "runs")
        dem, sketch = _case()
        print("recording the fill windows of one 1000x1000 run ...", flush=True)
        result, made, asked = _synthesize(dem, sketch, FillSearch)
        search, example, window, mask, f, overlap = max(made, key=lambda m: m[1].size)
        mine = [(t, m, c) for s, t, m, c in asked if s is search and m.any()]
        queries = mine[:: max(1, len(mine) // args.queries)][: args.queries]
        print(f"{len(mine)} fill queries on the {example.shape[0]}x{example.shape[1]} example "
              f"(window {window[0]}, spacing {f}, overlap {overlap}); replaying {len(queries)}\n", flush=True)
        rows = [
            _library("1x", example, mask, window, f, overlap, queries, cache_root),
            _library("4x", _mirror_tiled(example), None if mask is None else _mirror_tiled(mask), window, f,
                     overlap, queries, cache_root),
        ]
        _time_queries(rows, queries, args.repeats)
        head = (f"{'library':8}{'example':>12}{'windows':>9}{'zones':>6}{'FFT ms':>9}{'index ms':>9}{'new/old':>8}"
                f"{'FFT setup s':>12}{'idx setup s':>12}{'build s':>9}{'load s':>8}{'recall':>8}"
                f"{'score med':>10}{'p90':>7}{'better':>7}")
        print(head)
        print("-" * len(head))
        for r in rows:
            print(f"{r['name']:8}{r['shape'][0]:>6}x{r['shape'][1]:<5}{r['windows']:>9}{r['zones']:>6}"
                  f"{r['old_ms']:>9.2f}{r['new_ms']:>9.2f}{r['new_ms'] / r['old_ms']:>8.2f}"
                  f"{r['old_setup']:>12.2f}{r['new_setup']:>12.2f}{r['cold']:>9.2f}{r['warm']:>8.3f}"
                  f"{r['recall']:>8.2f}{r['ratio_med']:>10.3f}{r['ratio_p90']:>7.3f}{r['better']:>7.2f}")
        grow_new = rows[1]["new_ms"] / rows[0]["new_ms"]
        grow_old = rows[1]["old_ms"] / rows[0]["old_ms"]
        print(f"\n4x library / 1x, per query: index {grow_new:.2f}x (target <= 1.5x), FFT {grow_old:.2f}x")
        print("score = index search's best / FFT search's best, by the exact score (<= 1: as good or better); "
              "better = share of windows where the index found a strictly better window")

        if args.ann:
            zone = _most_used_zone(queries, overlap)
            print(f"\nnearest-neighbour libraries on zone {zone}'s vectors, shortlist 96 "
                  "(recall = share of the exact 96 nearest returned)")
            print(f"{'library':8}{'method':34}{'build s':>9}{'query ms':>10}{'recall':>8}")
            for name, ex, mk in (("1x", example, mask), ("4x", _mirror_tiled(example),
                                                          None if mask is None else _mirror_tiled(mask))):
                for method, build_s, query_ms, recall in _compare_ann(ex, mk, window, f, overlap, zone, queries):
                    print(f"{name:8}{method:34}{build_s:>9.2f}{query_ms:>10.3f}{recall:>8.3f}", flush=True)

        if not args.no_runs:
            os.environ["TERRASYNTH_CACHE_DIR"] = str(cache_root / "runs")  # warm: indexes from the first run
            print(f"\nwhole runs at 1000x1000, alternating, {args.runs} each (index cache warm) ...", flush=True)
            times = {"FFT": [], "index": []}
            for _ in range(args.runs):
                for label, cls in (("FFT", _FftWithOverlap(FftFillSearch)), ("index", FillSearch)):
                    res, _, _ = _synthesize(dem, sketch, cls)
                    times[label].append(res.timings)
            print(f"{'stage':12}{'FFT s':>8}{'index s':>9}{'new/old':>8}")
            for stage in ("landform", "fill_setup", "fill"):
                if all(stage in t for ts in times.values() for t in ts):
                    o = statistics.median(t[stage] for t in times["FFT"])
                    n = statistics.median(t[stage] for t in times["index"])
                    print(f"{stage:12}{o:>8.2f}{n:>9.2f}{n / o:>8.2f}")
    return 0


def _most_used_zone(queries, overlap) -> int:
    from terrasynth_core.matching.window_index import zone_of

    zones = [zone_of(filled, overlap) for _, filled, _ in queries]
    return max(set(zones), key=zones.count)


def _compare_ann(example, mask, window, f, overlap, zone, queries, k=96):
    """(method, build seconds, query ms, recall@k) for each library."""
    import faiss
    from scipy.spatial import cKDTree

    from terrasynth_core.matching.fill_search import FillSearch
    from terrasynth_core.matching.window_index import ZoneIndex, ivf_index, zone_of, zone_vectors

    search = FillSearch(example, window, feature_mask=mask, coarse_factor=f, overlap=overlap, use_cache=False)
    prior = search.prior[search.positions[:, 0], search.positions[:, 1]]
    parts, vectors = zone_vectors(example, window, overlap, zone, search.positions, prior)
    describe = ZoneIndex(**parts, positions=search.positions, index=None)
    q = np.concatenate([describe.query_vector(t, m) for t, m, _ in queries if zone_of(m, overlap) == zone])
    faiss.omp_set_num_threads(1)
    exact = faiss.IndexFlatL2(vectors.shape[1])
    exact.add(vectors)
    _, truth = exact.search(q, k)

    def hnsw():
        index = faiss.IndexHNSWFlat(vectors.shape[1], 16)
        index.hnsw.efConstruction = 40
        index.add(vectors)
        index.hnsw.efSearch = 128
        return index

    def nndescent():
        import pynndescent

        index = pynndescent.NNDescent(vectors, n_neighbors=15, random_state=0, n_jobs=1)
        index.prepare()
        return index

    methods = [
        ("faiss IVFFlat (chosen)", lambda: ivf_index(vectors), lambda ix: ix.search(q, k)[1]),
        ("faiss HNSWFlat M16 ef128", hnsw, lambda ix: ix.search(q, k)[1]),
        ("scipy cKDTree (exact)", lambda: cKDTree(vectors), lambda ix: ix.query(q, k)[1]),
        ("scipy cKDTree eps=1", lambda: cKDTree(vectors), lambda ix: ix.query(q, k, eps=1.0)[1]),
        ("brute force (faiss IndexFlatL2)", lambda: exact, lambda ix: ix.search(q, k)[1]),
        ("pynndescent", nndescent, lambda ix: ix.query(q, k)[0]),
    ]
    rows = []
    for method, build, query in methods:
        try:
            t = time.perf_counter()
            index = build()
            built = time.perf_counter() - t
            query(index)  # warm (pynndescent compiles on first use)
            t = time.perf_counter()
            got = query(index)
            per_query = 1e3 * (time.perf_counter() - t) / len(q)
        except ImportError:
            continue
        recall = np.mean([len(set(a) & set(b)) / k for a, b in zip(got, truth)])
        rows.append((method, built, per_query, float(recall)))
    return rows


def _FftWithOverlap(base):
    """The FFT search with the engine's thread count, as it ran before the index."""

    class Fft(base):
        def __init__(self, example, window, *, feature_mask=None, coarse_factor=2, void_mask=None):
            super().__init__(example, window, feature_mask=feature_mask, coarse_factor=coarse_factor,
                             workers=os.cpu_count() or 1, void_mask=void_mask)

    return Fft


if __name__ == "__main__":
    sys.exit(main())
