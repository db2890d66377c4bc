"""An approximate-nearest-neighbour index of an example's windows by their
boundary zone, so a fill search costs about the same whatever the example's
area (Liang et al. 2001).

A fill window is matched on the terrain already around it, which lies in
its boundary zone: the top, bottom, left and right strips of the overlap
width.  The filled strips make one of 15 *zones* (a bit per side,
:func:`zone_of`), and each zone gets its own index, built the first time a
run asks for it.  Each example window is described over the zone on a
coarse grid (block means ``step`` cells wide), with its mean removed (the
match ignores a height offset), and the description is split into its
direction and its size:

``[PCA(d / |d|), ln(rms(d)), sqrt(2 * ROUGHNESS_WEIGHT * prior)]``

For a query ``[PCA(t / |t|), ln(rms(t)), 0]``, half the squared distance is
``1 - cos + ln(rms_e / rms_t)**2 / 2 + ROUGHNESS_WEIGHT * prior``, which is,
to second order near a good match, the fill search's own score (the
offset-free SSD over the two windows' variances, ``1 - cos / cosh(ln(rms_e
/ rms_t))``, plus the roughness prior).  So the nearest neighbours are the
windows the exact score ranks first, up to the PCA truncation and the coarse
grid, and a generous shortlist re-ranked exactly (:class:`FillSearch`) finds
the exact best in nearly every case.

A query describes the output window the same way; a coarse cell of its zone
with no terrain yet counts as the zone's mean.

The index is faiss's inverted file (``IndexIVFFlat``, chosen by measurement
over HNSW, scipy's cKDTree and pynndescent: see README, "Dependencies, and
why"): about ``sqrt(n)`` k-means cells, :data:`NPROBE` of them visited per
query, so a query scans ``NPROBE * sqrt(n)`` short vectors, well under a
millisecond even for a library four times the White Mountains; the exact
re-ranking of the fixed-size shortlist is most of a query's cost.  faiss
runs on one thread with a fixed k-means seed, so a build is deterministic
and a run's output does not depend on timing or the machine's cores.

References
----------
Liang, L., Liu, C., Xu, Y.-Q., Guo, B., Shum, H.-Y. (2001). Real-time texture
synthesis by patch-based sampling. ACM Transactions on Graphics 20(3).
"""

from __future__ import annotations

import hashlib
import os
import threading
from functools import partial
from typing import Callable

import numpy as np

from ..exemplars import mapped_pages
from ..memo import Memo
from .costs import ROUGHNESS_WEIGHT

#: Bump when descriptors, index parameters or their storage change, so
#: stored indexes are rebuilt (2: the faiss index in a file of its own,
#: mapped; 3: built with faiss's portable kernels, :func:`faiss_module`).
INDEX_VERSION = 3

_faiss_lock = threading.Lock()
_faiss_pinned = False


def faiss_module():
    """faiss, its distance kernels pinned to the portable ones (once per process).

    faiss chooses its SIMD kernels at run time by the CPU (AVX2, AVX-512...),
    and kernels of different widths add a distance's terms in different
    orders: the k-means that builds an index, and the distances a query
    ranks by, then differ in their last bits, enough to change a
    shortlist's ties and so the terrain.  On this machine 3 of the 11 cases
    of ``scripts/digests.py`` gave other bytes with faiss on AVX2 than on
    AVX-512.  The portable kernels give every x86-64 machine the same
    numbers (a cluster of mixed machines, a user repeating a seed), at no
    cost to the queries (4.9-5.1 ms against 5.8-5.9 ms,
    ``benchmarks/bench_fill_search.py``; an index takes 1.2x as long to
    build, once per example).
    """
    global _faiss_pinned
    import faiss

    if not _faiss_pinned:
        with _faiss_lock:
            if not _faiss_pinned:
                faiss.SIMDConfig.set_level(faiss.SIMDLevel_NONE)
                _faiss_pinned = True
    return faiss


