"""A tiled run's tasks as a Dask worker runs them: the memory a task freed
is handed back to the system before the next one starts.

A worker runs its tasks on a thread of its own, whose allocations glibc
serves from an arena of its own; memory a tile's session frees in the
middle of that arena stays with the process (the allocator keeps it for
later) unless it is trimmed.  Measured on a 1024x1024 run in 512-cell
tiles over 20 example DEMs, the worker that ran the tiles kept 143 MB
between tiles untrimmed and 128 MB trimmed, and peaked at 178-182 MB
against 165 MB (``benchmarks/bench_tiled.py --library``; the README's
World-size section).
"""

from __future__ import annotations

import ctypes
import functools
import os

__all__ = ["run_task", "release_freed_memory", "malloc_trim_threshold"]


def run_task(fn, *args):
    """``fn(*args)``, then :func:`release_freed_memory`."""
    try:
        return fn(*args)
    finally:
        release_freed_memory()


def release_freed_memory() -> None:
    """Hand the pages the allocator holds free back to the system
    (glibc's ``malloc_trim``); nothing where the C library has none."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


@functools.cache
def _malloc_trim():
    # The C library the process already has (no search for it: that runs
    # ldconfig in a subprocess, from a worker's threads).
    try:
        return ctypes.CDLL(None).malloc_trim
    except (OSError, AttributeError, TypeError):  # not glibc (macOS, musl, Windows): nothing to trim
        return None


def malloc_trim_threshold() -> str | None:
    """This process's ``MALLOC_TRIM_THRESHOLD_``, if set: Dask sets it to
    64 kB for the workers its nannies start, which made a tile's session
    1.8-2x as long (it also fixes glibc's mmap threshold, so numpy's larger
    temporaries are mapped afresh and faulted in each time)."""
    return os.environ.get("MALLOC_TRIM_THRESHOLD_")
