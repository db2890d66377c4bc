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
never touched) or written (its newest file's time).

Only the cache's own files are counted and removed (:data:`_ENTRY`,
:data:`_SIDE`, :data:`_UNFINISHED`): ``TERRASYNTH_CACHE_DIR`` may name a
folder that holds the user's files too.  No file used or written in the
last :data:`KEEP_RECENT_S` seconds is removed, nor any entry holding one: a
run may still read it, or a writer be laying it (side files first, the
``.npz`` last).  A file is looked at again just before it goes, and an
entry whose ``.npz`` changed since the scan (used, rewritten) or cannot be
removed (open elsewhere, on Windows) is left whole.  Removing an entry
another process has mapped is safe on POSIX (the mapping keeps the file's
data until it is closed); a reader that then asks for the entry finds none
and makes it again, as after any miss.  Side files without an entry (a
crash can leave them) and unfinished temporary files go once old.
"""

from __future__ import annotations

import contextlib
import os
import re
import threading
import time
from pathlib import Path

#: Default most bytes the cache keeps; ``TERRASYNTH_CACHE_MAX_GB`` sets
#: another.  A library of 20 DEMs uses a few GB during a tiled run.
DEFAULT_LIMIT_BYTES = 16 * 2**30
#: A file used (or written) this recently, in seconds, is never removed: a
#: long tiled run reads its examples' entries throughout.
KEEP_RECENT_S = 3600.0
#: Shortest time between two scans of the folder in one process, seconds.
SCAN_EVERY_S = 60.0
#: Removal goes down to this share of the limit, so the next entries
#: written do not start a removal each.
AFTER_REMOVAL = 0.8
#: The names the cache writes (:func:`.cache._path`, :func:`.cache._side_path`,
#: :func:`~terrasynth_core.io._common.atomic_outputs`); no other file is touched.
_ENTRY = re.compile(r"example-v\d+-.+\.npz")
_SIDE = re.compile(r"example-v\d+-.+\.[^.]+\.(npy|bin)")
_UNFINISHED = re.compile(r"\.example-v\d+-.+\.[0-9a-f]{12}\.tmp")

_last_scan = float("-inf")
_scan_lock = threading.Lock()


def cache_limit() -> int:
    """Most bytes the cache keeps: ``TERRASYNTH_CACHE_MAX_GB`` (GiB, a
    positive number; at most a million), else :data:`DEFAULT_LIMIT_BYTES`
    (also for anything else: the cache never stops a run)."""
    try:
        gib = float(os.environ.get("TERRASYNTH_CACHE_MAX_GB", ""))
    except ValueError:
        return DEFAULT_LIMIT_BYTES
    return int(min(gib, 1e6) * 2**30) if gib > 0 else DEFAULT_LIMIT_BYTES  # (NaN > 0 is False)


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
    this process scanned it less than :data:`SCAN_EVERY_S` ago.  Never
    raises (the cache never stops a run)."""
    global _last_scan
    with _scan_lock:
        now = time.monotonic()
        if now - _last_scan < SCAN_EVERY_S:
            return
        _last_scan = now
    try:
        with _pruning(folder) as mine:
            if mine:
                keep_within(folder, cache_limit())
    except Exception:  # best effort: a cache too big is better than a failed run
        pass


@contextlib.contextmanager
def _pruning(folder: Path):
    """True when this process holds the folder's pruning lock (an advisory
    lock on ``.prune.lock``), False when another holds it: two processes
    pruning from listings made at different moments removed twice what
    was needed (a tiled run's workers took a 19 GB cache to 8.6 GB)."""
    try:
        import fcntl
    except ImportError:  # (Windows: no advisory locks here; prune anyway)
        yield True
        return
    with open(folder / ".prune.lock", "a") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            yield False
            return
        try:
            yield True
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


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
        Bytes removed (by this call, or by another process meanwhile).
    """
    now = time.time() if now is None else now
    files = _listing(folder)
    total = sum(st.st_size for st in files.values())
    if total <= limit:
        return 0
    # (The listing holds the cache's names only: an .npz is an entry, a
    # .tmp unfinished, anything else a side file.)
    stems = {name[:-4] for name in files if name.endswith(".npz")}
    entries: dict[str, list[str]] = {stem: [stem + ".npz"] for stem in stems}
    loose = []  # side files without an entry, unfinished temporary files
    for name in files:
        if name.endswith(".npz"):
            continue
        stem = None if name.endswith(".tmp") else _entry_of(name, stems)
        if stem is None:
            loose.append(name)
        else:
            entries[stem].append(name)
    old = now - KEEP_RECENT_S
    # Loose files first, then entries by when they were last used (their
    # newest file), none holding a file younger than ``old``.
    queue = sorted((files[name].st_mtime, [name]) for name in loose if files[name].st_mtime < old)
    queue += sorted((max(files[n].st_mtime for n in members), members) for members in entries.values()
                    if max(files[n].st_mtime for n in members) < old)
    removed = 0
    goal = AFTER_REMOVAL * limit
    for _, members in queue:
        if total - removed <= goal:
            break
        for i, name in enumerate(members):  # an entry's .npz first: gone before its side files
            gone = _remove(folder / name, files[name])
            if gone is None and i == 0:
                break  # changed since the scan, or held open: the entry stays whole
            removed += gone or 0
    return removed


def _listing(folder: Path) -> dict[str, os.stat_result]:
    """The cache's own regular files in ``folder`` with their status (none
    when it cannot be read; a file gone meanwhile left out)."""
    files = {}
    try:
        scan = list(os.scandir(folder))
    except OSError:
        return files
    for e in scan:
        if not (_ENTRY.fullmatch(e.name) or _SIDE.fullmatch(e.name) or _UNFINISHED.fullmatch(e.name)):
            continue
        try:
            if e.is_file(follow_symlinks=False):
                files[e.name] = e.stat(follow_symlinks=False)
        except OSError:
            pass
    return files


def _remove(path: Path, seen: os.stat_result) -> int | None:
    """Remove ``path`` if it is still the file ``seen`` was; the bytes it
    held (0 when another process removed it first), or None when it changed
    or cannot be removed."""
    try:
        st = path.stat()
        if (st.st_ino, st.st_mtime_ns, st.st_size) != (seen.st_ino, seen.st_mtime_ns, seen.st_size):
            return None
        path.unlink()
        return st.st_size
    except FileNotFoundError:
        return seen.st_size  # another pruner took it: counted, so this one does not go further
    except OSError:
        return None


def _entry_of(name: str, stems) -> str | None:
    """The entry (stem) whose side file ``name`` is (``{stem}.{member}{suffix}``;
    a stem may hold dots itself, so the longest stem that fits), or None."""
    cut = name.rfind(".")
    while cut > 0:
        cut = name.rfind(".", 0, cut)
        if cut > 0 and name[:cut] in stems:
            return name[:cut]
    return None
