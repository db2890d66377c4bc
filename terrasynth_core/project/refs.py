"""Example DEMs by reference: what a project stores of a DEM it uses.

An :class:`ExampleRef` is a built-in key or a file path, optionally a crop;
loading is memoised because the same examples are used run after run (and
for the app's thumbnails).  Used alike by project files, the app and
``terrasynth-cli synth --project``.
"""

from __future__ import annotations

import os
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from threading import Lock

from ..errors import DEMFormatError
from ..examples import builtin_example
from ..heightfield import HeightField
from ..io import load_dem

__all__ = ["ExampleRef"]

#: Loaded examples kept in memory (a 1201x1201 tile is under 6 MB).
_CACHE_SIZE = 8


@dataclass(frozen=True)
class ExampleRef:
    """One example DEM of a document.

    Parameters
    ----------
    builtin : str or None
        Key of a built-in example (``"white-mountains"``...).
    path : str or None
        DEM file path, when not built in.  Exactly one of ``builtin`` and
        ``path`` is given.
    crop : (r0, r1, c0, c1) or None
        Half-open window of the loaded DEM to use, in cells; ``None`` uses
        all of it.
    """

    builtin: str | None = None
    path: str | None = None
    crop: tuple[int, int, int, int] | None = None

    def __post_init__(self):
        if (self.builtin is None) == (self.path is None):
            raise DEMFormatError("an example is either a built-in key or a file path, not both or neither")
        if self.builtin is not None:
            builtin_example(self.builtin)  # raises, listing the valid keys
        if self.path is not None:
            object.__setattr__(self, "path", os.fspath(self.path))
        if self.crop is not None:
            r0, r1, c0, c1 = (int(v) for v in self.crop)
            if not (0 <= r0 < r1 and 0 <= c0 < c1):
                raise DEMFormatError(f"example crop {self.crop}: expected (r0, r1, c0, c1) with r0 < r1, c0 < c1")
            object.__setattr__(self, "crop", (r0, r1, c0, c1))

    @property
    def label(self) -> str:
        """Name for people: the built-in example's place or the file name."""
        if self.builtin is not None:
            return builtin_example(self.builtin).name
        return Path(self.path).name

    @property
    def description(self) -> str:
        """Where the example comes from: a built-in's name, style, source and
        licence, or the file's path."""
        if self.builtin is None:
            return self.path
        ex = builtin_example(self.builtin)
        return f"{ex.name}\n{ex.style}\nSource: {ex.source} ({ex.licence})"

    @property
    def thumbnail_file(self) -> Path | None:
        """The built-in example's pre-rendered thumbnail; None for a file or when it is missing."""
        if self.builtin is None:
            return None
        path = builtin_example(self.builtin).thumbnail_path
        return path if path.is_file() else None

    def load(self) -> HeightField:
        """The example's height field (cropped), memoised.

        Raises
        ------
        DEMFormatError
            When the file cannot be read or the crop lies outside the DEM.
        """
        key = self._key()
        with _LOCK:
            field = _CACHE.get(key)
            if field is not None:
                _CACHE.move_to_end(key)
        if field is None:
            field = builtin_example(self.builtin).load() if self.builtin is not None else load_dem(self.path)
            with _LOCK:
                _CACHE[key] = field
                while len(_CACHE) > _CACHE_SIZE:
                    _CACHE.popitem(last=False)
        if self.crop is None:
            return field
        r0, r1, c0, c1 = self.crop
        rows, cols = field.shape
        if r1 > rows or c1 > cols:
            raise DEMFormatError(
                f"crop {self.crop} of {self.label} lies outside its {rows}x{cols} cells"
            )
        return field.with_heights(field.heights[r0:r1, c0:c1].copy(), georef=None)

    def _key(self) -> tuple:
        return (self.builtin, self.path, None if self.path is None else _mtime(self.path))

    def loaded_cell_size(self) -> tuple[float, float] | None:
        """The DEM's ground cell size ``(dy, dx)`` in metres when it is
        already loaded (no reading here: safe on the GUI thread); None when
        it is not loaded or has no cell size."""
        try:
            key = self._key()
        except DEMFormatError:
            return None
        with _LOCK:
            field = _CACHE.get(key)
        return None if field is None else field.cell_size

    def to_dict(self) -> dict:
        data: dict = {"builtin": self.builtin} if self.builtin is not None else {"path": self.path}
        if self.crop is not None:
            data["crop"] = list(self.crop)
        return data

    @classmethod
    def from_dict(cls, data: dict) -> "ExampleRef":
        crop = data.get("crop")
        return cls(builtin=data.get("builtin"), path=data.get("path"),
                   crop=tuple(crop) if crop is not None else None)


def _mtime(path: str) -> float:
    try:
        return os.stat(path).st_mtime
    except OSError as exc:
        raise DEMFormatError(f"cannot read DEM {path}: {exc.strerror or exc}") from None


_CACHE: OrderedDict = OrderedDict()
_LOCK = Lock()
