"""A minimal observable: how the model notifies views and controllers without Qt."""

from __future__ import annotations

from typing import Callable


class Observable:
    """A list of callbacks called, in connection order, by :meth:`emit`.

    The model owns its observables and views connect to them; a callback must not
    raise (an exception propagates to whoever changed the model).
    """

    def __init__(self) -> None:
        self._callbacks: list[Callable] = []

    def connect(self, callback: Callable) -> None:
        """Call ``callback(*args)`` on every :meth:`emit` from now on."""
        self._callbacks.append(callback)

    def disconnect(self, callback: Callable) -> None:
        """Stop calling ``callback``; a callback not connected is ignored."""
        if callback in self._callbacks:
            self._callbacks.remove(callback)

    def emit(self, *args) -> None:
        # A copy, so a callback may disconnect itself while being called.
        for callback in list(self._callbacks):
            callback(*args)
