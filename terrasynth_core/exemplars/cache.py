"""An on-disk cache of example analyses, so that a second run on the same
example (the CLI, a restarted app) starts placing patches at once.

One ``.npz`` file per (heights, patch size, version), one per example
resampled to a run's cell size (:mod:`.ground`), and one per fill-search
zone index (:mod:`terrasynth_core.matching.window_index`: example, window,
zone, version), in
``$TERRASYNTH_CACHE_DIR`` or ``$XDG_CACHE_HOME/terrasynth`` (default
``~/.cache/terrasynth``), kept within ``$TERRASYNTH_CACHE_MAX_GB`` (default
16 GiB) by removing the least recently used entries (:mod:`.cache_size`).  Files are written atomically and read with
``allow_pickle=False``; each holds its key (the heights' digest, shape and
patch size), checked on load, so a file of another example under this
one's name is never used; an unreadable, stale or foreign file is ignored
and rewritten, never an error.  Set ``TERRASYNTH_CACHE_DIR`` to an empty string to turn the
cache off.

Large members are not inside the ``.npz`` but beside it, so a run maps them
instead of reading them (a library of examples larger than memory, each
worker of a tiled run touching only the windows its searches read): an
array of :data:`SIDE_BYTES` or more as a ``.npy`` loaded with
``mmap_mode="r"``, and raw bytes (a faiss index) as a ``.bin`` handed back
as its path, for the reader to map.  The ``.npz``, written last, names each
side file with its size, modification time and BLAKE2b digest; a side file
is checked against them once per process before it is first used: one
whose size and time are those written is the file written (reading a fill
index's 15 MB files through the hash cost a cold run 0.3 s in each
process), any other is read through and hashed (a damaged or replaced one
makes the entry unreadable: it is rebuilt, never trusted).  Mapped pages are the
page cache's: resident while used, dropped by the kernel under pressure,
shared by every process on the machine that maps the same file.  An entry
from before side files, its large arrays inside, is made again and stored
anew rather than read into memory.  A stored analysis's feature graphs
and samples stay arrays (:class:`~terrasynth_core.features.graph.NodeTable`,
:class:`~terrasynth_core.features.graph.PathTable`,
:class:`~terrasynth_core.features.samples.SampleTable`): an object per
node, path or sample is made only when one is asked for.
"""

from __future__ import annotations

import hashlib
import json
import os
import threading
from collections import OrderedDict
from pathlib import Path
from typing import Callable

import numpy as np

from ..features import FeatureGraph, FeatureMaps
from ..features.graph import NodeTable, PathTable
from ..io._common import atomic_outputs, open_new
from ..features.samples import FeatureSample, SampleTable
from . import cache_size, mapped_pages

#: Bump when the analysis changes, so old files are not reused.
CACHE_VERSION = 1
_KINDS = ("ridge", "valley")

#: Arrays of at least this many bytes (a page) are kept beside the ``.npz``
#: and mapped: a library's many small arrays too, which read into each
#: worker's memory would grow it with the library.
SIDE_BYTES = 4096
#: Entries written before side files held arrays this large inside; one
#: holding any such array is made again (an earlier version's entries with
#: arrays of 4-256 kB inside are read as they are).
_INSIDE_BEFORE_SIDES = 256 * 1024

#: Side files checked in this process: (path, size, mtime, digest) of each.
_CHECKED: set = set()
_CHECKED_LOCK = threading.Lock()


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


def _side_path(entry: Path, member: str, suffix: str) -> Path:
    """A member kept beside the entry ``entry`` (named for the entry and the member)."""
    return entry.with_name(f"{entry.stem}.{member}{suffix}")


