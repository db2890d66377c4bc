"""The pages of the example cache's mapped files a process holds, kept
within a budget.

The cache maps its large arrays and the fill indexes (:mod:`.cache`), so a
process holds file pages, not copies of the examples.  But a page once
touched stays in the process's resident set until the mapping goes or the
kernel needs the memory, and the resident set is what Dask's memory
monitor (like ``ps`` and ``top``) counts.  A fill window reads pages of
many examples of its style, so a tiled run's worker over 20 DEMs came to
hold 1.4 GB resident where it held 0.57 GB over 2, its own (private)
memory 0.17 GB either way.

Past :data:`MAPPED_BUDGET` of file pages, :func:`keep_within_budget` hands
them back to the page cache: ``madvise(MADV_DONTNEED)`` on every mapped
array the cache gave (:func:`track`), and the releasers registered with
:func:`on_release` (the fill indexes close their open files).  Nothing is
lost: the next read of a page maps it again from the page cache (a minor
fault, no disk read while the machine has the memory).  The resident set
of a process that reads a large library then stays under about its
private memory plus the budget, however many examples there are.
"""

from __future__ import annotations

import mmap
import threading
import weakref
from typing import Callable, Iterable, Iterator, TypeVar

import numpy as np

#: Resident file-backed memory (bytes, the mapped cache files and the
#: process's shared libraries, about 70 MB of them) past which the mapped
#: pages are handed back.  A 512x512 session over two DEMs holds about
#: 400 MB of file pages, so it is never trimmed; over 20 it reaches 450 MB
#: in one session and 1.2 GB over a tiled run's tiles.
MAPPED_BUDGET = 512 * 2**20

_MAPS: weakref.WeakSet = weakref.WeakSet()  # the mmap objects of the tracked arrays
_RELEASERS: list[Callable[[], None]] = []
_LOCK = threading.Lock()
_CHECK = threading.Lock()  # one thread decides (and releases) at a time
_PAGE = mmap.PAGESIZE
_floor = 0  # file-backed resident bytes just after the last release

T = TypeVar("T")


def track(array: np.ndarray) -> np.ndarray:
    """``array``, its mapping tracked (a ``numpy.memmap`` of a file, as
    ``np.load(..., mmap_mode="r")`` gives); any other array is returned as
    it is.  The mapping is forgotten when its last array goes."""
    mapped = getattr(array, "_mmap", None)
    # (Read-only maps alone: advice on a copy-on-write one would drop its writes.)
    if isinstance(mapped, mmap.mmap) and getattr(array, "mode", None) == "r":
        with _LOCK:
            _MAPS.add(mapped)
    return array


def on_release(release: Callable[[], None]) -> None:
    """Have :func:`release` call ``release()`` too (a mapping the cache
    did not make: the fill indexes' files, which faiss maps)."""
    with _LOCK:
        _RELEASERS.append(release)


def release() -> None:
    """Hand every tracked mapping's pages back to the page cache, and call
    the registered releasers.  Safe while other threads read the arrays:
    a page read after this is mapped again, with the same bytes (the files
    are read only).  A releaser must be safe too: the fill indexes' closes
    an index another thread may hold, which that thread keeps open until
    it lets it go."""
    with _LOCK:
        maps, releasers = list(_MAPS), list(_RELEASERS)
    advise = getattr(mmap, "MADV_DONTNEED", None)
    for mapped in maps:
        if advise is not None and not mapped.closed:
            try:
                mapped.madvise(advise)
            except (OSError, ValueError):  # closed meanwhile, or a platform without it
                pass
    for fn in releasers:
        fn()


def file_resident() -> int | None:
    """This process's resident file-backed memory (and shared memory),
    bytes, from ``/proc/self/statm``; None where there is no such file
    (not Linux)."""
    try:
        with open("/proc/self/statm", "rb") as f:
            fields = f.read().split()
    except OSError:
        return None
    return int(fields[2]) * _PAGE


def keep_within_budget(budget: int | None = None) -> bool:
    """:func:`release` if the file-backed resident memory is past
    ``budget`` (bytes; :data:`MAPPED_BUDGET` unless given).  A read of
    ``/proc`` (about 10 microseconds) when within it; nothing while
    another thread checks (its release would serve both).

    Returns
    -------
    bool
        Whether the pages were released.
    """
    global _floor
    if not _CHECK.acquire(blocking=False):
        return False
    try:
        used = file_resident()
        limit = MAPPED_BUDGET if budget is None else budget
        # Pages a release cannot hand back (the libraries', other mappings')
        # raise the mark, so they do not make every call release again.
        if used is None or used <= max(limit, _floor + limit // 2):
            return False
        release()
        _floor = file_resident() or 0
        return True
    finally:
        _CHECK.release()


def checked(items: Iterable[T]) -> Iterator[T]:
    """``items``, with :func:`keep_within_budget` after each: for a loop
    that reads every example of a library whole (a session's set-up, the
    landform fit), whose pages would otherwise pile up with the library's
    size between two checks."""
    for item in items:
        yield item
        keep_within_budget()