#: PCA dimensions of a zone's direction (Liang et al. keep a few dozen).
PCA_DIMS = 24
#: Coarse cells across a window side in the descriptor.
GRID_CELLS = 16
#: Windows the PCA is fitted on (evenly spread over the example).
PCA_SAMPLE = 8_000
#: Inverted lists visited per query.
NPROBE = 32

_TOP, _BOTTOM, _LEFT, _RIGHT = 1, 2, 4, 8
#: Every zone (see :func:`zone_of`), those with more sides filled first:
#: the order a live stroke's crop, a hole in kept terrain, most needs them
#: (though its first windows may hold terrain on one side only).
ZONES_BY_SIDES = tuple(sorted(range(1, 16), key=lambda zone: (-bin(zone).count("1"), zone)))


def zone_of(filled: np.ndarray, overlap: int) -> int:
    """The zone a partly filled window is matched on.

    Parameters
    ----------
    filled : ndarray of bool, shape (h, w)
    overlap : int
        Strip width, cells.

    Returns
    -------
    int
        A bit per side (1 top, 2 bottom, 4 left, 8 right) whose strip is at
        least half filled; when none is, the fullest strip alone, so every
        window with terrain in it has a zone (1 to 15).
    """
    strips = (filled[:overlap], filled[-overlap:], filled[:, :overlap], filled[:, -overlap:])
    share = np.array([s.mean() for s in strips])
    bits = np.array([_TOP, _BOTTOM, _LEFT, _RIGHT])
    zone = int(bits[share >= 0.5].sum())
    return zone or int(bits[int(np.argmax(share))])