class Memo(OrderedDict):
    """The last ``size`` values in memory, backed by this disk cache.

    ``get(key, compute)`` looks in memory, then on disk (``load``), and
    only then computes (and saves) the value; thread-safe for lookups
    (two threads may compute the same value once each).  A value just
    computed and saved is kept as read back from disk when that works: its
    large arrays then are mapped files, not this process's memory.
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
                # The same bytes, mapped (None when the cache is off or the write failed).
                stored = self._load(key)
                value = value if stored is None else stored
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
        if "strong_mask" in z.files:
            strong = z["strong_mask"]
            if strong.shape != shape or strong.dtype != bool:
                return None
        else:  # an entry written before the mask was kept unpacked
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
            if _large_inside(z):
                return None  # written before side files: made again, so that it is mapped
            got = read(_Entry(z, path))
    except Exception:  # a damaged or foreign file (or a side file missing or changed): recompute
        return None
    if got is not None:
        cache_size.mark_used(path)
    return got


def _large_inside(z) -> bool:
    """Whether the archive ``z`` holds a large array itself (an entry
    from before side files), which would be read into memory rather than
    mapped."""
    return any(info.file_size >= _INSIDE_BEFORE_SIDES for info in z.zip.infolist())


class _Entry:
    """An opened ``.npz`` entry whose members may be side files: ``entry[name]``
    is the array (mapped for a ``.npy`` side file) or the path of a raw one."""

    def __init__(self, z, path: Path):
        self._z, self._folder = z, path.parent
        self._side = json.loads(str(z["sides"])) if "sides" in z.files else {}
        self.files = [n for n in z.files if n != "sides"] + list(self._side)

    def __getitem__(self, name: str):
        if name not in self._side:
            return self._z[name]
        filename, size, digest, *written = self._side[name]  # entries before times hold three
        side = self._folder / filename
        _check_side(side, int(size), digest, int(written[0]) if written else None)
        if side.suffix == ".npy":
            # (Tracked, so a process over a large library can hand its
            # pages back: mapped_pages.)
            return mapped_pages.track(np.load(side, mmap_mode="r", allow_pickle=False))
        return side


def _check_side(path: Path, size: int, digest: str, written_ns: int | None = None) -> None:
    """Raise ValueError unless ``path`` has ``size`` bytes and the BLAKE2b
    ``digest``: read through once per process and file version, unless its
    modification time is still ``written_ns`` (the file as it was written
    and named in its entry)."""
    st = path.stat()
    if st.st_size != size:
        raise ValueError(f"{path} has {st.st_size} bytes, its entry says {size}")
    if written_ns is not None and st.st_mtime_ns == written_ns:
        return
    seen = (str(path), st.st_size, st.st_mtime_ns, digest)
    with _CHECKED_LOCK:
        if seen in _CHECKED:
            return
    h = hashlib.blake2b(digest_size=20)
    with open(path, "rb") as fh:
        while chunk := fh.read(1 << 22):
            h.update(chunk)
    if h.hexdigest() != digest:
        raise ValueError(f"{path} is not the file its entry names (damaged or replaced)")
    with _CHECKED_LOCK:
        _CHECKED.add(seen)


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
    # The mask unpacked: a large one is then mapped, not unpacked into memory.
    arrays = {"key": np.array(key), "shape": np.array(strong.shape), "strong_mask": np.asarray(strong, bool),
              "relief": np.array(relief)}
    for graph in (features.ridges, features.valleys):
        arrays.update(_graph_arrays(graph))
    for kind in _KINDS:
        arrays.update(_sample_arrays(kind, samples[kind]))
    _write(path, arrays)


def _write(path: Path, arrays: dict) -> None:
    """Save ``arrays`` (with their ``"key"``) as the entry ``path``: large
    arrays and raw bytes as side files first, each atomically, then the
    ``.npz`` naming them, so an entry is whole or absent."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        inside, sides = {}, {}
        for name, value in arrays.items():
            if isinstance(value, (bytes, bytearray, memoryview)):
                sides[name] = _write_side(_side_path(path, name, ".bin"), bytes(value))
            elif isinstance(value, np.ndarray) and value.nbytes >= SIDE_BYTES and name != "key":
                sides[name] = _write_side(_side_path(path, name, ".npy"), _npy_bytes(value))
            else:
                inside[name] = value
        if sides:
            inside["sides"] = np.array(json.dumps(sides))
        with atomic_outputs(path) as (tmp,), open_new(tmp) as f:
            np.savez(f, **inside)
    except OSError:
        return
    cache_size.written(path.parent)


def _npy_bytes(array: np.ndarray) -> bytes:
    import io

    buffer = io.BytesIO()
    np.save(buffer, np.ascontiguousarray(array), allow_pickle=False)
    return buffer.getvalue()


