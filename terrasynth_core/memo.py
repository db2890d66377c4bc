"""Values made once and kept for the next caller: a small, thread-safe,
least-recently-used memo, and keys from the bytes of arrays.

A session is made again for every run and every live stroke, while what it
derives from the examples (their detail band, their fill searches, a seam
solver per window shape) does not change with the sketch.
"""

from __future__ import annotations

import hashlib
import threading
import weakref
from collections import OrderedDict
from typing import Callable, Hashable, TypeVar

import numpy as np

T = TypeVar("T")


class Memo:
    """At most ``size`` values, the least recently used dropped first.

    Parameters
    ----------
    size : int
    once : bool, default False
        Make each value once even when threads ask for it together (see
        :meth:`get`).
    """

    def __init__(self, size: int, *, once: bool = False):
        self.size = int(size)
        self.once = bool(once)
        self._values: OrderedDict = OrderedDict()
        self._making: dict = {}  # key -> Event set when its maker is done
        self._lock = threading.Lock()

    def get(self, key: Hashable, make: Callable[[], T]) -> T:
        """The value kept for ``key``, or ``make()`` kept from now on.

        ``make`` runs outside the lock, so two threads may both make a
        missing value (the values must be equal).  With ``once``, a thread
        asking for a key being made waits for it instead (a live stroke
        arriving while its examples' pools are being prepared); if ``make``
        raises, a waiting thread makes the value itself.  A ``once`` memo's
        ``make`` must not ask it for its own key, nor wait on another
        thread that does (it would wait for itself).
        """
        if not self.once:
            with self._lock:
                if key in self._values:
                    self._values.move_to_end(key)
                    return self._values[key]
            return self._keep(key, make())
        mine = False
        try:
            while True:
                with self._lock:
                    if key in self._values:
                        self._values.move_to_end(key)
                        return self._values[key]
                    making = self._making.get(key)
                    if making is None:
                        making = self._making[key] = threading.Event()
                        mine = True
                        break
                making.wait()  # then look again: kept now, or to be made here
            return self._keep(key, make())
        finally:
            if mine:
                with self._lock:
                    del self._making[key]
                making.set()

    def _keep(self, key: Hashable, value: T) -> T:
        with self._lock:
            self._values[key] = value
            while len(self._values) > self.size:
                self._values.popitem(last=False)
        return value

    def clear(self) -> None:
        """Drop every kept value (values being made are kept when made)."""
        with self._lock:
            self._values.clear()

    def peek(self, key: Hashable):
        """The value kept for ``key`` (None when there is none), not made."""
        with self._lock:
            if key in self._values:
                self._values.move_to_end(key)
                return self._values[key]
        return None


def array_key(*arrays: np.ndarray | None) -> tuple:
    """A key for arrays' contents: a 128-bit hash of their bytes (a few
    milliseconds for an example DEM), shapes and types; None stays None.

    A read-only array's hash is made once and kept while the array lives
    (:func:`_digest`): the examples' detail, shared read-only by every
    session, is asked for by several memos (its detail band, level spread,
    feature pools, fill searches) in every run and every live stroke.
    """
    described = [None if a is None else (a.shape, a.dtype.str) for a in arrays]
    digests = [_digest(a) for a in arrays if a is not None]
    if len(digests) == 1:
        return digests[0], tuple(described)
    combined = hashlib.blake2b(digest_size=16)
    for d in digests:
        combined.update(d)
    return combined.digest(), tuple(described)


#: Hashes of read-only arrays by ``id``, each with a weak reference that
#: drops it when its array goes.
_DIGESTS: dict[int, tuple[weakref.ref, bytes]] = {}
_DIGESTS_LOCK = threading.Lock()


def _digest(a: np.ndarray) -> bytes:
    """The 128-bit BLAKE2b hash of ``a``'s bytes (C order), kept for an
    array whose bytes cannot change (not writeable, nor any array it views)."""
    fixed = not a.flags.writeable
    base = a.base
    while fixed and isinstance(base, np.ndarray):
        fixed, base = not base.flags.writeable, base.base
    if fixed:
        with _DIGESTS_LOCK:
            kept = _DIGESTS.get(id(a))
        if kept is not None and kept[0]() is a:
            return kept[1]
    digest = hashlib.blake2b(np.ascontiguousarray(a).data, digest_size=16).digest()
    if fixed:
        key = id(a)

        def forget(_ref, key=key):
            with _DIGESTS_LOCK:
                if _DIGESTS.get(key, (None,))[0] is _ref:
                    del _DIGESTS[key]

        with _DIGESTS_LOCK:
            _DIGESTS[key] = (weakref.ref(a, forget), digest)
    return digest
