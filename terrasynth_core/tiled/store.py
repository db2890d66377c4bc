"""Finished tiles on disk, beside the output, so a run stopped by a crash, a
kill or Ctrl-C continues where it was.

The store is the folder ``OUT.tiles`` beside the output ``OUT``: a
``run.json`` naming the run's digest (:func:`run_digest`: the inputs, the
parameters and the tile plan), the landform pass's coarse terrain and one
``.npy`` per finished tile, each saved atomically (a killed run leaves
whole tiles or none).  A store made for another digest (a changed example,
sketch, seed, size or tile) is emptied before the run: stale tiles are
never reused.  A folder of that name that is not a store is never touched.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path
from typing import Sequence

import numpy as np

from .. import __version__
from ..errors import ParamsError
from ..features.sketch import SketchMap
from ..heightfield import HeightField
from ..io._common import atomic_outputs, open_new
from ..synthesis.params import SynthesisParams
from .plan import TilePlan

__all__ = ["STORE_FORMAT", "TileStore", "compose", "run_digest", "store_path"]

#: ``run.json``'s ``"format"``: a folder without it is not a tile store.
STORE_FORMAT = "terrasynth-tiles"
#: Bumped when what a tile holds changes meaning, or the same inputs make
#: other tiles (4: examples keep their voids inside instead of being
#: cropped to their largest valid rectangle; 5: the engine's changes of
#: bytes since, which had left it at 4; 6: where the landform pass cannot
#: serve, the drawing's landforms and a wider detail split).
STORE_VERSION = 6


def store_path(out: Path) -> Path:
    """The tile store of the output ``out``: ``OUT.tiles`` beside it."""
    out = Path(out)
    return out.with_name(out.name + ".tiles")


def run_digest(examples: Sequence[HeightField | np.ndarray], sketch: SketchMap | None, params: SynthesisParams,
               plan: TilePlan, controls: dict | None = None) -> str:
    """A SHA-256 of everything a tile's heights depend on.

    Parameters
    ----------
    examples : sequence of HeightField or ndarray
        Their heights, cell sizes and placement.
    sketch : SketchMap or None
        As painted.
    params : SynthesisParams
    plan : TilePlan
        The output's size, the tile grid and the context.
    controls : dict, optional
        The run's style regions, water, stamps and pins as described by
        :meth:`~.controls.MapControls.description` (their DEMs are among
        ``examples``).

    Returns
    -------
    str
        64 hex digits.
    """
    h = hashlib.sha256()
    # Drainage is not in it: it runs after the tiles (.drainage), whose
    # heights do not depend on it.
    described = {"version": __version__, "store": STORE_VERSION,
                 "params": {k: v for k, v in params.to_dict().items() if k != "drainage"},
                 "shape": list(plan.shape), "tile": plan.tile, "context": plan.context, "band": plan.band,
                 "rows": list(plan.row_edges), "cols": list(plan.col_edges), "examples": []}
    for ex in examples:
        heights = np.ascontiguousarray(ex.heights if isinstance(ex, HeightField) else ex)
        h.update(heights.data)
        described["examples"].append({
            "shape": list(heights.shape), "dtype": heights.dtype.str,
            "cell_size": None if not isinstance(ex, HeightField) or ex.cell_size is None else list(ex.cell_size),
            "georef": repr(ex.georef) if isinstance(ex, HeightField) else None})
    if controls is not None:
        described["controls"] = controls
    if sketch is not None:
        h.update(np.packbits(sketch.ridge_mask).data)
        h.update(np.packbits(sketch.valley_mask).data)
        described["sketch"] = list(sketch.shape)
    h.update(json.dumps(described, sort_keys=True).encode())
    return h.hexdigest()


class TileStore:
    """The finished tiles of one run, in ``folder``.

    Parameters
    ----------
    folder : Path
        ``OUT.tiles`` (:func:`store_path`); created when missing.
    digest : str
        The run's :func:`run_digest`.

    Raises
    ------
    ParamsError
        When ``folder`` exists and is not a tile store (it is left as it is).
    """

    def __init__(self, folder: Path, digest: str):
        self.folder = Path(folder)
        self.digest = digest
        #: Tiles found from an earlier run of the same digest.
        self.reused = 0
        self._lock = None
        marker = self.folder / "run.json"
        #: Whether this run made the folder (a run that fails before it
        #: keeps anything removes a folder it made: :meth:`holds_work`).
        self.created = not self.folder.exists()
        if self.folder.exists():
            if not self._is_store(marker):
                raise ParamsError(f"{self.folder} exists and is not a TerraSynth tile store (no run.json of format "
                                  f"{STORE_FORMAT!r}): move it away, or give another --out")
        else:
            self.folder.mkdir(parents=True)
        self._lock = _lock(self.folder)
        if marker.exists():
            if json.loads(marker.read_text()).get("digest") != digest:
                # Another run's tiles (changed inputs or parameters): never reused.
                self._clear()
        if not marker.exists():
            self._write_json(marker, {"format": STORE_FORMAT, "digest": digest})
        self.reused = len(list(self.folder.glob("tile_*.npy")))

    @staticmethod
    def _is_store(marker: Path) -> bool:
        try:
            return json.loads(marker.read_text()).get("format") == STORE_FORMAT
        except (OSError, ValueError, AttributeError):
            return False

    def _clear(self) -> None:
        for path in [*self.folder.glob("tile_*.npy"), self.folder / "coarse.json", self.folder / "coarse.npy",
                     self.folder / "coherent.npy", self.folder / "run.json"]:
            path.unlink(missing_ok=True)

    def _write_json(self, path: Path, data: dict) -> None:
        with atomic_outputs(path) as (tmp,), open_new(tmp) as f:
            f.write(json.dumps(data).encode())

    # -- tiles ---------------------------------------------------------------------------
    def tile_path(self, key: tuple[int, int]) -> Path:
        return self.folder / f"tile_{key[0]}_{key[1]}.npy"

    def has(self, key: tuple[int, int]) -> bool:
        return self.tile_path(key).exists()

    def load(self, key: tuple[int, int], *, mmap: bool = False) -> np.ndarray:
        """A finished tile's heights over its region, float32 (memory-mapped
        with ``mmap``)."""
        return np.load(self.tile_path(key), mmap_mode="r" if mmap else None, allow_pickle=False)

    def save(self, key: tuple[int, int], heights: np.ndarray) -> None:
        """Keep a finished tile (atomic: a kill leaves it whole or absent)."""
        self._save_array(self.tile_path(key), heights)

    def _save_array(self, path: Path, array: np.ndarray) -> None:
        with atomic_outputs(path) as (tmp,), open_new(tmp) as f:
            np.save(f, np.ascontiguousarray(array, dtype=np.float32), allow_pickle=False)

    # -- the landform pass ---------------------------------------------------------------
    def load_coarse(self) -> tuple[np.ndarray | None, np.ndarray | None, dict] | None:
        """The landform pass as kept: its coarse terrain (None when the pass
        did not serve), its coherence weights (None without strokes) and its
        description; None when not kept yet."""
        info = self.folder / "coarse.json"
        if not info.exists():
            return None
        described = json.loads(info.read_text())
        heights = np.load(self.folder / "coarse.npy", allow_pickle=False) if described.get("heights") else None
        coherent = (np.load(self.folder / "coherent.npy", allow_pickle=False) if described.get("coherent")
                    else None)
        return heights, coherent, described

    def save_coarse(self, heights: np.ndarray | None, info: dict, *, coherent: np.ndarray | None = None) -> None:
        """Keep the landform pass (``heights`` None: the pass did not serve;
        ``coherent``: its coherence weights, if any)."""
        if heights is not None:
            self._save_array(self.folder / "coarse.npy", heights)
        if coherent is not None:
            self._save_array(self.folder / "coherent.npy", coherent)
        # The description last: it says the pass is complete.
        self._write_json(self.folder / "coarse.json",
                         dict(info, heights=heights is not None, coherent=coherent is not None))

    def holds_work(self) -> bool:
        """Whether a later run could continue from the store: a finished
        tile or the landform pass's terrain."""
        return any(self.folder.glob("tile_*.npy")) or (self.folder / "coarse.json").exists()

    def close(self) -> None:
        """Let another run use the store."""
        if self._lock is not None:
            self._lock.close()  # closing the file releases its lock
            self._lock = None

    def remove(self) -> None:
        """Delete the store (after the output is written)."""
        self.close()
        shutil.rmtree(self.folder, ignore_errors=True)


