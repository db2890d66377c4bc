"""Digests of the engine's output on the README's cases, to show that a
change which should not change behaviour gives the same bytes.

Usage::

    python scripts/digests.py                       # print the table
    python scripts/digests.py --json after.json     # also keep it
    python scripts/digests.py --compare before.json # exit 1 on any difference

Each case hashes the heights, the patch-id map, the seam mask and the patch
records (SHA-256, first 16 hex digits).  Run it on the commit before a
refactor (a ``git worktree``) and after; the tables must match line for line.

The bytes depend on the numerical libraries as well as on the engine: the
BLAS kernels OpenBLAS picks for the machine's processor and the library
versions move round-off, and a float32 height can round the other way
(the same commit gave 4 of the 11 digests differently on two machines).
So the JSON also records the environment (:func:`environment`), and
``--compare`` names what differs from the reference's; where it does, make
the reference again from the commit before, here, rather than read a
difference as the change's.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import sys
import time
from importlib import metadata
from pathlib import Path

import numpy as np

from terrasynth_core.examples import builtin_example, resource_path
from terrasynth_core.features import read_sketch
from terrasynth_core.presets import load_preset
from terrasynth_core.synthesis import Session, SynthesisParams


def _digest(result) -> str:
    h = hashlib.sha256()
    for array in (result.heights, result.patch_id, result.seam_mask):
        h.update(np.ascontiguousarray(array).tobytes())
    for p in result.patches:
        h.update(repr((p.kind, p.feature, p.bbox, p.example, p.source, p.mirrored)).encode())
    return h.hexdigest()[:16]


def _sketch(name: str):
    return read_sketch(resource_path("sketches") / name)


def _single(sketch: str, example: str, shape=None, **params):
    def run():
        return Session([builtin_example(example).load()], _sketch(sketch), shape=shape,
                       params=SynthesisParams(**params)).run()
    return run


def _middle_earth(resynthesis: bool):
    def run():
        preset = load_preset("middle-earth")
        params = SynthesisParams(seed=0, cell_size=preset.cell_size)
        result = Session([], preset.sketch, shape=preset.shape, params=params, controls=preset.controls).run()
        if not resynthesis:
            return result
        box = np.zeros(preset.shape, dtype=bool)
        box[300:460, 200:400] = True
        redo = dataclasses.replace(preset.controls, previous=result.heights, selection=box)
        again = SynthesisParams(seed=1, cell_size=preset.cell_size)
        return Session([], preset.sketch, shape=preset.shape, params=again, controls=redo).run()
    return run


CASES = {
    "demo: y_junction / white-mountains": _single("y_junction_512.png", "white-mountains", seed=0),
    "gallery: ring_cross / big-tujunga": _single("ring_cross_512.png", "big-tujunga", seed=0),
    "gallery: s_valley / himalaya 600": _single("s_valley_1000.png", "himalaya", (600, 600), seed=0),
    "seams: paste": _single("s_valley_1000.png", "white-mountains", (512, 512), seed=0, seam="paste", blend="none"),
    "seams: cut": _single("s_valley_1000.png", "white-mountains", (512, 512), seed=0, seam="cut", blend="none"),
    "seams: cut + poisson": _single("s_valley_1000.png", "white-mountains", (512, 512), seed=0, blend="poisson"),
    "seams: cut + c1": _single("s_valley_1000.png", "white-mountains", (512, 512), seed=0, blend="c1"),
    "raster order, no mirrors, seed 3": _single("y_junction_512.png", "st-helens", seed=3, order="raster",
                                                mirror=False, patch_size=48),
    "bench: s_valley / white-mountains 1000": _single("s_valley_1000.png", "white-mountains", seed=0),
    "middle-earth": _middle_earth(False),
    "middle-earth re-synthesis": _middle_earth(True),
}


#: Distributions whose version can move the engine's round-off.
PACKAGES = ("numpy", "scipy", "scikit-image", "PyMaxflow", "faiss-cpu")

#: Key of the environment in the JSON (the other keys are the cases).
ENVIRONMENT = "_environment"


def environment() -> dict[str, str]:
    """The numerical libraries' versions and the BLAS builds and kernels
    in use (``threadpoolctl``), as strings."""
    # A BLAS shows only once its library is loaded: scipy's with its
    # linalg, faiss's (the fill search's index) with faiss.
    import scipy.linalg  # noqa: F401
    from threadpoolctl import threadpool_info
    try:
        import faiss  # noqa: F401
    except ImportError:
        pass

    env = {}
    for name in PACKAGES:
        try:
            env[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            env[name] = "absent"
    for lib in threadpool_info():
        if lib.get("user_api") == "blas":
            # (Keyed by the folder it ships in: numpy's and scipy's wheels each bring one.)
            where = Path(lib.get("filepath", "")).parent.name
            env[f"blas in {where}"] = f"{lib.get('internal_api')} {lib.get('version')} {lib.get('architecture')}"
    return env


def environment_differences(reference: dict) -> list[str]:
    """What differs between the reference's environment and this one, one
    line each (the reference's first); a reference without one says so."""
    theirs = reference.get(ENVIRONMENT)
    if theirs is None:
        return ["the reference does not record its environment"]
    ours = environment()
    return [f"{key}: {theirs.get(key, 'absent')} there, {ours.get(key, 'absent')} here"
            for key in sorted(set(theirs) | set(ours)) if theirs.get(key) != ours.get(key)]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", metavar="OUT", help="also write the digests as JSON")
    ap.add_argument("--compare", metavar="REF", help="compare with a JSON written before; exit 1 on a difference")
    ap.add_argument("--only", metavar="TEXT", help="run only the cases whose name contains TEXT")
    args = ap.parse_args(argv)
    reference = json.loads(open(args.compare).read()) if args.compare else {}
    digests, differ = {}, 0
    print(f"{'case':42s} {'sha256[:16]':16s} {'seconds':>8s}  same")
    for name, run in CASES.items():
        if args.only and args.only not in name:
            continue
        t = time.perf_counter()
        digests[name] = _digest(run())
        same = "" if name not in reference else ("yes" if reference[name] == digests[name] else "NO")
        differ += same == "NO"
        print(f"{name:42s} {digests[name]:16s} {time.perf_counter() - t:8.1f}  {same}", flush=True)
    moved = environment_differences(reference) if args.compare else []
    if differ and moved:
        print(f"\n{differ} digest(s) differ, but so does the environment (the bytes can follow it):")
        for line in moved:
            print(f"  {line}")
        print("Make the reference from the commit before, in this environment (a git worktree), to tell.")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({**digests, ENVIRONMENT: environment()}, f, indent=1)
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
