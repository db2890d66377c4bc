"""A tiled run on Dask: the landform pass once, then every tile as a task
as soon as the neighbours it is constrained by are finished, then the
GeoTIFF from the tiles on disk.

Dask does the distribution: a :class:`distributed.LocalCluster` of worker
processes on this machine, or the cluster of an existing scheduler
(``scheduler="tcp://host:8786"``; its workers need the same TerraSynth
installed).  Tasks carry their inputs (a few megabytes: the tile's sketch,
its window of the landform pass, its neighbours' border strips); the
examples are sent once to every worker.  Finished tiles come back to this
process, which keeps them on disk (:mod:`.store`) and cuts the next tiles'
border strips from there, so nothing needs a shared file system and no
process holds the whole terrain.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import re
import secrets
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ..controls.layout import grounded_examples
from ..controls.options import Controls
from ..controls.water import Water, flooded_land, flooded_note
from ..errors import ParamsError, SynthesisCancelled
from ..features.sketch import SketchMap
from ..heightfield import HeightField
from ..io.resample import output_georeference
from ..synthesis.params import SynthesisParams
from ..synthesis.session import Session, with_patch_size
from .controls import MapControls, TileControls, map_controls
from .drainage import PaintedMask, drain_tiles
from .inputs import CoarseLevel, coarse_level, sketch_window
from .library import library_examples
from .output import write_geotiff_from_tiles
from .plan import Tile, TilePlan, plan_tiles
from .store import TileStore, compose, run_digest, store_path
from .task import malloc_trim_threshold, run_task
from .tile import TileJob, synthesize_tile, tile_params

__all__ = ["TileFinished", "TiledResult", "check_scheduler", "run_tiled", "tiled_project_inputs"]

#: Extensions a tiled run writes (the GeoTIFF is streamed; other formats
#: would need the whole terrain in memory).
TILED_EXTENSIONS = (".tif", ".tiff")

#: Largest output side, cells.
MAX_SIDE = 131_072

#: Tasks in flight per worker: one running, one waiting, so a worker never
#: idles while this process prepares the next job, and jobs (with their
#: border strips) do not pile up on the workers.
IN_FLIGHT_PER_WORKER = 2

#: Seconds between two looks at ``cancel`` while tiles run.
CANCEL_POLL = 0.25

#: A scheduler address: ``tcp://host:port`` (or tls, ws, wss, ucx), or ``host:port``.
_ADDRESS = re.compile(r"^((tcp|tls|ws|wss|ucx)://)?(\[[0-9a-fA-F:]+\]|[A-Za-z0-9_.-]+):\d{1,5}$")


@dataclass(frozen=True)
class TileFinished:
    """Progress of a tiled run: a tile is finished (or was found on disk).

    Parameters
    ----------
    row, col : int
        The tile.
    done, total : int
        Tiles finished so far (reused ones included), and all.
    reused : bool
        Taken from an earlier run's store.
    """

    row: int
    col: int
    done: int
    total: int
    reused: bool


@dataclass(frozen=True)
class TiledResult:
    """What :func:`run_tiled` made.

    Parameters
    ----------
    path : Path
        The GeoTIFF.
    shape : (rows, cols)
    plan : TilePlan
    reused : int
        Tiles taken from an earlier run.
    workers : int
        Dask workers used.
    seconds : float
        Wall time.
    timings : dict of str to float
        ``"landform"``, ``"tiles"``, ``"write"``, seconds.
    notes : tuple of str
        Warnings for the user.
    lowest, highest : float
        The heights' range, metres.
    cell_size : float or None
        Metres.
    """

    path: Path
    shape: tuple[int, int]
    plan: TilePlan
    reused: int
    workers: int
    seconds: float
    timings: dict
    notes: tuple[str, ...]
    lowest: float
    highest: float
    cell_size: float | None


def check_scheduler(address: str) -> str:
    """A Dask scheduler address, checked for form (not reached).

    Raises
    ------
    ParamsError
        Naming the address and the expected form.
    """
    if not isinstance(address, str) or not _ADDRESS.match(address.strip()):
        raise ParamsError(f"scheduler address {address!r}: expected tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786, "
                          "the address a dask scheduler prints)")
    return address.strip()


def tiled_project_inputs(spec) -> tuple[list[HeightField], SketchMap | None, SynthesisParams, Controls | None]:
    """The examples, sketch, parameters and controls (style regions, water,
    stamps, pins; None for none) of a project's run
    (:class:`~terrasynth_core.project.RunSpec`) for :func:`run_tiled`.

    Raises
    ------
    ParamsError
        Naming the first control a tiled run does not take (a height
        range, a re-synthesis).
    """
    unsupported = [("a height range", spec.height_range is not None), ("a re-synthesis", spec.selection is not None)]
    for what, used in unsupported:
        if used:
            raise ParamsError(f"the project uses {what}, which a tiled run does not take: render it without tiles, "
                              f"or remove {what} from a copy of the project")
    controls = None
    if spec.styles or (spec.water is not None and bool(spec.water.any())) or spec.stamps or spec.pins:
        controls = spec.make_controls()
    return list(spec.example_fields()), spec.sketch_map, spec.params, controls


def check_tiled_output(out: Path) -> Path:
    """The output of a tiled run: a GeoTIFF in an existing folder."""
    out = Path(out)
    if out.suffix.lower() not in TILED_EXTENSIONS:
        raise ParamsError(f"a tiled run writes a GeoTIFF (streamed tile by tile): {out} is not a .tif/.tiff file")
    if not out.parent.is_dir():
        raise ParamsError(f"cannot write {out}: folder {out.parent} does not exist")
    return out


def run_tiled(examples: Sequence[HeightField | np.ndarray], sketch: SketchMap | None, *, shape: tuple[int, int],
              tile: int, out: str | os.PathLike, params: SynthesisParams = SynthesisParams(),
              workers: int | None = None, scheduler: str | None = None, client=None,
              keep_tiles: bool = False, progress: Callable[[object], None] | None = None,
              cancel: Callable[[], bool] | None = None, controls: Controls | None = None) -> TiledResult:
    """Synthesize a terrain of ``shape`` as tiles on Dask and write it as a GeoTIFF.

    Parameters
    ----------
    examples : sequence of HeightField or ndarray
        Example DEMs (metres).
    sketch : SketchMap or None
        Ridges and valleys as painted, any size (scaled to ``shape``).
    shape : (rows, cols)
        Output cells.
    tile : int
        Tile side, cells (at least two patches).
    out : path
        The ``.tif``/``.tiff`` to write; its tile store is ``OUT.tiles``.
    params : SynthesisParams
        As for a whole-map run; ``workers`` is ignored (one process per
        Dask worker).  Drainage, which needs the whole map's strokes, runs
        once the tiles are finished (:mod:`.drainage`).
    workers : int, optional
        Worker processes of the local cluster (default: one per core).
        Not used with ``scheduler`` or ``client``.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``).
    client : distributed.Client, optional
        A client to use as it is (tests, notebooks); not closed.
    keep_tiles : bool, default False
        Keep ``OUT.tiles`` after the output is written.
    progress : callable, optional
        Called with a :class:`TileFinished` per tile.
    cancel : callable, optional
        Polled after every tile; True stops the run (finished tiles stay
        on disk for the next run) and raises ``SynthesisCancelled``.
    controls : Controls, optional
        Style regions (their map and the water mask as painted, any size
        with the output's aspect ratio), water, stamps and pins (output
        cells), as for a whole-map run (:mod:`.controls`).  Not a height
        range or a re-synthesis.  With styles the landform pass is not run
        (each region is built on its own level, as a whole-map run with
        several regions); each stamp must lie inside one tile.

    Returns
    -------
    TiledResult

    Raises
    ------
    ParamsError
        Bad sizes, tile, output path, scheduler address, or an unreachable
        scheduler; anything a session refuses.
    SynthesisCancelled
        When ``cancel`` returned True.

    Notes
    -----
    The same inputs give the same bytes with any number of workers and
    after any interruption: each tile is seeded by its place and sees only
    the tiles of earlier phases (:mod:`.plan`).
    """
    t_start = time.perf_counter()
    if not isinstance(params, SynthesisParams):
        raise ParamsError(f"params must be SynthesisParams, got {type(params).__name__}")
    rows, cols = _checked_shape(shape)
    out = check_tiled_output(Path(out))
    if scheduler is not None:
        scheduler = check_scheduler(scheduler)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ParamsError(f"workers {workers!r}: expected a whole number of at least 1")
    if controls is not None and not isinstance(controls, Controls):
        raise ParamsError(f"controls must be Controls, got {type(controls).__name__}")
    examples = list(examples or ())
    if not examples and not (controls is not None and controls.styles):
        raise ParamsError("no example DEM given: synthesis needs at least one")
    size_notes = []
    if params.patch_size is None:  # chosen once for every tile
        (controls or Controls()).check_kinds()
        params, size_notes = with_patch_size(
            params, grounded_examples(examples, controls or Controls(), params.cell_size), sketch, (rows, cols))
    plan = plan_tiles((rows, cols), tile, patch_size=params.patch_size, seed=params.seed)
    # Checks the examples (and the parameters against them) before any
    # worker starts; its layout gives the run's cell size and the styles' bases.
    styles = () if controls is None else tuple(controls.styles)
    side = 2 * params.patch_size
    probe = Session(examples, None, shape=(side, side), params=_quiet(params),
                    controls=Controls(styles=styles, style_map=np.zeros((side, side), np.int16)) if styles else None)
    notes = [*size_notes, *(w for w in probe.warnings if "no strokes" not in w)]
    mapped = map_controls(controls, examples, (rows, cols), plan, params, probe.layout)
    if styles and params.landform:
        notes.append("landform pass not used with style regions in a tiled run: each region is built on its own "
                     "level")
        params = dataclasses.replace(params, landform=False)
    # Sent to the workers once: the plain examples, the styles', the stamps'.
    stamps = () if controls is None else controls.stamps
    fields = [*examples, *(s.example for s in styles), *(st.field for st in stamps)]
    store = TileStore(store_path(out), run_digest(fields, sketch, params, plan,
                                                  None if controls is None else mapped.description()))
    try:
        timings, n_workers, written = _run_stored(store, plan, fields, mapped, sketch, params, out, probe.cell_size,
                                                  workers, scheduler, client, progress, cancel, notes)
        reused = store.reused
        if not keep_tiles:
            store.remove()
    except BaseException:
        if store.created and not store.holds_work():
            store.remove()  # (failed before anything was kept: a cluster out of reach, say)
        raise
    finally:
        store.close()  # a failed or cancelled run leaves its tiles for the next
    cell = probe.cell_size
    return TiledResult(out, (rows, cols), plan, reused, n_workers, time.perf_counter() - t_start, timings,
                       tuple(notes), written.lowest, written.highest, cell)


def _run_stored(store: TileStore, plan: TilePlan, examples, mapped: MapControls, sketch, params, out: Path,
                cell: float | None, workers, scheduler, client, progress, cancel, notes: list[str]):
    """The landform pass, the tiles and the GeoTIFF, with ``store``
    (``examples``: the plain ones, then the styles' and stamps')."""
    timings: dict[str, float] = {}
    own = None
    if client is None:
        client, own = _client(workers, scheduler)
    try:
        n_workers = max(len(client.scheduler_info().get("workers", {})), 1)
        notes.extend(_allocator_notes(client))
        # The examples go to every worker once, as data rather than inside
        # each task (the scheduler warns of, and slows on, large tasks); each
        # worker stores them on its disk and maps them (:mod:`.library`).
        # Keys unique to this run (hash=False): a finished run's data being
        # released on a shared client never takes this run's with it.  One
        # example at a time: a worker holds the bytes of the one it is
        # storing, not the whole library's at once (one message each).
        shared = [client.scatter(example, broadcast=True, hash=False) for example in library_examples(examples)]
        t = time.perf_counter()
        coarse, coarse_notes = _landform(client, store, shared[:mapped.n_plain], sketch, plan.shape, params)
        notes.extend(coarse_notes)
        timings["landform"] = time.perf_counter() - t
        t = time.perf_counter()
        _run_tiles(client, store, plan, shared, sketch, coarse, params, n_workers, progress, cancel,
                   lambda t: (mapped.for_tile(t, plan.shape, params.patch_size), cell))
        timings["tiles"] = time.perf_counter() - t
    finally:
        if own is not None:
            _close(client, own)
    drained = None
    if params.drainage:
        # The whole map's valleys drain to their outlets, tiles away, and its
        # closed depressions open: read from the finished tiles, added as
        # they are written.
        t = time.perf_counter()
        drained, drain_notes = drain_tiles(store, plan, sketch, patch_size=params.patch_size, water=mapped.water,
                                           pins=mapped.pins)
        notes.extend(drain_notes)
        timings["drainage"] = time.perf_counter() - t
    t = time.perf_counter()
    placed = examples[:mapped.n_plain + len(mapped.styles)]  # the stamps do not place the output
    georef = None if cell is None else output_georeference(placed, plan.shape, cell)
    water = mapped.water if mapped.water is not None and np.any(mapped.water.mask) else None
    painted = None if water is None else PaintedMask(water.mask, plan.shape)
    flooded = 0

    def adjust(box, heights):
        nonlocal flooded
        if drained is not None:
            heights = drained.corrected(box, heights)
        if painted is not None:
            # (Land below the level away from the water, as a whole-map run's finish says.)
            flooded += flooded_land(heights, Water(painted.window(box), water.level))
        return heights

    written = write_geotiff_from_tiles(store, plan, out, cell_size=cell, georef=georef, adjust=adjust)
    if flooded:
        notes.append(flooded_note(flooded, water.level))
    timings["write"] = time.perf_counter() - t
    return timings, n_workers, written


def _allocator_notes(client) -> list[str]:
    """A note when the cluster's workers run with Dask's
    ``MALLOC_TRIM_THRESHOLD_`` (see :func:`.task.malloc_trim_threshold`):
    a user's cluster started as Dask does by default (a local one of ours
    starts without it)."""
    values = [v for v in client.run(malloc_trim_threshold).values() if v is not None]
    if not values:
        return []
    return [f"{len(values)} of the cluster's workers run with MALLOC_TRIM_THRESHOLD_={values[0]}, which made "
            "the engine 1.8-2x slower in our measurements: start them without it (README: World-size terrains)"]


def _quiet(params: SynthesisParams) -> SynthesisParams:
    return dataclasses.replace(params, landform=False, drainage=False, workers=1)


def _checked_shape(shape) -> tuple[int, int]:
    try:
        rows, cols = (int(v) for v in shape)
    except (TypeError, ValueError):
        raise ParamsError(f"output size {shape!r}: expected (rows, cols)") from None
    if not (1 <= rows <= MAX_SIDE and 1 <= cols <= MAX_SIDE):
        raise ParamsError(f"output size {rows}x{cols}: each side must be 1 to {MAX_SIDE} cells")
    return rows, cols


# -- the cluster -----------------------------------------------------------------------------
def _client(workers: int | None, scheduler: str | None):
    """A client of the given scheduler, or of a new local cluster; and what
    to close afterwards."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout="15s")
        except (OSError, TimeoutError) as exc:
            raise ParamsError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        return client, (client, None)
    n = workers or os.cpu_count() or 1
    # One thread per worker: a worker is one core (the engine runs in one
    # process there).  The scheduler's web server (the dashboard when bokeh
    # is installed) on a free port: a fixed one may be taken.  Without the
    # MALLOC_TRIM_THRESHOLD_ Dask sets for its workers, which slows the
    # engine (:func:`.task.malloc_trim_threshold`); each task trims once at
    # its end instead (:func:`.task.run_task`).
    with _ctrl_c_ignored(), dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                               silence_logs=logging.ERROR)
    client = Client(cluster)
    return client, (client, cluster)


