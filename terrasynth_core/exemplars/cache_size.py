"""The disk cache kept within a size: its least recently used entries go.

Every example a user tries leaves its analyses, resampled grids, detail
bands and fill indexes in the cache (:mod:`.cache`): for a 1201x1201 DEM
a few hundred MB, most of it fill-search zone indexes of 15 MB each.
Without a limit the folder only grows (a library of DEMs tried over months
filled 19 GB).  After an entry is written, at most once a minute in a
process, the folder is scanned and, when over :func:`cache_limit`, whole
entries are removed, least recently used first, down to four fifths of
it.  An entry is used when it is read (:func:`mark_used` sets its ``.npz``
file's modification time; its side files' times are their checks' and are
never touched) or written.

Only the cache's own files are counted and removed (named as
:data:`ENTRY_PREFIX` says): ``TERRASYNTH_CACHE_DIR`` may name a folder that
holds the user's files too.  Nothing used in the last
:data:`KEEP_RECENT_S` seconds is removed: a run may still read it.  Removing an entry another process has mapped is safe
(the mapping keeps the file's data until it is closed); a reader that then
asks for the entry finds none and makes it again, as after any miss.  An
entry goes ``.npz`` first, so a reader never finds an entry whose side
files are gone without it noticing (the ``.npz`` names them).  Side files
without an entry (an entry being written lays them first; a crash can
leave them) and unfinished temporary files are removed once older than
:data:`KEEP_RECENT_S`.
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

#: How the cache's files are named (:func:`.cache._path`); no other file is touched.
ENTRY_PREFIX = "example-v"
#: Default most bytes the cache keeps; ``TERRASYNTH_CACHE_MAX_GB`` sets another.
DEFAULT_LIMIT_BYTES = 4 * 2**30
#: A file used (or written) this recently, in seconds, is never removed.
KEEP_RECENT_S = 600.0
#: Shortest time between two scans of the folder in one process, seconds.
SCAN_EVERY_S = 60.0
#: Removal goes down to this share of the limit, so the next entries
#: written do not start a removal each.
AFTER_REMOVAL = 0.8

_last_scan = float("-inf")
_scan_lock = threading.Lock()


def cache_limit() -> int:
    """Most bytes the cache keeps: ``TERRASYNTH_CACHE_MAX_GB`` (GiB, a
    positive number), else :data:`DEFAULT_LIMIT_BYTES` (also for a value
    that is not a positive number: the cache never stops a run)."""
    try:
        gib = float(os.environ.get("TERRASYNTH_CACHE_MAX_GB", ""))
    except ValueError:
        return DEFAULT_LIMIT_BYTES
    return int(gib * 2**30) if gib > 0 and gib != float("inf") else DEFAULT_LIMIT_BYTES


def mark_used(entry: Path) -> None:
    """Record that the entry ``entry`` (its ``.npz``) was read now; best
    effort, and at most once per :data:`KEEP_RECENT_S` / 10 per entry."""
    try:
        if time.time() - entry.stat().st_mtime > KEEP_RECENT_S / 10:
            os.utime(entry)
    except OSError:
        pass


def written(folder: Path) -> None:
    """An entry was written to ``folder``: keep it within the limit, unless
    this process scanned it less than :data:`SCAN_EVERY_S` ago."""
    global _last_scan
    with _scan_lock:
        now = time.monotonic()
        if now - _last_scan < SCAN_EVERY_S:
            return
        _last_scan = now
    keep_within(folder, cache_limit())


def keep_within(folder: Path, limit: int, *, now: float | None = None) -> int:
    """Remove whole entries of the cache ``folder``, least recently used
    first, until it holds at most ``AFTER_REMOVAL * limit`` bytes, when it
    holds more than ``limit``.  Best effort: a file that cannot be read or
    removed is passed over.

    Parameters
    ----------
    folder : Path
    limit : int
        Bytes.
    now : float, optional
        The time (``time.time()``) files are aged against.

    Returns
    -------
    int
        Bytes removed.
    """
    now = time.time() if now is None else now
    try:
        files = [(e.name, e.stat()) for e in os.scandir(folder)
                 if _ours(e.name) and e.is_file(follow_symlinks=False)]
    except OSError:
        return 0
    total = sum(st.st_size for _, st in files)
    if total <= limit:
        return 0
    stems = {name[:-4]: st for name, st in files if name.endswith(".npz") and not name.startswith(".")}
    entries: dict[str, list[tuple[str, int]]] = {stem: [(stem + ".npz", st.st_size)] for stem, st in stems.items()}
    loose = []  # side files without an entry, unfinished temporary files
    for name, st in files:
        if name.endswith(".npz") and name[:-4] in stems:
            continue
        stem = _entry_of(name, stems)
        if stem is None:
            loose.append((st.st_mtime, name, st.st_size))
        else:
            entries[stem].append((name, st.st_size))
    old = now - KEEP_RECENT_S
    # Loose files first, then entries by when they were last used.
    queue = [(mtime, [(name, size)]) for mtime, name, size in sorted(loose) if mtime < old]
    queue += sorted((stems[stem].st_mtime, entries[stem]) for stem in stems if stems[stem].st_mtime < old)
    removed = 0
    goal = AFTER_REMOVAL * limit
    for _, members in queue:
        if total - removed <= goal:
            break
        for name, size in members:  # the .npz first: the entry is gone before its side files
            try:
                (folder / name).unlink()
                removed += size
            except OSError:
                pass
    return removed


def _ours(name: str) -> bool:
    """Whether the file ``name`` is one the cache writes (an entry, a side
    file, an unfinished temporary): the folder may be one the user chose
    and share with files of their own, which are never counted or removed."""
    return name.startswith(ENTRY_PREFIX) or (name.startswith("." + ENTRY_PREFIX) and name.endswith(".tmp"))


def _entry_of(name: str, stems) -> str | None:
    """The entry (stem) whose side file ``name`` is (``{stem}.{member}{suffix}``;
    a stem may hold dots itself, so the longest stem that fits), or None."""
    cut = name.rfind(".")
    while cut > 0:
        cut = name.rfind(".", 0, cut)
        if cut > 0 and name[:cut] in stems:
            return name[:cut]
    return None
