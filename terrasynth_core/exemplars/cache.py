"""An on-disk cache of example analyses, so that a second run on the same
example (the CLI, a restarted app) starts placing patches at once.

One ``.npz`` file per (heights, patch size, version), one per example
resampled to a run's cell size (:mod:`.ground`), and one per fill-search
zone index (:mod:`terrasynth_core.matching.window_index`: example, window,
zone, version), in
``$TERRASYNTH_CACHE_DIR`` or ``$XDG_CACHE_HOME/terrasynth`` (default
``~/.cache/terrasynth``).  Files are written atomically and read with
``allow_pickle=False``; each holds its key (the heights' digest, shape and
patch size), checked on load, so a file of another example under this
one's name is never used; an unreadable, stale or foreign file is ignored
and rewritten, never an error.  Set ``TERRASYNTH_CACHE_DIR`` to an empty string to turn the
cache off.
"""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from pathlib import Path
from typing import Callable

import numpy as np

from ..features import FeatureGraph, FeatureMaps
from ..features.graph import FeatureNode, FeaturePath
from ..io._common import atomic_outputs, open_new
from ..features.samples import FeatureSample

#: Bump when the analysis changes, so old files are not reused.
CACHE_VERSION = 1
_KINDS = ("ridge", "valley")


def cache_dir() -> Path | None:
    """Folder of the cache, or None when it is turned off."""
    env = os.environ.get("TERRASYNTH_CACHE_DIR")
    if env is not None:
        return Path(env) if env else None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "terrasynth"


def _path(key: str) -> Path | None:
    folder = cache_dir()
    return None if folder is None else folder / f"example-v{CACHE_VERSION}-{key}.npz"


class Memo(OrderedDict):
    """The last ``size`` values in memory, backed by this disk cache.

    ``get(key, compute)`` looks in memory, then on disk (``load``), and
    only then computes (and saves) the value; thread-safe for lookups
    (two threads may compute the same value once each).
    """

    def __init__(self, size: int, load: Callable[[str], object], save: Callable[[str, object], None]):
        super().__init__()
        self.size, self._load, self._save = size, load, save
        self._lock = threading.Lock()

    def get(self, key: str, compute: Callable[[], object]):
        with self._lock:
            value = super().get(key)
        if value is None:
            value = self._load(key)
            if value is None:
                value = compute()
                self._save(key, value)
            with self._lock:
                self[key] = value
                while len(self) > self.size:
                    self.popitem(last=False)
        return value


def load(key: str):
    """The cached ``(features, samples, strong_mask, relief)`` or None."""

    def read(z):
        shape = tuple(int(v) for v in z["shape"])
        graphs = [_graph_from(z, kind, shape) for kind in _KINDS]
        samples = {kind: _samples_from(z, kind) for kind in _KINDS}
        strong = np.unpackbits(z["strong"], count=shape[0] * shape[1]).reshape(shape).astype(bool)
        return FeatureMaps(*graphs), samples, strong, float(z["relief"])

    return _read(key, read)


def _read(key: str, read):
    """``read(z)`` of the file saved under ``key``, or None when there is
    none, it is damaged, or it was saved under another key."""
    path = _path(key)
    if path is None or not path.is_file():
        return None
    try:
        # The file is opened here, not by np.load: given a path, np.load
        # leaves the file open when a truncated archive fails to open.
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            if not _same_key(z, key):
                return None  # another grid's file under this name (or one from before keys)
            return read(z)
    except Exception:  # a damaged or foreign file: recompute
        return None


def _same_key(z, key: str) -> bool:
    """Whether the file ``z`` was saved under ``key``: the key (the heights'
    digest, shape and patch size) is stored inside, so a file copied or
    renamed onto another example's name is never used for it."""
    return "key" in z.files and z["key"].shape == () and str(z["key"]) == key


