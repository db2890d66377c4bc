"""Values made once and kept for the next caller: a small, thread-safe,
least-recently-used memo, and keys from the bytes of arrays.

A session is made again for every run and every live stroke, while what it
derives from the examples (their detail band, their fill searches, a seam
solver per window shape) does not change with the sketch.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from typing import Callable, Hashable, TypeVar

import numpy as np

T = TypeVar("T")


class Memo:
    """At most ``size`` values, the least recently used dropped first.

    Parameters
    ----------
    size : int
    """

    def __init__(self, size: int):
        self.size = int(size)
        self._values: OrderedDict = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Hashable, make: Callable[[], T]) -> T:
        """The value kept for ``key``, or ``make()`` (called outside the
        lock, so two threads may both make a missing value; the values must
        be equal) kept from now on."""
        with self._lock:
            if key in self._values:
                self._values.move_to_end(key)
                return self._values[key]
        value = make()
        with self._lock:
            self._values[key] = value
            while len(self._values) > self.size:
                self._values.popitem(last=False)
        return value

    def peek(self, key: Hashable):
        """The value kept for ``key`` (None when there is none), not made."""
        with self._lock:
            if key in self._values:
                self._values.move_to_end(key)
                return self._values[key]
        return None


def array_key(*arrays: np.ndarray | None) -> tuple:
    """A key for arrays' contents: a 128-bit hash of their bytes (a few
    milliseconds for an example DEM), shapes and types; None stays None."""
    digest = hashlib.blake2b(digest_size=16)
    described = []
    for a in arrays:
        if a is None:
            described.append(None)
            continue
        a = np.ascontiguousarray(a)
        digest.update(a.data)
        described.append((a.shape, a.dtype.str))
    return digest.digest(), tuple(described)