@contextlib.contextmanager
def _ctrl_c_ignored():
    """SIGINT ignored while the local workers start, so that they ignore it
    too (an ignored signal stays ignored in a new process, and Python then
    installs no KeyboardInterrupt for it).  Ctrl-C reaches the terminal's
    whole process group: this process stops the run and closes the
    cluster, and each worker's own KeyboardInterrupt printed its traceback
    first (67 lines for two workers)."""
    if threading.current_thread() is not threading.main_thread():
        yield  # (only the main thread sets handlers; Ctrl-C is its anyway)
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        # (None: a handler set outside Python; Python's own is the default.)
        signal.signal(signal.SIGINT, signal.default_int_handler if previous is None else previous)


def _close(client, own) -> None:
    c, cluster = own
    c.close()
    if cluster is not None:
        cluster.close()


# -- the landform pass -------------------------------------------------------------------------
def _landform(client, store: TileStore, examples, sketch, shape, params) -> tuple[CoarseLevel | None, list[str]]:
    """The landform pass over the whole map, on a worker; kept in the store
    (a resumed run does not make it again).  ``examples``: their futures."""
    kept = store.load_coarse()
    if kept is None:
        coarse, notes = client.submit(run_task, coarse_level, examples, sketch, shape, params,
                                      key=f"coarse_level-{secrets.token_hex(8)}", pure=False).result()
        info = dict(notes=notes)
        if coarse is not None:
            info.update(sigma=coarse.sigma, factor=coarse.factor, split=coarse.detail_split)
        store.save_coarse(None if coarse is None else coarse.heights, info,
                          coherent=None if coarse is None else coarse.coherent)
        return coarse, notes
    heights, coherent, info = kept
    coarse = None if heights is None else CoarseLevel(heights, tuple(shape), float(info["sigma"]), int(info["factor"]),
                                                      coherent, float(info["split"]))
    return coarse, list(info.get("notes", []))