def _lock(folder: Path):
    """An exclusive lock on the store for this process's run, released when
    the file is closed or the process ends (a kill included), so a second
    run on the same output is refused instead of mixing its tiles in."""
    try:
        import fcntl
    except ImportError:  # Windows: no advisory locks; one run at a time is the user's care
        return None
    handle = open(folder / "lock", "a+b")
    try:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        handle.close()
        raise ParamsError(f"another run is writing {folder}: wait for it to end, or give another --out") from None
    return handle


def compose(store: TileStore, plan: TilePlan, box: tuple[int, int, int, int],
            keys: set[tuple[int, int]] | None = None) -> np.ndarray:
    """The terrain over ``box`` from the finished tiles: each cell from the
    latest phase whose region holds it.

    Parameters
    ----------
    store : TileStore
    plan : TilePlan
    box : (r0, r1, c0, c1)
        Output cells.
    keys : set of (row, col), optional
        Only these tiles (default: every tile whose region meets ``box``).

    Returns
    -------
    ndarray of float32, shape (r1 - r0, c1 - c0)
        Zero where no tile given holds a cell.
    """
    r0, r1, c0, c1 = box
    out = np.zeros((r1 - r0, c1 - c0), np.float32)
    for tile in plan.tiles:  # in phase order: later phases paint over earlier ones
        if keys is not None and tile.key not in keys:
            continue
        a0, a1, b0, b1 = tile.region
        lo_r, hi_r, lo_c, hi_c = max(a0, r0), min(a1, r1), max(b0, c0), min(b1, c1)
        if lo_r >= hi_r or lo_c >= hi_c:
            continue
        made = store.load(tile.key, mmap=True)
        out[lo_r - r0:hi_r - r0, lo_c - c0:hi_c - c0] = made[lo_r - a0:hi_r - a0, lo_c - b0:hi_c - b0]
    return out
