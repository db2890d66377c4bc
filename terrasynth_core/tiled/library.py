"""The examples as a tiled run's workers hold them: stored on each worker's
disk once, then memory-mapped, so a library of many DEMs is not copied
into every worker's memory.

The coordinator sends the examples to the workers once (Dask's scatter, as
any data); each arrives as a :class:`LibraryExample` whose heights are
written to that machine's example cache
(:mod:`terrasynth_core.exemplars.cache`, keyed by their digest, written
atomically) and read back mapped, so the bytes received are freed and the
worker keeps a mapped file.  The analyses made from them (resampling, the
features, the detail bands, the fill indexes) go to the same cache and are
mapped the same way: a tile touches the pages of the windows its searches
read, which stay in the page cache (shared by the machine's workers, and
dropped by the kernel when memory is short), not in the worker's own
memory.  Nothing needs a shared file system: each machine stores what it
receives.  With the cache turned off (``TERRASYNTH_CACHE_DIR=""``) the
examples stay in memory, as before.
"""

from __future__ import annotations

import dataclasses
import hashlib
from typing import Sequence

import numpy as np

from ..exemplars import cache
from ..heightfield import HeightField

__all__ = ["LibraryExample", "library_examples"]


@dataclasses.dataclass(frozen=True, eq=False)
class LibraryExample(HeightField):
    """A :class:`~terrasynth_core.heightfield.HeightField` that, when
    unpickled (on a Dask worker), stores its heights in the example cache
    and maps them from there."""

    def __reduce__(self):
        meta = dict(cell_size=self.cell_size, georef=self.georef, source=self.source, format=self.format,
                    metadata=self.metadata)
        return _arrive, (np.ascontiguousarray(self.heights), meta)


def library_examples(examples: Sequence[HeightField | np.ndarray]) -> list[LibraryExample]:
    """The run's examples, to send to the workers (no copy of the heights).

    Parameters
    ----------
    examples : sequence of HeightField or ndarray
        Metres (an array is a field without cell size).
    """
    out = []
    for ex in examples:
        if isinstance(ex, HeightField):
            out.append(LibraryExample(ex.heights, cell_size=ex.cell_size, georef=ex.georef, source=ex.source,
                                      format=ex.format, metadata=ex.metadata))
        else:
            out.append(LibraryExample(np.asarray(ex)))
    return out


def stored_key(heights: np.ndarray) -> str:
    """The cache key of an example's heights: their digest, shape and type."""
    digest = hashlib.sha1(heights.data).hexdigest()
    return f"library-{digest}-{heights.shape[0]}x{heights.shape[1]}-{heights.dtype.str}"


def _arrive(heights: np.ndarray, meta: dict) -> LibraryExample:
    """Unpickling a :class:`LibraryExample`: its heights stored (keyed by
    the digest of the bytes received, so a damaged or stale file is never
    taken for them) and mapped."""
    heights = np.ascontiguousarray(heights, dtype=np.float32)
    return LibraryExample(cache.kept_array(stored_key(heights), lambda: heights), **meta)