def save(key: str, features: FeatureMaps, samples: dict, strong: np.ndarray, relief: float) -> None:
    """Store an analysis; failures (read-only home, full disk) are ignored."""
    path = _path(key)
    if path is None:
        return
    arrays = {"key": np.array(key), "shape": np.array(strong.shape), "strong": np.packbits(strong),
              "relief": np.array(relief)}
    for graph in (features.ridges, features.valleys):
        arrays.update(_graph_arrays(graph))
    for kind in _KINDS:
        arrays.update(_sample_arrays(kind, samples[kind]))
    _write(path, arrays)


def _write(path: Path, arrays: dict) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_outputs(path) as (tmp,), open_new(tmp) as f:
            np.savez(f, **arrays)
    except OSError:
        pass


def load_array(key: str) -> np.ndarray | None:
    """A cached float32 grid (an example resampled to a cell size) or None."""
    heights = _read(key, lambda z: z["heights"])
    return heights if heights is not None and heights.ndim == 2 and heights.dtype == np.float32 else None


def save_array(key: str, heights: np.ndarray) -> None:
    """Store a float32 grid; failures are ignored, as for analyses."""
    path = _path(key)
    if path is not None:
        _write(path, {"key": np.array(key), "heights": np.ascontiguousarray(heights, dtype=np.float32)})


def load_arrays(key: str) -> dict | None:
    """Every array of the file saved under ``key`` (by :func:`save_arrays`),
    or None."""
    return _read(key, lambda z: {name: z[name] for name in z.files if name != "key"})


def save_arrays(key: str, arrays: dict) -> None:
    """Store named arrays (a fill-search index); failures are ignored, as
    for analyses."""
    path = _path(key)
    if path is not None:
        _write(path, {**arrays, "key": np.array(key)})


def _graph_arrays(graph: FeatureGraph) -> dict:
    k = graph.kind
    pts = [p.points for p in graph.paths]
    return {
        f"{k}_nodes": np.array([[n.row, n.col] for n in graph.nodes], dtype=float).reshape(-1, 2),
        f"{k}_node_branch": np.array([n.type == "branch" for n in graph.nodes], dtype=bool),
        f"{k}_node_degree": np.array([n.degree for n in graph.nodes], dtype=np.int32),
        f"{k}_ends": np.array([[p.start, p.end] for p in graph.paths], dtype=np.int64).reshape(-1, 2),
        f"{k}_counts": np.array([len(p) for p in pts], dtype=np.int64),
        f"{k}_points": np.concatenate(pts) if pts else np.zeros((0, 2)),
    }


def _graph_from(z, kind: str, shape) -> FeatureGraph:
    nodes = tuple(
        FeatureNode(i, float(r), float(c), "branch" if b else "end", int(d))
        for i, ((r, c), b, d) in enumerate(zip(z[f"{kind}_nodes"], z[f"{kind}_node_branch"], z[f"{kind}_node_degree"]))
    )
    splits = np.cumsum(z[f"{kind}_counts"])[:-1]
    points = np.split(z[f"{kind}_points"], splits) if len(z[f"{kind}_counts"]) else []
    paths = tuple(FeaturePath(int(a), int(b), p) for (a, b), p in zip(z[f"{kind}_ends"], points))
    return FeatureGraph(kind, shape, nodes, paths)


def _sample_arrays(kind: str, samples: list[FeatureSample]) -> dict:
    return {
        f"{kind}_s_centers": np.array([s.center for s in samples], dtype=float).reshape(-1, 2),
        f"{kind}_s_degree": np.array([s.degree for s in samples], dtype=np.int64),
        f"{kind}_s_crossings": (np.concatenate([s.crossings for s in samples]) if samples
                                else np.zeros((0, 2))),
    }


def _samples_from(z, kind: str) -> list[FeatureSample]:
    degrees = z[f"{kind}_s_degree"]
    crossings = np.split(z[f"{kind}_s_crossings"], np.cumsum(degrees)[:-1]) if len(degrees) else []
    return [FeatureSample(c.copy(), kind, x) for c, x in zip(z[f"{kind}_s_centers"], crossings)]