def _write_side(path: Path, data: bytes) -> list:
    """Write a side file atomically; its (name, size, digest, modification
    time in ns) for the entry."""
    with atomic_outputs(path) as (tmp,), open_new(tmp) as f:
        f.write(data)
    return [path.name, len(data), hashlib.blake2b(data, digest_size=20).hexdigest(), path.stat().st_mtime_ns]


def load_array(key: str) -> np.ndarray | None:
    """A cached float32 grid (an example resampled to a cell size, a detail
    band) or None; mapped read-only from its file when it is large."""
    heights = _read(key, lambda z: z["heights"])
    return heights if heights is not None and heights.ndim == 2 and heights.dtype == np.float32 else None


def save_array(key: str, heights: np.ndarray) -> None:
    """Store a float32 grid; failures are ignored, as for analyses."""
    path = _path(key)
    if path is not None:
        _write(path, {"key": np.array(key), "heights": np.ascontiguousarray(heights, dtype=np.float32)})


def load_arrays(key: str) -> dict | None:
    """Every array of the file saved under ``key`` (by :func:`save_arrays`),
    or None; large ones mapped, raw bytes given as the path of their file."""
    return _read(key, lambda z: {name: z[name] for name in z.files if name != "key"})


def save_arrays(key: str, arrays: dict) -> None:
    """Store named arrays (a fill-search index) and raw bytes (``bytes``
    values: its faiss index, kept as a file of its own); failures are
    ignored, as for analyses."""
    path = _path(key)
    if path is not None:
        _write(path, {**arrays, "key": np.array(key)})


def kept_array(key: str, make: Callable[[], np.ndarray], *, name: str = "heights",
               dtype: type = np.float32) -> np.ndarray:
    """``make()``'s array, made once: read from the file saved under
    ``key`` when it holds one of ``dtype`` (mapped, read-only), else made,
    stored and read back mapped, so that a process holds file pages the
    system can drop rather than its own copy; the array made when the
    cache is off or the write fails.  ``key`` names everything the array
    depends on, its shape included.

    Parameters
    ----------
    key : str
    make : callable
        Gives the array.
    name : str
        Its name in the file (``"heights"``, as :func:`save_array` names
        its grids).
    dtype : numpy dtype
        What the array is (a file of another, from an older version, is
        made again).
    """

    def read() -> np.ndarray | None:
        got = load_arrays(key)
        stored = None if got is None else got.get(name)
        return stored if isinstance(stored, np.ndarray) and stored.dtype == dtype else None

    stored = read()
    if stored is not None:
        return stored
    made = np.asarray(make(), dtype=dtype)
    save_arrays(key, {name: made})
    stored = read()
    return stored if stored is not None and stored.shape == made.shape else made


def _graph_arrays(graph: FeatureGraph) -> dict:
    k = graph.kind
    pts = graph.path_points()
    return {
        f"{k}_nodes": graph.node_positions(),
        f"{k}_node_branch": np.array([n.type == "branch" for n in graph.nodes], dtype=bool),
        f"{k}_node_degree": np.array([n.degree for n in graph.nodes], dtype=np.int32),
        f"{k}_ends": graph.path_ends(),
        f"{k}_counts": np.array([len(p) for p in pts], dtype=np.int64),
        f"{k}_points": np.concatenate(pts) if pts else np.zeros((0, 2)),
    }


def _graph_from(z, kind: str, shape) -> FeatureGraph:
    """The stored graph as tables over the (possibly mapped) arrays: no
    object per node or path is made until one is asked for."""
    nodes = NodeTable(z[f"{kind}_nodes"], z[f"{kind}_node_branch"], z[f"{kind}_node_degree"])
    paths = PathTable(z[f"{kind}_ends"], z[f"{kind}_counts"], z[f"{kind}_points"])
    return FeatureGraph(kind, shape, nodes, paths)


def _sample_arrays(kind: str, samples: list[FeatureSample]) -> dict:
    table = SampleTable.of(samples, kind)
    return {f"{kind}_s_centers": table.centers, f"{kind}_s_degree": table.degrees,
            f"{kind}_s_crossings": table.crossings}


def _samples_from(z, kind: str) -> SampleTable:
    return SampleTable(kind, z[f"{kind}_s_centers"], z[f"{kind}_s_degree"], z[f"{kind}_s_crossings"])