def zone_cells(window: tuple[int, int], overlap: int, zone: int, step: int) -> np.ndarray:
    """The coarse cells of a zone.

    Parameters
    ----------
    window : (h, w)
    overlap : int
        Strip width, cells.
    zone : int
        1 to 15 (see :func:`zone_of`).
    step : int
        Coarse cell side, cells.

    Returns
    -------
    ndarray of int, shape (n, 2)
        (row, col) of each coarse cell whose centre lies in the zone, in
        coarse units (cell ``(i, j)`` covers rows ``i*step`` to
        ``(i+1)*step - 1``).
    """
    h, w = window
    gi = np.arange(h // step)
    gj = np.arange(w // step)
    ci = gi * step + (step - 1) / 2
    cj = gj * step + (step - 1) / 2
    rows = np.zeros((gi.size, gj.size), bool)
    if zone & _TOP:
        rows |= (ci < overlap)[:, None]
    if zone & _BOTTOM:
        rows |= (ci >= h - overlap)[:, None]
    if zone & _LEFT:
        rows |= (cj < overlap)[None, :]
    if zone & _RIGHT:
        rows |= (cj >= w - overlap)[None, :]
    return np.argwhere(rows)


def descriptor_step(window: tuple[int, int]) -> int:
    """Coarse cell side for a window: about :data:`GRID_CELLS` cells across."""
    return max(1, round(min(window) / GRID_CELLS))


def block_means(heights: np.ndarray, step: int) -> np.ndarray:
    """Mean of the ``step`` x ``step`` block whose top-left corner is each cell.

    Parameters
    ----------
    heights : ndarray of float32, shape (H, W)
    step : int

    Returns
    -------
    ndarray of float32, shape (H - step + 1, W - step + 1)
    """
    if step == 1:
        return np.asarray(heights, dtype=np.float32)
    # A summed-area table: exact block sums, O(1) per block.
    sat = np.pad(heights.astype(np.float64).cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    s = step
    sums = sat[s:, s:] - sat[:-s, s:] - sat[s:, :-s] + sat[:-s, :-s]
    return (sums / (s * s)).astype(np.float32)


def _direction_and_size(d: np.ndarray, floor: float) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``d`` (already mean-free) as unit vectors and their log rms."""
    norm = np.sqrt(np.einsum("ij,ij->i", d, d, dtype=np.float64))
    rms = norm / np.sqrt(d.shape[1])
    unit = d / np.maximum(norm, floor * np.sqrt(d.shape[1]))[:, None]
    return unit.astype(np.float32), np.log(rms + floor).astype(np.float32)


class ZoneIndex:
    """The windows of one example for one zone, searchable by their zone
    terrain.

    Built by :func:`build_zone_index` or restored by :meth:`from_arrays`.

    Attributes
    ----------
    positions : ndarray of int32, shape (n, 2)
        Top-left corners of the indexed windows, cells.
    """

    def __init__(self, *, cells: np.ndarray, step: int, floor: float, pca_mean: np.ndarray,
                 pca_axes: np.ndarray, positions: np.ndarray, index=None, path: str | None = None):
        self.cells, self.step, self.floor = cells, step, floor
        self.pca_mean, self.pca_axes = pca_mean, pca_axes
        self.positions = positions
        self._index = index  # the faiss index in memory (built, or read from bytes) ...
        # ... or the file it is stored in, opened through _OPEN: the file
        # as it was read (_file_identity).
        self._stored = None if path is None else _file_identity(path)
        if self._stored is not None:
            _OPEN.get(self._stored, self._reopen)  # (a damaged file raises here)
        #: Gives the index again once its file is gone (set by LazyIndexes).
        self._remake: Callable[[], ZoneIndex] | None = None

    def _faiss(self):
        """The faiss index: this one's own, or its stored file's, opened
        (mapped) through the process's few open indexes (:data:`OPEN_INDEXES`).
        Should the file have gone or been replaced since (another worker
        stored the same index again, the cache was cleared during a run),
        ``remake`` gives it again: read from the cache entry as it is now
        (checked against its digest), or made and kept in memory."""
        if self._index is not None:
            return self._index
        try:
            return _OPEN.get(self._stored, self._reopen)
        except (OSError, RuntimeError, ValueError):
            if self._remake is None:
                raise
        again = self._remake()
        if again._stored is None:
            self._index = again._index
            return self._index
        self._stored = again._stored
        return _OPEN.get(self._stored, self._reopen)  # (opened by that read)

    def _reopen(self):
        path = self._stored[0]
        if _file_identity(path) != self._stored:
            raise ValueError(f"{path} is not the file this index was read from")
        index = _open_stored(path)
        if _file_identity(path) != self._stored:  # (replaced while it was being read)
            raise ValueError(f"{path} was replaced while it was read")
        return index

    def query(self, target: np.ndarray, filled: np.ndarray, count: int) -> np.ndarray:
        """Indexed windows nearest to a partly filled output window.

        Parameters
        ----------
        target : ndarray of float, shape (h, w)
            Output heights, read where ``filled``.
        filled : ndarray of bool, shape (h, w)
        count : int
            Shortlist length.

        Returns
        -------
        ndarray of int32, shape (m, 2), m <= count
            Top-left corners of the shortlisted windows, nearest first.
        """
        return self.search(self.query_vector(target, filled), count)

    def search(self, vector: np.ndarray, count: int, *,
               distances: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """:meth:`query` for a window's vector (:meth:`query_vector`), when
        the caller has it already; with ``distances`` also each window's
        squared distance in the index (ndarray of float32, shape (m,); half
        of it approximates the search's score, see the module notes)."""
        _single_thread()
        k = min(count, self.positions.shape[0])
        index = self._faiss()
        dist, ids = index.search(vector, k)
        found = ids[0] >= 0
        if found.sum() < k and index.nprobe < index.nlist:
            # The probed lists held fewer windows than asked: an example
            # whose windows are all alike (a flat DEM) has k-means centres
            # that tie, most of their lists empty, and a query probing those
            # found nothing at all.  Every list, then.
            dist, ids = index.search(vector, k, params=faiss_module().SearchParametersIVF(nprobe=index.nlist))
            found = ids[0] >= 0
        if distances:
            return self.positions[ids[0][found]], dist[0][found]
        return self.positions[ids[0][found]]

    def cluster_distance(self, vector: np.ndarray) -> float:
        """Squared distance from a window's vector (:meth:`query_vector`)
        to the nearest of the index's k-means centres: how near its windows
        come, roughly.  The centres are a few kB of each index
        (:meth:`search` reads ``NPROBE`` lists besides)."""
        _single_thread()
        # (The index is held here: faiss's quantizer does not keep its index
        # alive, and another thread may close it meanwhile, mapped_pages.)
        index = self._faiss()
        dist, _ = index.quantizer.search(vector, 1)
        return float(dist[0, 0])

    def query_vector(self, target: np.ndarray, filled: np.ndarray) -> np.ndarray:
        """The index vector of an output window, shape (1, PCA_DIMS + 2),
        float32 (its roughness coordinate 0: the prior is the example
        window's alone)."""
        s = self.step
        h, w = filled.shape
        gh, gw = h // s, w // s
        m = filled[:gh * s, :gw * s].reshape(gh, s, gw, s).sum(axis=(1, 3)).astype(np.float64)
        v = np.where(filled, target, 0.0)[:gh * s, :gw * s].reshape(gh, s, gw, s).sum(axis=(1, 3))
        ci, cj = self.cells[:, 0], self.cells[:, 1]
        weight, total = m[ci, cj], v[ci, cj]
        # A coarse cell with no terrain yet counts as the zone's mean (0
        # once the mean is removed); the size is measured on cells with terrain.
        have = weight > 0
        means = np.where(have, total / np.where(have, weight, 1.0), 0.0)
        mean = float(means[have].mean()) if have.any() else 0.0
        d = np.where(have, means - mean, 0.0)[None, :]
        rms = float(np.sqrt((d[0, have] ** 2).mean())) if have.any() else 0.0
        unit = d / max(rms * np.sqrt(d.shape[1]), self.floor * np.sqrt(d.shape[1]))
        vec = np.empty((1, self.pca_axes.shape[1] + 2), np.float32)
        vec[0, :-2] = (unit - self.pca_mean) @ self.pca_axes
        vec[0, -2] = np.log(rms + self.floor)
        vec[0, -1] = 0.0
        return vec

    def to_arrays(self) -> dict:
        """Everything needed to restore the index: plain arrays, and the
        faiss index serialised as ``bytes`` (the disk cache keeps those as
        a file of their own, which :meth:`from_arrays` maps)."""
        faiss = faiss_module()

        return {"cells": self.cells, "step": np.array(self.step), "floor": np.array(self.floor),
                "pca_mean": self.pca_mean, "pca_axes": self.pca_axes, "positions": self.positions,
                "index": faiss.serialize_index(self._faiss()).tobytes()}

    @classmethod
    def from_arrays(cls, z) -> ZoneIndex:
        """The inverse of :meth:`to_arrays` (``z`` maps names to arrays).

        ``z["index"]`` may be the serialised index (bytes or an array of
        uint8: read into memory) or the path of a file holding it, as the
        disk cache gives it: then the index is memory-mapped
        (:func:`_open_stored`), opened now (a damaged file raises here) and
        again whenever it is asked for after being closed.
        """
        faiss = faiss_module()

        stored = z["index"]
        index = path = None
        if isinstance(stored, (str, os.PathLike)):
            path = os.fspath(stored)
        else:
            index = faiss.deserialize_index(np.frombuffer(stored, np.uint8) if isinstance(stored, bytes)
                                            else np.asarray(stored))
            index.nprobe = min(NPROBE, index.nlist)  # (as _open_stored)
        return cls(cells=np.asarray(z["cells"]), step=int(z["step"]), floor=float(z["floor"]),
                   pca_mean=np.asarray(z["pca_mean"]), pca_axes=np.asarray(z["pca_axes"]),
                   positions=np.asarray(z["positions"]), index=index, path=path)


#: Stored zone indexes open at once in a process.  An open index holds
#: its k-means centroids and list headers in memory (about 90 kB for a
#: 1201x1201 example at 80-cell windows); its vectors stay file pages.  A
#: fill window asks every example of its style, so open indexes grew with
#: the library; past this many, the least recently used is closed, and
#: opened again when asked (0.2 ms, against 1.3 ms for the whole stored
#: entry).  A 512x512 session opens 9 zones an example: 18 on two DEMs,
#: none closed; on 20, 180 zones opened 440-460 times, 0.1 s of 11-20 s.
OPEN_INDEXES = 64

_OPEN = Memo(OPEN_INDEXES)


def _close_open_indexes() -> None:
    """Close every open stored index (each is opened again when asked)."""
    _OPEN.clear()


# Closed with the cache's other mappings when a process holds too many of
# their pages (an open index keeps the pages of its lists it has read).
mapped_pages.on_release(_close_open_indexes)


def _file_identity(path: str) -> tuple:
    """A file as it is now (path, device, inode, size, modification time):
    the cache replaces an entry's files by renaming new ones onto them."""
    st = os.stat(path)
    return path, st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns


def _open_stored(path: str):
    """The faiss index stored in the file ``path``, memory-mapped."""
    faiss = faiss_module()
    # Zero-copy mapping of the lists' arrays (IO_FLAG_MMAP_IFC): as
    # fast as in memory; IO_FLAG_MMAP's on-disk lists searched 15x slower.
    index = faiss.read_index(path, faiss.IO_FLAG_MMAP_IFC)
    # Set again, whatever the serialisation keeps: a loaded index must
    # answer as the one just built.
    index.nprobe = min(NPROBE, index.nlist)
    return index


def _single_thread() -> None:
    """One faiss thread: results must not depend on scheduling (and the
    synthesis keeps the machine's other core busy)."""
    faiss_module().omp_set_num_threads(1)


def build_zone_index(example: np.ndarray, window: tuple[int, int], overlap: int, zone: int,
                     positions: np.ndarray, prior: np.ndarray, *, blocks: np.ndarray | None = None) -> ZoneIndex:
    """Index an example's windows for one zone.

    Parameters
    ----------
    example : ndarray of float32, shape (H, W)
    window : (h, w)
    overlap : int
        Strip width, cells.
    zone : int
        1 to 15 (see :func:`zone_of`).
    positions : ndarray of int, shape (n, 2)
        Top-left corners of the windows on offer (each window must fit).
    prior : ndarray of float, shape (n,)
        Each window's roughness prior (added to its score).
    blocks : ndarray of float32, or None
        :func:`centred_blocks` of ``example`` for this window, when the
        caller keeps it for the example's other zones; None computes it.

    Returns
    -------
    ZoneIndex
    """
    parts, vectors = zone_vectors(example, window, overlap, zone, positions, prior, blocks=blocks)
    return ZoneIndex(**parts, positions=positions.astype(np.int32), index=ivf_index(vectors))


def centred_blocks(example: np.ndarray, window: tuple[int, int]) -> np.ndarray:
    """The coarse grid every zone's descriptors read: :func:`block_means`
    of ``example`` at the window's :func:`descriptor_step`, less their mean
    (so float32 keeps the detail of high terrain).

    Returns
    -------
    ndarray of float32, shape (H - step + 1, W - step + 1)
        The same for all 15 zones: :class:`LazyIndexes` makes it once.
    """
    blocks = block_means(example, descriptor_step(window))
    return blocks - np.float32(blocks.mean())


def zone_vectors(example: np.ndarray, window: tuple[int, int], overlap: int, zone: int,
                 positions: np.ndarray, prior: np.ndarray, *,
                 blocks: np.ndarray | None = None) -> tuple[dict, np.ndarray]:
    """The index vectors of an example's windows for one zone.

    Parameters are those of :func:`build_zone_index`.

    Returns
    -------
    parts : dict
        ``cells``, ``step``, ``floor``, ``pca_mean`` and ``pca_axes`` of
        the :class:`ZoneIndex` (what a query needs to describe a window).
    vectors : ndarray of float32, shape (n, PCA_DIMS + 2)
        Per window: the PCA projection of its zone's direction, its log
        rms, and ``sqrt(2 * ROUGHNESS_WEIGHT * prior)``.
    """
    step = descriptor_step(window)
    cells = zone_cells(window, overlap, zone, step)
    if blocks is None:
        blocks = centred_blocks(example, window)
    # Heights differences below a millimetre are noise: the floor keeps
    # flat windows' directions finite.
    floor = 1e-3
    flat = blocks.ravel()
    width = blocks.shape[1]
    flat_offsets = (cells[:, 0] * step) * width + cells[:, 1] * step
    n = positions.shape[0]

    def describe(rows) -> tuple[np.ndarray, np.ndarray]:
        p = positions[rows]
        unit = np.empty((p.shape[0], flat_offsets.size), np.float32)
        size = np.empty(p.shape[0], np.float32)
        # Row by row arithmetic, in slices of 2048 windows: each numpy call
        # holds the interpreter lock a few milliseconds at most, so the
        # app's event loop keeps turning while an index is built.
        for a in range(0, p.shape[0], 2048):
            q = p[a:a + 2048]
            d = flat[(q[:, :1] * width + q[:, 1:]) + flat_offsets[None, :]]
            d -= d.mean(axis=1, keepdims=True)
            unit[a:a + 2048], size[a:a + 2048] = _direction_and_size(d, floor)
        return unit, size

    # PCA of the directions, fitted on windows spread evenly over the example.
    sample = np.linspace(0, n - 1, min(n, PCA_SAMPLE)).astype(np.int64)
    unit, _ = describe(sample)
    pca_mean = unit.mean(axis=0, dtype=np.float64)
    centred = (unit - pca_mean).astype(np.float32)
    cov = (centred.T @ centred).astype(np.float64) / max(1, unit.shape[0] - 1)
    _, vecs = np.linalg.eigh(np.atleast_2d(cov))
    dims = min(PCA_DIMS, cells.shape[0])
    # eigh sorts ascending; a fixed sign per axis keeps stored indexes stable.
    axes = vecs[:, ::-1][:, :dims]
    axes *= np.where(axes[np.argmax(np.abs(axes), axis=0), np.arange(dims)] < 0, -1.0, 1.0)
    pca_mean = pca_mean.astype(np.float32)
    axes = np.ascontiguousarray(axes, dtype=np.float32)
    vectors = np.empty((n, dims + 2), np.float32)
    chunk = 16_384
    for a in range(0, n, chunk):
        unit, size = describe(slice(a, a + chunk))
        vectors[a:a + chunk, :dims] = (unit - pca_mean) @ axes
        vectors[a:a + chunk, dims] = size
    vectors[:, dims + 1] = np.sqrt(2.0 * ROUGHNESS_WEIGHT * np.asarray(prior, dtype=np.float64))
    return {"cells": cells, "step": step, "floor": floor, "pca_mean": pca_mean, "pca_axes": axes}, vectors


def ivf_index(vectors: np.ndarray):
    """A faiss inverted-file index of ``vectors`` (n, d) float32: about
    sqrt(n) k-means cells (fixed seed, one thread), :data:`NPROBE` visited
    per query."""
    faiss = faiss_module()

    _single_thread()
    n, d = vectors.shape
    nlist = int(np.clip(np.sqrt(n), 1, max(1, n // 39)))
    index = faiss.IndexIVFFlat(faiss.IndexFlatL2(d), d, nlist)
    index.cp.seed = 1234
    index.cp.niter = 10
    index.train(vectors[np.linspace(0, n - 1, min(n, 40 * nlist)).astype(np.int64)])
    index.add(vectors)
    index.nprobe = min(NPROBE, nlist)
    return index


def index_key(example: np.ndarray, window: tuple[int, int], overlap: int, positions: np.ndarray,
              prior: np.ndarray) -> str:
    """Cache key of an example's zone indexes (``-z<zone>`` is appended per
    zone): the digests of the example, the offered windows and their prior
    (a coordinate of every vector, with its weight), the window, overlap and
    :data:`INDEX_VERSION`."""
    h = hashlib.sha1(np.ascontiguousarray(example, dtype=np.float32).tobytes())
    h.update(np.ascontiguousarray(positions, dtype=np.int32).tobytes())
    h.update(np.ascontiguousarray(prior, dtype=np.float64).tobytes())
    h.update(repr((example.shape, tuple(window), int(overlap), float(ROUGHNESS_WEIGHT))).encode())
    return f"windows-v{INDEX_VERSION}-{h.hexdigest()}"


def _stored_or_built(load, key: str, *build_args) -> ZoneIndex:
    """The zone index stored under ``key`` as the cache holds it now, or,
    when it holds none, one built here (``build_args`` as for
    :func:`build_zone_index`)."""
    got = load(key) if load else None
    return got if got is not None else build_zone_index(*build_args)


class LazyIndexes:
    """The zone indexes of one example and window, each built (or loaded
    from the disk cache) the first time it is asked for; thread-safe: a
    caller waits only while the zone it asks for is being made (a live
    stroke's search runs beside the background preparation building the
    other zones, :meth:`make_all`)."""

    def __init__(self, example, window, overlap, positions, prior, *, load=None, save=None):
        self.example, self.window, self.overlap = example, window, overlap
        self.positions, self.prior = positions, prior
        self._load, self._save = load, save
        self._indexes: dict[int, ZoneIndex] = {}
        self._lock = threading.Lock()  # the shared parts: the key, the blocks, the zones' locks
        self._zone_locks: dict[int, threading.Lock] = {}
        self._base_key = None
        self._blocks = None  # centred_blocks, made by the first build

    def __getstate__(self) -> dict:
        # Sent to the fill's worker processes without the indexes built so
        # far (faiss objects do not pickle) or the locks: a worker loads each
        # index from the disk cache the first time it needs it.
        state = self.__dict__.copy()
        state["_indexes"] = {}
        state["_blocks"] = None
        del state["_lock"], state["_zone_locks"]
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()
        self._zone_locks = {}

    def get(self, zone: int) -> ZoneIndex:
        got = self._indexes.get(zone)
        if got is not None:
            return got
        with self._lock:
            zone_lock = self._zone_locks.setdefault(zone, threading.Lock())
        with zone_lock:
            got = self._indexes.get(zone)  # made while this caller waited
            if got is not None:
                return got
            key = f"{self._key()}-z{zone}"
            got = self._load(key) if self._load else None
            if got is None:
                got = self._build(zone)
                if self._save:
                    self._save(key, got)
                    # Read back mapped, as a later run would: the vectors
                    # just built leave this process's memory (a first run
                    # on a library builds every example's zones).
                    stored = self._load(key) if self._load else None
                    got = got if stored is None else stored
            # (From the inputs, not this object's blocks: no cycle through
            # the index back to this object.)
            got._remake = partial(_stored_or_built, self._load, key, self.example, self.window, self.overlap,
                                  zone, self.positions, self.prior)
            self._indexes[zone] = got
            return got

    def make_all(self, cancel: Callable[[], bool] | None = None) -> None:
        """Build (or load) every zone's index now, those with more sides
        filled first (:data:`ZONES_BY_SIDES`); ``cancel`` is asked before
        each and True stops there (the zones made so far are kept)."""
        for zone in ZONES_BY_SIDES:
            if cancel is not None and cancel():
                return
            self.get(zone)

    def _key(self) -> str:
        with self._lock:
            if self._base_key is None:
                self._base_key = index_key(self.example, self.window, self.overlap, self.positions, self.prior)
                # (That read the example's arrays whole: a first window of a
                # large library asks every example's, mapped_pages.)
                mapped_pages.keep_within_budget()
            return self._base_key

    def _build(self, zone: int) -> ZoneIndex:
        """The zone's index, built here (in memory)."""
        with self._lock:
            if self._blocks is None:
                self._blocks = centred_blocks(self.example, self.window)
            blocks = self._blocks
        return build_zone_index(self.example, self.window, self.overlap, zone, self.positions, self.prior,
                                blocks=blocks)