# -- the tiles ---------------------------------------------------------------------------------
def _run_tiles(client, store: TileStore, plan: TilePlan, shared, sketch, coarse, params, n_workers: int,
               progress, cancel, controls_of) -> None:
    """Submit each tile when its needs are finished; keep each result.
    ``shared``: the examples' futures; ``controls_of(tile)``: its
    :class:`~.controls.TileControls` and the run's cell size."""
    from distributed import wait

    tiles = plan.by_key()
    done = {key for key in tiles if store.has(key)}
    total = len(tiles)
    count = 0
    for tile in plan.tiles:
        if tile.key in done:
            count += 1
            if progress is not None:
                progress(TileFinished(tile.row, tile.col, count, total, True))
    waiting = [t for t in plan.tiles if t.key not in done]  # in plan order: phase, row, col
    if not waiting:
        return
    limit = IN_FLIGHT_PER_WORKER * n_workers
    # Task names for the dashboard; unique per run, so a cancelled run's
    # tasks still being dropped never stand for this run's on a shared client.
    run_id = secrets.token_hex(4)
    pending: dict[str, tuple] = {}  # future key -> (future, tile, job future)

    def submit_ready() -> None:
        for t in list(waiting):
            if len(pending) >= limit:
                return
            if all(n in done for n in t.needs):
                waiting.remove(t)
                # The job (its border strips: megabytes) is sent as data too.
                job = client.scatter(_job(t, plan, store, sketch, coarse, params, *controls_of(t)), hash=False)
                future = client.submit(run_task, synthesize_tile, job, shared, key=f"tile-{t.row}-{t.col}-{run_id}",
                                       retries=1, pure=False)
                pending[future.key] = (future, t, job)  # the job's data lives while the task does

    try:
        submit_ready()
        while pending:
            try:
                finished, _ = wait([f for f, _, _ in pending.values()], timeout=CANCEL_POLL,
                                   return_when="FIRST_COMPLETED")
            except TimeoutError:
                finished = set()
            for future in sorted(finished, key=lambda f: pending[f.key][1].key):
                _, tile, job = pending.pop(future.key)
                heights = future.result()
                future.release()
                job.release()
                store.save(tile.key, heights)
                done.add(tile.key)
                count += 1
                if progress is not None:
                    progress(TileFinished(tile.row, tile.col, count, total, False))
            if cancel is not None and cancel():
                raise SynthesisCancelled("tiled synthesis cancelled")
            submit_ready()
    finally:
        # On an error or a cancel, tasks not finished are dropped (their
        # tiles are made again by the next run).
        for future, _, job in pending.values():
            future.cancel()
            job.release()


def _job(tile: Tile, plan: TilePlan, store: TileStore, sketch, coarse, params, controls: TileControls,
         cell: float | None) -> TileJob:
    """A tile's job: its sketch, its landform window, its neighbours'
    strips and its part of the controls."""
    context = None if not tile.needs else compose(store, plan, tile.crop, set(tile.needs))
    window = None
    if coarse is not None:
        # The level box when pins or stamps bend the level (computed there);
        # else just the crop's window.
        window = coarse.window(controls.level_box if controls.steering or controls.stamps else tile.crop)
    return TileJob(tile, tile_params(params, tile), sketch_window(sketch, plan.shape, tile.crop), window, context,
                   controls, cell)
