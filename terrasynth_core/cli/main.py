"""``terrasynth-cli``: DEM information, conversion, feature extraction, synthesis.

Exit status: 0 on success, 2 on bad input (one line on stderr naming the
problem), 130 when interrupted.  Progress goes to stderr so stdout stays
clean for ``--json``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
import tempfile
import threading
from pathlib import Path

from .controls import add_control_arguments
from ..errors import TerraSynthError

EXIT_OK = 0
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
#: A run stopped because its output pipe closed (128 + SIGPIPE, as a shell
#: reports a tool killed by it).
EXIT_BROKEN_PIPE = 141
#: Commands whose product is what they print: a closed pipe ends them quietly.
_STDOUT_COMMANDS = ("info", "examples", "features")

#: ``export --preset`` and ``masks --preset`` values: the names of
#: :data:`terrasynth_core.export.PRESETS`, and ``masks --format`` values:
#: :data:`terrasynth_core.export.MASK_FORMATS`.  Written out here because the
#: export package needs numpy, scipy and rasterio, which ``--help`` must not
#: load; tests/core/test_cli_fast_start.py checks that both lists agree.
PRESET_NAMES = ("unreal", "unity", "godot", "blender", "houdini")
MASK_FORMATS = ("png8", "png16", "exr")


def parse_size(text: str) -> tuple[int, int]:
    """``ROWSxCOLS`` (or a single ``N`` for a square) -> (rows, cols)."""
    parts = text.lower().split("x")
    try:
        dims = tuple(int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"size {text!r} is not ROWSxCOLS, e.g. 1000x1000") from None
    if len(dims) == 1:
        dims = (dims[0], dims[0])
    if len(dims) != 2:
        raise argparse.ArgumentTypeError(f"size {text!r} has {len(dims)} numbers: give ROWSxCOLS (two), e.g. 1000x1000")
    if min(dims) < 2:
        raise argparse.ArgumentTypeError(f"size {text!r}: both ROWS and COLS must be at least 2")
    return dims  # type: ignore[return-value]


class _Stages:
    """A stage-by-stage progress bar on stderr; tqdm keeps it silent when stderr
    is not a terminal, so logs and pipes stay clean."""

    def __init__(self, total: int, desc: str):
        from tqdm import tqdm

        self._bar = tqdm(total=total, desc=desc, file=sys.stderr, unit="step", leave=False,
                         disable=None, bar_format="{desc}: {n_fmt}/{total_fmt} {postfix} [{elapsed}]")

    def step(self, what: str) -> None:
        self._bar.set_postfix_str(what)
        self._bar.update(1)

    def close(self) -> None:
        self._bar.close()


# -- info ---------------------------------------------------------------------
def _json_number(value: float | None) -> float | str | None:
    """``value`` as strict JSON holds it: a NaN or infinite nodata value
    (a float GeoTIFF's usual NaN) as the string GDAL's own JSON writes,
    ``"nan"``, ``"inf"`` or ``"-inf"``."""
    if value is None or math.isfinite(value):
        return value
    return str(float(value))


def cmd_info(args: argparse.Namespace) -> int:
    from ..examples import resolve_dem

    field = resolve_dem(args.dem, size=args.size, band=args.band)
    crs_name = _crs_name(field)
    info = {
        "file": str(args.dem),
        "format": field.format,
        "shape": list(field.shape),
        "min": round(field.min, 3),
        "max": round(field.max, 3),
        "nodata": field.nodata_count,  # (cells; kept under this key for scripts that read it)
        "nodata_value": _json_number(field.metadata.get("nodata_value")),
        "cell_size": None if field.cell_size is None else [round(v, 4) for v in field.cell_size],
        "epsg": None if field.georef is None else field.georef.epsg,
        "crs": crs_name,
    }
    if args.json:
        print(json.dumps(info, allow_nan=False))
        return EXIT_OK
    rows, cols = field.shape
    cell = "unknown" if field.cell_size is None else "{:.2f} m x {:.2f} m (dy x dx)".format(*field.cell_size)
    print(f"{args.dem}: {info['format']}, {rows} x {cols} cells")
    print(f"  heights   {info['min']} .. {info['max']} m")
    value = "" if info["nodata_value"] is None else f", value {float(info['nodata_value']):g}"
    print(f"  nodata    {info['nodata']} cells ({100 * info['nodata'] / (rows * cols):.1f} %){value}")
    print(f"  cell size {cell}")
    if info["epsg"]:
        print(f"  CRS       EPSG:{info['epsg']}")
    elif crs_name:
        print(f"  CRS       {crs_name}")
    return EXIT_OK


def _crs_name(field) -> str | None:
    """The CRS's name from its WKT (what names a CRS without EPSG code)."""
    from ..io.gdal import field_crs

    crs = field_crs(field.georef)
    return None if crs is None else crs.to_wkt().split('"')[1]


def _check_cog(args: argparse.Namespace, out: Path) -> None:
    if getattr(args, "cog", False) and out.suffix.lower() not in (".tif", ".tiff"):
        raise TerraSynthError(f"--cog writes GeoTIFF only: {out} is not a .tif/.tiff file")


#: Options that name what a command writes, not what it reads.
_OUTPUT_OPTIONS = ("out", "output", "report", "debug_dir", "json", "overlay")


def _input_files(args: argparse.Namespace) -> list[Path]:
    """Every existing file the command's options name as an input: plain
    paths (``--example``, ``--sketch``, ``--water``, ``--project``, ...) and the
    paths inside specs such as ``--style "#3070c0=DEM,relief=1.5"`` and
    ``--stamp "DEM@row,col"``."""
    import re

    found = []
    for name, value in vars(args).items():
        if name in _OUTPUT_OPTIONS or callable(value):
            continue
        for item in value if isinstance(value, (list, tuple)) else [value]:
            if not isinstance(item, (str, os.PathLike)):
                continue
            text = os.fspath(item)
            for token in [text, *re.split(r"[=,@]", text)]:
                if token and Path(token).is_file():
                    found.append(Path(token))
    return found


def _refuse_replacing(args: argparse.Namespace, outputs, inputs=()) -> None:
    """Refuse, before any work, to write over a file the command reads (ever)
    or over any existing file (unless ``--overwrite``): a run never loses
    what the user owns: nor over a heightmap's sidecar, nor two outputs
    over one file, nor into a folder that does not exist.

    Parameters
    ----------
    outputs : iterable of path
        What the command writes; an ESRI grid's ``<stem>.prj`` is counted
        with it, and a heightmap's ``<stem>.json`` sidecar is checked as
        the writer will check it (never a file not ours).
    inputs : iterable of path, optional
        Files read that the options do not name (a project's DEMs, a
        built-in's file), besides :func:`_input_files`.

    Raises
    ------
    TerraSynthError
        One line naming the file.
    """
    from ..io import sidecar_of
    from ..io._common import check_not_sidecar, check_sidecar_ours

    inputs = [*_input_files(args), *(Path(i) for i in inputs if i and Path(i).is_file())]
    written = []
    for out in map(Path, outputs):
        written.append(out)
        check_not_sidecar(out, "output")  # (another heightmap's metres and cell size: never replaced)
        if sidecar_of(out) is not None:
            check_sidecar_ours(out)
        if out.suffix.lower() == ".asc":
            written.append(out.with_suffix(".prj"))
    seen = {}
    for out in written:
        # (One output written over another: a --report named as --out.)
        other = seen.setdefault(out.resolve(), out)
        if other is not out:
            raise TerraSynthError(f"two of the outputs are the same file, {out}: give each its own name")
    for out in written:
        _check_output_file(out)
        if not out.exists():
            continue
        if any(os.path.samefile(out, i) for i in inputs):
            raise TerraSynthError(f"{out} is an input of this command; write the output to another file")
        if not getattr(args, "overwrite", False):
            raise TerraSynthError(f"{out} exists; give --overwrite to replace it, or choose another output")


def _sources(examples=(), controls=None, *paths) -> list[str]:
    """The files a run reads, from what was loaded: its examples', styles'
    and stamps' DEMs (a project's or a built-in's too), and ``paths``."""
    fields = [*examples]
    if controls is not None:
        fields += [s.example for s in controls.styles] + [s.field for s in controls.stamps]
    return [*(getattr(f, "source", None) for f in fields), *paths]


# -- convert ------------------------------------------------------------------
def cmd_convert(args: argparse.Namespace) -> int:
    from ..examples import resolve_dem
    from ..io import MESH_EXTENSIONS, save_dem, save_mesh

    out = Path(args.output)
    _check_output_file(out)
    _check_cog(args, out)
    is_mesh = out.suffix.lower() in MESH_EXTENSIONS
    if (args.texture or args.triangles) and not is_mesh:
        raise TerraSynthError(f"--texture and --triangles are for meshes; {out} is not one "
                              f"({', '.join(MESH_EXTENSIONS)})")
    if args.texture and out.suffix.lower() != ".glb":
        raise TerraSynthError(f"--texture needs a .glb output, got {out}")
    field = resolve_dem(args.input, size=args.size, band=args.band)
    _refuse_replacing(args, [out], _sources([field]))  # (the file a builtin:KEY names too)
    if args.cell_size is not None:
        if field.cell_size is not None:
            raise TerraSynthError(f"{args.input} has cells of {field.cell_size[0]:g} x {field.cell_size[1]:g} m "
                                  f"already; --cell-size is for an input without a cell size")
        field = field.with_heights(field.heights, cell_size=(args.cell_size, args.cell_size))
    if is_mesh:
        texture = None
        if args.texture:
            from ..pictures import shaded_relief

            # The app's colours: the height ramp under the hillshade.
            texture = shaded_relief(field.heights, cell_size=field.cell_size)[..., :3]
        save_mesh(field, out, vertical_scale=args.vertical_scale, target_triangles=args.triangles,
                  texture=texture)
    else:
        save_dem(field, out, cog=args.cog)
    print(f"wrote {out} ({field.shape[0]} x {field.shape[1]})", file=sys.stderr)
    _note_assumed_cell(field, out)
    if out.suffix.lower() == ".ter" and field.nodata_count:
        print(f"terrasynth-cli: note: Terragen has no nodata: {field.nodata_count} nodata cells of {args.input} "
              f"were written as the minimum height {field.min:g} m", file=sys.stderr)
    return EXIT_OK


# -- export and masks -----------------------------------------------------------
def cmd_export(args: argparse.Namespace) -> int:
    from ..examples import resolve_dem
    from ..export import export_for_engine
    from ..export.engines import check_stem, export_file_for_engine

    check_stem(args.name)
    if Path(args.input).is_file():
        # Read window by window where the format allows: a world-size
        # terrain's tiles are cut without holding it whole.
        done = export_file_for_engine(args.input, args.preset, args.out, size=args.size, tiles=args.tiles,
                                      stem=args.name, band=args.band, input_size=args.input_size)
    else:
        field = resolve_dem(args.input, size=args.input_size, band=args.band)
        done = export_for_engine(field, args.preset, args.out, size=args.size, tiles=args.tiles, stem=args.name)
    _said_export(done)
    return EXIT_OK


def _said_export(done) -> None:
    """An engine export's notes, files and the numbers to type into the engine."""
    for note in done.notes:
        print(f"terrasynth-cli: note: {note}", file=sys.stderr)
    heightmaps = [f for f in done.files if f.name in done.settings["files"]]
    settings = done.files[-1]
    print(f"wrote {len(heightmaps)} heightmap{'s' * (len(heightmaps) > 1)} and {settings}", file=sys.stderr)
    print(done.summary())


def cmd_masks(args: argparse.Namespace) -> int:
    from ..examples import resolve_dem
    from ..export import terrain_masks, write_masks
    from ..export.engines import check_stem, engine_ready, longer_side_shape, preset_grid
    from ..io.resample import resample_nodes

    check_stem(args.name)
    field = resolve_dem(args.input, size=args.input_size, band=args.band)
    notes = []
    if args.preset is not None:
        # The very grid `export --preset` writes, so masks and heightmap match cell for cell.
        field, _, notes = preset_grid(field, args.preset, size=args.size)
    elif args.size is not None:
        # The EXR presets' rule: SIZE samples on the longer side, square cells.
        ready, notes = engine_ready(field)
        field = resample_nodes(ready, longer_side_shape(ready, args.size))
    for note in notes:
        print(f"terrasynth-cli: note: {note}", file=sys.stderr)
    masks = terrain_masks(field, sea_level=args.sea_level)
    written = write_masks(masks, args.out, fmt=args.format, stem=args.name)
    for note in masks.notes:
        print(f"terrasynth-cli: note: {note}", file=sys.stderr)
    print(f"wrote {len(written) - 1} masks ({field.shape[0]} x {field.shape[1]}, {args.format}) and "
          f"{written[-1]}", file=sys.stderr)
    return EXIT_OK


# -- features -----------------------------------------------------------------
def cmd_features(args: argparse.Namespace) -> int:
    import numpy as np

    from ..features import FeatureMaps, extract_features, read_sketch, sketch_features
    from ..pictures import render_overlay, save_png

    if args.overlay and Path(args.overlay).suffix.lower() != ".png":
        raise TerraSynthError(f"--overlay writes a PNG picture: give a .png file, got {args.overlay}")
    stages = _Stages(3, "features")
    try:
        if args.sketch:
            sketch = read_sketch(args.input)
            _refuse_replacing(args, [p for p in (args.json, args.overlay) if p])
            stages.step("read sketch")
            maps = sketch_features(sketch)
            heights = np.where(sketch.ridge_mask, 1.0, np.where(sketch.valley_mask, -1.0, 0.0)).astype(np.float32)
            cell_size = None
        else:
            from ..examples import resolve_dem

            field = resolve_dem(args.input, size=args.size, band=args.band)
            # (Inputs: the file a builtin:KEY names too.)
            _refuse_replacing(args, [p for p in (args.json, args.overlay) if p], _sources([field]))
            stages.step("read DEM")
            maps = extract_features(field, kind=args.kind)
            heights, cell_size = field.heights, field.cell_size
        stages.step("extracted")
        if args.kind != "both":
            empty = maps.valleys if args.kind == "ridge" else maps.ridges
            empty = type(empty)(empty.kind, empty.shape, (), ())
            maps = FeatureMaps(maps.ridges, empty) if args.kind == "ridge" else FeatureMaps(empty, maps.valleys)
        if args.json:
            _write_json_atomic(Path(args.json), maps.to_dict())
        if args.overlay:
            save_png(render_overlay(heights, maps, cell_size=cell_size), args.overlay, colours=256)
        stages.step("written")
    finally:
        stages.close()
    for g in (maps.ridges, maps.valleys):
        if args.kind in ("both", g.kind):
            print(
                f"{g.kind}s: {g.count('branch')} branch points, {g.count('end')} endpoints, "
                f"{len(g.paths)} paths, {g.total_length():.0f} cells long",
                file=sys.stderr,
            )
    return EXIT_OK


# -- synth / demo -------------------------------------------------------------
def cmd_synth(args: argparse.Namespace) -> int:
    if args.tile is not None or args.scheduler is not None:
        return _synth_tiled(args)
    given = [o for o in ("engine", "engine_tiles", "engine_size") if getattr(args, o) is not None]
    if given:
        raise TerraSynthError(f"--{given[0].replace('_', '-')} is for a tiled run's terrain (--tile); for a "
                              "whole-map run, export its output: 'terrasynth-cli export OUT --preset PRESET --out DIR'")
    if args.keep_tiles:
        raise TerraSynthError("--keep-tiles keeps a tiled synthesis's tiles: give the tile size too (--tile 1024)")
    if args.project:
        return _synth_project(args)
    _fill_run_defaults(args)
    if not args.example and not args.styles:
        raise TerraSynthError("give at least one --example DEM (a file or builtin:KEY), or --styles with --style")
    if not args.sketch and not args.styles and not args.size:
        raise TerraSynthError("give a --sketch (or --styles, or an output --size for a sketch-free run)")
    from ..synthesis.variations import MAX_VARIATIONS

    if not 1 <= args.variations <= MAX_VARIATIONS:
        raise TerraSynthError(f"--variations must be 1 to {MAX_VARIATIONS}, got {args.variations}")
    examples, sketch, params, controls = _run_inputs(args)
    return _synthesize(examples, sketch, args.size, params, args, controls)


def _run_inputs(args: argparse.Namespace):
    """The examples, sketch, parameters and controls the run options give
    (after :func:`_fill_run_defaults` and the caller's checks)."""
    from ..examples import resolve_dem
    from ..features import read_sketch
    from ..synthesis import SynthesisParams

    from .controls import controls_from_args

    examples = [resolve_dem(e, band=args.band) for e in args.example or ()]
    sketch = read_sketch(args.sketch) if args.sketch else None
    params = SynthesisParams(
        patch_size=args.patch_size, seed=args.seed, order=args.order, seam=args.seam, blend=args.blend,
        cell_size=args.cell_size, drainage=not args.no_drainage, landform=not args.no_landform,
        **({"overlap": args.overlap} if args.overlap is not None else {}),
    )
    # The style map and water mask as painted: a run scales them to its output.
    return examples, sketch, params, controls_from_args(args, have_examples=bool(examples))


#: ``synth`` options that set up a run, and their defaults; given with
#: ``--project`` they would contradict the project (which holds them all).
_RUN_OPTIONS = {"example": None, "sketch": None, "patch_size": None, "overlap": None, "order": "bfs", "seam": "cut",
                "blend": "c1", "cell_size": None, "no_drainage": None, "no_landform": None, "band": None, "styles": None, "style": None,
                "water": None, "water_level": None, "water_depth": None, "bank_width": None, "stamp": None,
                "pin": None, "pin_radius": None, "height_range": None}


def _fill_run_defaults(args: argparse.Namespace) -> None:
    """The defaults of the run options (None in the parser, so ``--project`` can tell what was given)."""
    for name, default in _RUN_OPTIONS.items():
        if getattr(args, name) is None:
            setattr(args, name, [] if name in ("style", "stamp", "pin") else default)
    args.no_drainage = bool(args.no_drainage)
    args.no_landform = bool(args.no_landform)
    if args.seed is None:
        args.seed = 0


#: ``synth`` options a tiled run does not take (a tiled run streams one
#: GeoTIFF and never holds the whole terrain), with why.
_NOT_TILED = {"variations": "run the command once per seed",
              "report": "its patch list is one whole-map run's; run without --tile for a report",
              "debug_dir": "its stage pictures are one whole-map run's; run without --tile for them",
              "cog": "a tiled run streams a tiled, compressed GeoTIFF; make a Cloud-Optimized copy of it with "
                     "'terrasynth-cli convert OUT.tif OUT_cog.tif --cog'",
              "height_range": "it maps the whole terrain's lowest and highest cells; map the GeoTIFF afterwards"}

#: Ends a message about a synth option's value.
_SYNTH_HELP = " (see 'terrasynth-cli synth --help')"


def _synth_tiled(args: argparse.Namespace) -> int:
    """``synth --tile N [--size RxC] [--workers N | --scheduler ADDR]``: the
    output synthesized as tiles on Dask (:mod:`terrasynth_core.tiled`)."""
    from tqdm import tqdm

    from ..tiled import TileFinished, check_scheduler, run_tiled, tiled_project_inputs
    from ..tiled.run import check_tiled_output

    if args.tile is None:
        raise TerraSynthError("--scheduler runs a tiled synthesis: give the tile size too (--tile 1024)")
    tile = _tile_size(args.tile)
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
        if args.workers is not None:
            raise TerraSynthError("--workers starts a local cluster; with --scheduler the cluster's workers are used"
                                  + _SYNTH_HELP)
    for name, how in _NOT_TILED.items():
        value = getattr(args, name, None)
        if value not in (None, [], False) and not (name == "variations" and value == 1):
            option = "--" + name.replace("_", "-")
            raise TerraSynthError(f"{option} is not available with --tile: {how}")
    if args.workers is not None and args.workers < 1:
        raise TerraSynthError(f"--workers must be at least 1, got {args.workers}" + _SYNTH_HELP)
    out = check_tiled_output(Path(args.out))
    if args.project:
        spec = _project_spec(args, "--out, --size, --seed, --tile, --workers, --scheduler, --keep-tiles, --engine")
        examples, sketch, params, controls = tiled_project_inputs(spec)
        size = spec.shape
    else:
        examples, sketch, params, size, controls = _tiled_run_options(args)
    _refuse_replacing(args, [out], _sources(examples, controls))
    engine_dir = _engine_folder(args, out, size)
    bar = tqdm(total=0, desc="tiles", unit="tile", file=sys.stderr, disable=None, leave=False)

    def progress(event) -> None:
        if isinstance(event, TileFinished):
            bar.total = event.total
            bar.update(event.done - bar.n)
            if event.reused and event.done == event.total:
                bar.set_postfix_str("all kept from the last run")

    try:
        result = run_tiled(examples, sketch, shape=size, tile=tile, out=out, params=params, workers=args.workers,
                           scheduler=args.scheduler, keep_tiles=args.keep_tiles, progress=progress,
                           controls=controls)
    finally:
        bar.close()
    for note in result.notes:
        print(f"terrasynth-cli: note: {note}", file=sys.stderr)
    rows, cols = result.shape
    grid = "x".join(str(v) for v in result.plan.grid)
    kept = f", {result.reused} reused from an earlier run of the same inputs" if result.reused else ""
    print(f"wrote {out}: {rows}x{cols} in {grid} tiles of {tile} on {result.workers} worker(s) in "
          f"{result.seconds:.1f} s{kept}; heights {result.lowest:.1f} .. {result.highest:.1f} m", file=sys.stderr)
    if engine_dir is not None:
        from ..export.engines import export_file_for_engine

        tiles = args.engine_tiles or 1
        try:
            done = export_file_for_engine(out, args.engine, engine_dir, size=args.engine_size, tiles=tiles,
                                          stem=out.stem)
        except TerraSynthError as exc:
            again = (f"terrasynth-cli export {out} --preset {args.engine} --tiles {tiles} --name {out.stem} "
                     f"--out {engine_dir}" + (f" --size {args.engine_size}" if args.engine_size else ""))
            raise type(exc)(f"{exc} ({out} is written: make the {args.engine} files with '{again}')") from exc
        _said_export(done)
    return EXIT_OK


def _engine_folder(args: argparse.Namespace, out: Path, size: tuple[int, int]) -> Path | None:
    """Where ``synth --tile ... --engine PRESET`` writes the engine's files
    (``OUTSTEM_PRESET`` beside the output), checked before the run: a long
    run never ends on a refused option, grid size or folder."""
    if args.engine is None:
        if args.engine_tiles is not None or args.engine_size is not None:
            raise TerraSynthError("--engine-tiles and --engine-size go with --engine PRESET" + _SYNTH_HELP)
        return None
    from ..export.engines import check_export, folder_beside

    folder = folder_beside(out, args.engine)
    check_export(args.engine, folder, shape=size, size=args.engine_size, tiles=args.engine_tiles or 1,
                 stem=out.stem, hint="remove it, or choose another --out (the folder is named after it)")
    return folder


def _tiled_run_options(args: argparse.Namespace):
    """The examples, sketch, parameters, size and controls of ``synth --tile`` without a project."""
    _fill_run_defaults(args)
    if not args.example and not args.styles:
        raise TerraSynthError("give at least one --example DEM (a file or builtin:KEY), or --styles with --style")
    if not args.size and not args.sketch:
        raise TerraSynthError("give the output --size (ROWSxCOLS) or a --sketch")
    examples, sketch, params, controls = _run_inputs(args)
    size = tuple(args.size) if args.size else sketch.shape
    return examples, sketch, params, size, controls


def _tile_size(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise TerraSynthError(f"--tile {text!r}: expected a tile side in cells, a positive whole number such as 1024"
                              + _SYNTH_HELP)
    return value


def _synth_project(args: argparse.Namespace) -> int:
    """``synth --project FILE.tsproj``: render a saved project as the app's
    *Synthesize* would (its examples, sketch, styles, water, stamps, pins and
    parameters), optionally at another ``--size`` and ``--seed``."""
    from ..synthesis.variations import MAX_VARIATIONS

    def check() -> None:
        if not 1 <= args.variations <= MAX_VARIATIONS:
            raise TerraSynthError(f"--variations must be 1 to {MAX_VARIATIONS}, got {args.variations}")
        _check_output(args)

    spec = _project_spec(args, "--out, --size, --seed, --variations, --workers, --cog, --report, --debug-dir",
                         before_reading=check)
    return _synthesize(spec.example_fields(), spec.sketch_map, spec.shape, spec.params, args, spec.make_controls())


def _project_spec(args: argparse.Namespace, allowed: str, *, before_reading=None):
    """The run of ``--project FILE``, at ``--size`` and with ``--seed`` when
    given (pins and stamps follow the sketch, as in the app).

    Parameters
    ----------
    allowed : str
        The options that may come with ``--project``, for the error that
        names one that may not.
    before_reading : callable, optional
        Checks to make once the options are known good, before the file is
        read.
    """
    import dataclasses

    from ..project import read_project

    given = [name for name in _RUN_OPTIONS if getattr(args, name) not in (None, [])]
    if given:
        option = "--" + given[0].replace("_", "-")
        raise TerraSynthError(f"{option} cannot be combined with --project {args.project}: the project holds the "
                              f"examples, sketch, controls and parameters (with it give only {allowed})")
    if before_reading is not None:
        before_reading()
    project = read_project(args.project)
    spec = project.run_spec()
    if args.seed is not None:
        spec = dataclasses.replace(spec, params=dataclasses.replace(spec.params, seed=args.seed))
    return spec.at_size(tuple(args.size) if args.size else project.shape)


def cmd_demo(args: argparse.Namespace) -> int:
    from ..examples import DEFAULT_EXAMPLE, DEFAULT_SKETCH, builtin_example, resource_path
    from ..features import read_sketch
    from ..synthesis import SynthesisParams

    if args.map != "default":
        from ..presets import load_preset

        preset = load_preset(args.map)
        params = SynthesisParams(seed=args.seed, cell_size=preset.cell_size)
        return _synthesize([], preset.sketch, preset.shape, params, args, preset.controls)
    examples = [builtin_example(DEFAULT_EXAMPLE).load()]
    path = resource_path("sketches", DEFAULT_SKETCH)
    return _synthesize(examples, read_sketch(path), None, SynthesisParams(seed=args.seed), args, inputs=[path])


def _synthesize(examples, sketch, size, params, args, controls=None, *, inputs=()) -> int:
    """Run and write a whole-map synthesis; ``inputs``: files it reads that
    neither the options nor the loaded DEMs name (the demo's sketch)."""
    import dataclasses

    from tqdm import tqdm

    from ..synthesis import LandformProgress, PatchPlaced, Session, StageStarted, SynthesisFinished

    from ..project import check_stamp_footprints

    # (With what was loaded: a project's DEMs, a built-in's file.)
    out = _check_output(args, _sources(examples, controls, *inputs))
    if getattr(args, "workers", None) is not None:
        if args.workers < 1:
            raise TerraSynthError(f"--workers must be at least 1, got {args.workers}" + _SYNTH_HELP)
        params = dataclasses.replace(params, workers=args.workers)
    check_stamp_footprints(controls, examples, params.cell_size)
    session = Session(examples, sketch, shape=size, params=params, controls=controls)
    for w in session.warnings:
        print(f"terrasynth-cli: note: {w}", file=sys.stderr)
    save = dict(cog=getattr(args, "cog", False))
    if getattr(args, "variations", 1) > 1:
        return _variations(examples, sketch, size, params, controls, args, save)
    bar = tqdm(total=0, desc="analyse", unit="patch", file=sys.stderr, disable=None, leave=False)
    result = None
    try:
        for event in session.iter_run():
            if isinstance(event, StageStarted):
                bar.set_description(event.stage)
                if event.stage == "analyse":  # the landform pass counted its own patches
                    bar.reset(total=0)
            elif isinstance(event, LandformProgress):
                bar.total = event.total
                bar.update(event.done - bar.n)
            elif isinstance(event, PatchPlaced):
                bar.total = event.total
                bar.update(event.index + 1 - bar.n)
            elif isinstance(event, SynthesisFinished):
                result = event.result
    finally:
        bar.close()
    _save_result(result, out, **save)
    if args.report:
        # Example indices of the patches: the plain examples, then the styles'.
        names = [getattr(e, "source", None) for e in [*examples, *(s.example for s in session.controls.styles)]]
        report = result.report(names)
        report["examples"] = names[:len(examples)]
        _after_output(out, f"the report {args.report}", lambda: _write_json_atomic(Path(args.report), report))
    if getattr(args, "debug_dir", None):
        _after_output(out, f"the debug folder {args.debug_dir}", lambda: _write_debug(result, Path(args.debug_dir)))
    _summary(result, out, session.warnings)
    return EXIT_OK


def _check_output_file(out: Path) -> None:
    """Refuse an output path that is a folder, or in a folder that does not
    exist (one line, before any work)."""
    if out.is_dir():
        raise TerraSynthError(f"{out} is a folder; give a file name for the output (in it or elsewhere)")
    if not out.parent.is_dir():
        raise TerraSynthError(f"cannot write {out}: folder {out.parent} does not exist")


def _check_writable(out: Path) -> None:
    """Refuse an output whose folder takes no new file (read-only, full of
    permissions), before the run: found only when the result is written,
    it cost the whole synthesis.  A probe file is made and removed, as the
    writer will make its temporary file there."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".terrasynth-probe-", dir=out.parent)
    except OSError as exc:
        raise TerraSynthError(f"cannot write {out}: folder {out.parent} takes no new file "
                              f"({exc.strerror or exc})") from exc
    os.close(fd)
    os.unlink(probe)


def _check_output(args, inputs=()) -> Path:
    """``--out`` (and ``--report``), checked before the run so a typo in the
    path does not cost a whole synthesis; ``inputs`` as for
    :func:`_refuse_replacing`."""
    from ..io import MESH_EXTENSIONS, WRITE_EXTENSIONS

    out = Path(args.out)
    _check_output_file(out)
    if out.suffix.lower() not in WRITE_EXTENSIONS + MESH_EXTENSIONS:
        raise TerraSynthError(
            f"cannot write {out}: unknown extension {out.suffix!r}; expected one of "
            + ", ".join(WRITE_EXTENSIONS + MESH_EXTENSIONS)
        )
    _check_writable(out)
    _check_cog(args, out)
    _check_report_path(args, out)
    debug = getattr(args, "debug_dir", None)
    if debug and Path(debug).exists() and not Path(debug).is_dir():
        raise TerraSynthError(f"--debug-dir {debug} is a file; give a folder (it is created if missing)")
    _refuse_replacing(args, _run_outputs(args, out), inputs)
    return out


def _run_outputs(args, out: Path) -> list[Path]:
    """The files a run writes: ``out`` (or its variations) and the report."""
    outs = _variation_paths(out, args.variations) if getattr(args, "variations", 1) > 1 else [out]
    return [*outs, *([Path(args.report)] if getattr(args, "report", None) else [])]


def _check_report_path(args, out: Path) -> None:
    """Refuse a ``--report`` that would be this run's output's sidecar, before the run (another
    heightmap's: :func:`_refuse_replacing`)."""
    from ..io import sidecar_of

    if not getattr(args, "report", None):
        return
    report = Path(args.report)
    outs = [out]
    if getattr(args, "variations", 1) > 1:
        outs = _variation_paths(out, args.variations)
    for o in outs:
        side = sidecar_of(o)
        if side is not None and report.resolve() == side.resolve():
            raise TerraSynthError(f"--report {report} is the sidecar of the output {o} (its metres and "
                                  "cell size); give the report another name")


def _after_output(out: Path, what: str, write) -> None:
    """Run ``write`` (an extra output); on failure say that ``out`` was written and ``what`` was not."""
    try:
        write()
    except (TerraSynthError, OSError) as exc:
        detail = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise TerraSynthError(f"wrote {out}, but {what} could not be written: {detail}") from None


def _save_result(result, out: Path, *, cog: bool = False) -> None:
    """Write the heights with the run's square cell size and map placement
    (:meth:`SynthesisResult.to_heightfield`)."""
    from ..io import MESH_EXTENSIONS, save_dem, save_mesh

    field = result.to_heightfield(source=str(out))
    if out.suffix.lower() in MESH_EXTENSIONS:
        save_mesh(field, out)
    else:
        save_dem(field, out, cog=cog)
    _note_assumed_cell(field, out)


def _note_assumed_cell(field, out: Path) -> None:
    """Say so when ``out``'s format had to state a cell size ``field`` does not have."""
    from ..io import assumed_cell_size

    cell = assumed_cell_size(field, out)
    if cell is not None:
        print(f"terrasynth-cli: note: the heights have no cell size, but {out.suffix} states one: "
              f"written with cells of {cell:g} m (convert --cell-size M states it; .tif and .npy "
              f"can leave it unknown)", file=sys.stderr)


def _summary(result, out: Path, said: list[str]) -> None:
    """One line per output, pin errors, and warnings not said before."""
    counts = ", ".join(f"{v} {k}" for k, v in result.counts().items() if v)
    cell = "" if result.cell_size is None else f" cells of {result.cell_size:g} m,"
    print(f"wrote {out}: {result.heights.shape[0]}x{result.heights.shape[1]}{cell} in {result.total_seconds:.1f} s "
          f"({counts} patches)", file=sys.stderr)
    span = float(result.heights.max() - result.heights.min()) or 1.0
    for e in result.pin_errors:
        print(f"  pin ({e.row}, {e.col}): wanted {e.target:.1f} m, got {e.height:.1f} m "
              f"(error {e.error:+.3f} m, {100 * abs(e.error) / span:.4f} % of the height range)", file=sys.stderr)
    for w in result.warnings:
        if w not in said:
            print(f"terrasynth-cli: note: {w}", file=sys.stderr)


def _variation_paths(out: Path, n: int) -> list[Path]:
    """Where ``--variations N`` writes: OUT_v1 .. OUT_vN beside OUT."""
    return [out.with_name(f"{out.stem}_v{i}{out.suffix}") for i in range(1, n + 1)]


def _variations(examples, sketch, size, params, controls, args, save: dict) -> int:
    """``--variations N``: seeds SEED..SEED+N-1, one per core at a time, OUT_v1.. OUT_vN."""
    from ..synthesis import run_variations

    out = Path(args.out)
    seeds = [params.seed + i for i in range(args.variations)]
    paths = _variation_paths(out, len(seeds))
    at_once = min(len(seeds), os.cpu_count() or 1)
    print(f"terrasynth-cli: {len(seeds)} variations (seeds {seeds[0]}-{seeds[-1]}), {at_once} at a time",
          file=sys.stderr)

    def done(i, result):
        _save_result(result, paths[i], **save)
        _summary(result, paths[i], [])

    results = run_variations(examples, sketch, seeds=seeds, shape=size, params=params, controls=controls,
                             progress=done)
    if args.report:
        _write_json_atomic(Path(args.report), {"variations": [
            dict(r.report(), seed=s, file=str(p)) for r, s, p in zip(results, seeds, paths)]})
    return EXIT_OK


def _write_debug(result, folder: Path) -> None:
    """Patch ids, seams and the sketch's features as pictures and arrays."""
    import numpy as np

    from ..io._common import atomic_outputs, open_new
    from ..pictures import grey_hillshade, patch_colours, render_overlay, save_png

    folder.mkdir(parents=True, exist_ok=True)
    for name, array in (("patch_id.npy", result.patch_id), ("seam_mask.npy", result.seam_mask)):
        # Atomic, as every output: a full disk leaves no truncated array.
        with atomic_outputs(folder / name) as (tmp,), open_new(tmp) as f:
            np.save(f, array, allow_pickle=False)
    save_png(patch_colours(result.patch_id), folder / "patch_id.png")
    rgb = np.repeat(grey_hillshade(result.heights)[..., None], 3, axis=2)
    rgb[result.seam_mask] = (255, 200, 0)
    save_png(rgb, folder / "seams.png")
    save_png(render_overlay(result.heights, result.sketch_features), folder / "sketch_features.png", colours=256)
    _write_json_atomic(folder / "patches.json", {"patches": [
        {"kind": p.kind, "feature": p.feature, "bbox": list(p.bbox), "example": p.example,
         "source": list(p.source), "mirrored": p.mirrored, "deformation": p.deformation,
         "ssd": p.ssd, "seam_cost": p.seam_cost, "cost": p.cost}
        for p in result.patches]})


def _write_json_atomic(path: Path, data: dict) -> None:
    from ..io._common import atomic_outputs, check_not_sidecar, open_new

    check_not_sidecar(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_outputs(path) as (tmp,), open_new(tmp) as f:
        f.write(json.dumps(data).encode("utf-8"))


# -- entry point --------------------------------------------------------------
class _Parser(argparse.ArgumentParser):
    """argparse, but a bad option is one line (no usage block before it)."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="terrasynth-cli",
        description="Example-based terrain synthesis from real DEMs. "
        "A DEM argument is a file or builtin:KEY (see 'terrasynth-cli examples').",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("info", help="shape, height range, nodata and cell size of a DEM")
    p.add_argument("dem")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.add_argument("--size", type=parse_size, help="ROWSxCOLS of a headerless .r16/.r32")
    _add_band(p)
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("convert", help="convert a DEM between formats (by extension), or to a mesh")
    p.add_argument("input")
    p.add_argument("output")
    _add_overwrite(p)
    p.add_argument("--size", type=parse_size, help="ROWSxCOLS of a headerless .r16/.r32 input")
    p.add_argument("--cell-size", type=positive_metres, metavar="M",
                   help="the input's cell size in metres, for an input without one (.npy, .png, .r16)")
    p.add_argument("--vertical-scale", type=float, default=1.0, help="height multiplier for meshes")
    p.add_argument("--triangles", type=positive_count, metavar="N",
                   help="meshes: simplify to about N triangles (fewer where the ground is flat)")
    p.add_argument("--texture", action="store_true",
                   help=".glb: drape the height colours under the hillshade (stored in the file)")
    _add_band(p)
    _add_cog(p)
    p.set_defaults(func=cmd_convert)

    p = sub.add_parser("export", help="heightmaps for a game engine or DCC tool (unreal, unity, godot, "
                                      "blender, houdini), with their import settings")
    p.add_argument("input", help="a DEM (any readable format, a synth output, or builtin:KEY)")
    p.add_argument("--preset", required=True, choices=PRESET_NAMES)
    p.add_argument("--out", required=True, metavar="DIR", help="output folder; existing files are never replaced")
    p.add_argument("--size", type=positive_count, metavar="N",
                   help="samples a side per tile (unreal: 127..8129, unity: 33..4097 = 2^n+1), or on the longer "
                        "side (EXR presets); default: the smallest that keeps every sample")
    p.add_argument("--tiles", type=positive_count, default=1, metavar="K", help="a K x K grid of tiles "
                   "sharing their edges, named _x{i}_y{j} (unreal, unity)")
    p.add_argument("--name", default="terrain", help="start of the file names (default terrain)")
    p.add_argument("--input-size", type=parse_size, help="ROWSxCOLS of a headerless .r16/.r32 input")
    _add_band(p)
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("masks", help="masks (splat maps): slope, curvature, flow, wetness, water, height bands, "
                                     "normal map")
    p.add_argument("input", help="a DEM (any readable format, a synth output, or builtin:KEY)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder; existing files are never replaced")
    p.add_argument("--format", choices=MASK_FORMATS, default="png8")
    p.add_argument("--size", type=positive_count, metavar="N",
                   help="samples on the longer side (default: the DEM's own grid); with --preset, its size")
    p.add_argument("--preset", choices=PRESET_NAMES,
                   help="make the masks on the grid 'export --preset' writes (same --size), cell for cell")
    p.add_argument("--sea-level", type=float, default=0.0, metavar="M",
                   help="water mask: cells at or below this height (default 0 m)")
    p.add_argument("--name", default="terrain", help="start of the file names (default terrain)")
    p.add_argument("--input-size", type=parse_size, help="ROWSxCOLS of a headerless .r16/.r32 input")
    _add_band(p)
    p.set_defaults(func=cmd_masks)

    p = sub.add_parser("features", help="ridges and valleys (PPA) of a DEM or a sketch")
    p.add_argument("input", help="a DEM, or a sketch PNG with --sketch")
    p.add_argument("--sketch", action="store_true", help="INPUT is a sketch map (red ridges, blue valleys)")
    p.add_argument("--kind", choices=("ridge", "valley", "both"), default="both")
    p.add_argument("--json", metavar="OUT.json", help="write the feature graphs as JSON")
    p.add_argument("--overlay", metavar="OUT.png", help="write a hillshade with ridges red, valleys blue")
    _add_overwrite(p)
    p.add_argument("--size", type=parse_size, help="ROWSxCOLS of a headerless .r16/.r32 input")
    _add_band(p)
    p.set_defaults(func=cmd_features)

    p = sub.add_parser("synth", help="synthesize a terrain from example DEMs and a sketch, or a saved project")
    p.add_argument("--project", metavar="FILE.tsproj",
                   help="render a project saved by the app, as its Synthesize would (examples, sketch, styles, "
                        "water, stamps, pins, parameters); with --size the sketch, pins and stamps are scaled")
    p.add_argument("--example", action="append", metavar="DEM",
                   help="example DEM (repeatable); with --styles, the style of unlisted colours")
    p.add_argument("--sketch", help="sketch PNG: red ridges, blue valleys")
    p.add_argument("--out", required=True, help="output file; the format follows the extension")
    _add_overwrite(p)
    p.add_argument("--size", type=parse_size, help="output ROWSxCOLS, or N for NxN (default: the sketch's; it is scaled)")
    # Run options default to None here (their defaults: _RUN_OPTIONS), so
    # --project can tell which were given.
    p.add_argument("--patch-size", type=int,
                   help="patch side in cells (default: automatic, 80, or down to 32 for a small example)")
    p.add_argument("--overlap", type=int, default=None, help="overlap in cells (default a third of the patch)")
    p.add_argument("--seed", type=int, help="random seed (default 0; with --project, the project's)")
    p.add_argument("--order", choices=("bfs", "raster"), help="patch order (default bfs)")
    p.add_argument("--seam", choices=("cut", "paste"), help="seams (default cut)")
    p.add_argument("--no-drainage", action="store_true", default=None,
                   help="leave the finished heights as synthesized (default: painted valleys drain, ridges divide)")
    p.add_argument("--no-landform", action="store_true", default=None,
                   help="one pass on a flat level, as in the paper (default: a coarse landform pass first)")
    p.add_argument("--blend", choices=("poisson", "c1", "none"), help="seam blend (default c1)")
    p.add_argument("--cell-size", type=positive_metres, metavar="M",
                   help="output cell size in metres, square (default: the finest example's)")
    _add_band(p, "band of every --example DEM (1-based; needed for multi-band files)")
    _add_cog(p)
    p.add_argument("--report", metavar="REPORT.json",
                   help="parameters, patch counts, timings, the source reuse and every patch as JSON")
    p.add_argument("--debug-dir", metavar="DIR", help="write patch ids, seams and features there")
    p.add_argument("--workers", type=int, metavar="N",
                   help="processes that fill windows (default: one per core; the terrain is the same); with --tile, "
                        "the Dask workers of the local cluster")
    p.add_argument("--tile", metavar="N",
                   help="synthesize the output in tiles of N x N cells on Dask (world-size terrains; GeoTIFF output, "
                        "resumable: finished tiles are kept in OUT.tiles until the output is written)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="with --tile: run on the Dask cluster of this scheduler (tcp://host:8786) instead of "
                        "local worker processes")
    p.add_argument("--keep-tiles", action="store_true", help="with --tile: keep OUT.tiles after the output is written")
    p.add_argument("--engine", choices=PRESET_NAMES, metavar="PRESET",
                   help="with --tile: also write the terrain for this engine or tool (" + ", ".join(PRESET_NAMES)
                        + ") into OUTSTEM_PRESET/, as 'export' does: tiles cut from the GeoTIFF window by window "
                          "(an EXR is one whole grid)")
    p.add_argument("--engine-tiles", type=positive_count, metavar="K",
                   help="with --engine: a K x K grid of engine tiles named _x{i}_y{j} (unreal, unity; default 1)")
    p.add_argument("--engine-size", type=positive_count, metavar="N",
                   help="with --engine: samples a side per engine tile (unreal, unity; default: the smallest that "
                        "keeps every sample), or on the longer side (EXR presets, up to 16384; default: the "
                        "output's)")
    add_control_arguments(p)
    p.set_defaults(func=cmd_synth)

    p = sub.add_parser("demo", help="synthesize the built-in example with the built-in sketch")
    p.add_argument("--map", choices=("default", "middle-earth"), default="default",
                   help="middle-earth: four styles, water, a stamp and pins (the paper's Middle-earth map)")
    p.add_argument("--out", required=True)
    _add_overwrite(p)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--report", metavar="REPORT.json")
    p.add_argument("--debug-dir", metavar="DIR")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("examples", help="list the built-in example DEMs and sketches")
    p.set_defaults(func=cmd_examples)
    return parser


def positive_metres(text: str) -> float:
    """A cell size: a positive finite number of metres."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (0 < value < float("inf")):
        raise argparse.ArgumentTypeError(f"cell size {text!r} is not a positive number of metres")
    return value


def positive_count(text: str) -> int:
    """A whole number >= 1 (a size, a tile count, a triangle count)."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number >= 1")
    return value


def positive_band(text: str) -> int:
    """A band number, 1-based."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"band {text!r} is not a band number (1, 2, ...)")
    return value


def _add_band(p: argparse.ArgumentParser, text: str = "band to read (1-based; needed for multi-band files)"):
    p.add_argument("--band", type=positive_band, metavar="N", help=text)


def _add_cog(p: argparse.ArgumentParser):
    p.add_argument("--cog", action="store_true", help="write a Cloud-Optimized GeoTIFF (.tif output only)")


def _add_overwrite(p: argparse.ArgumentParser):
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing output (never one of the command's inputs)")


def cmd_examples(args: argparse.Namespace) -> int:
    from ..examples import BUILTIN_EXAMPLES, builtin_sketches

    for ex in BUILTIN_EXAMPLES:
        print(f"builtin:{ex.key:<16} {ex.name}: {ex.style}")
    for path in builtin_sketches():
        print(f"sketch  {path}")
    return EXIT_OK


#: Options whose value may start with "-" (``--size -5x5``, ``--height-range -100,900``):
#: argparse would take such a value for an option and say "expected one argument".
_SIGNED_VALUE_OPTIONS = frozenset({"--size", "--height-range", "--pin", "--stamp", "--water-level", "--water-depth",
                                   "--bank-width", "--pin-radius", "--vertical-scale", "--seed", "--patch-size",
                                   "--overlap", "--variations", "--sea-level", "--tiles",
                                   "--triangles"})


def _join_signed_values(argv: list[str]) -> list[str]:
    """``["--size", "-5x5"]`` -> ``["--size=-5x5"]``, so the value reaches its parser."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        arg = argv[i]
        nxt = argv[i + 1] if i + 1 < len(argv) else None
        if arg in _SIGNED_VALUE_OPTIONS and nxt is not None and nxt.startswith("-") and not nxt.startswith("--"):
            out.append(f"{arg}={nxt}")
            i += 2
        else:
            out.append(arg)
            i += 1
    return out


def _terminated(signum, frame):
    """SIGTERM as Ctrl-C: unwinding runs the atomic writes' clean-up, so no temporary file stays."""
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(_join_signed_values(list(sys.argv[1:] if argv is None else argv)))
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _terminated)
    try:
        return _run(args)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _run(args: argparse.Namespace) -> int:
    try:
        code = _run_command(args)
    except BrokenPipeError:
        if args.command not in _STDOUT_COMMANDS:
            # A run's progress or notes had nowhere to go (``2>&1 | head``):
            # it stopped unfinished, so it must not look like a success.
            return EXIT_BROKEN_PIPE
        code = EXIT_OK  # what it printed is all the reader wanted
    try:
        sys.stdout.flush()  # (a reader that left shows here, not at exit)
    except BrokenPipeError:
        pass
    else:
        return code
    # The reader left (``| head``): end quietly, as Unix tools do; what is
    # still buffered goes nowhere instead of failing at exit.
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return code


def _run_command(args: argparse.Namespace) -> int:
    try:
        return args.func(args)
    except TerraSynthError as exc:
        print(f"terrasynth-cli: error: {_with_option(str(exc), args)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except FileNotFoundError as exc:
        print(f"terrasynth-cli: error: {exc.filename or exc}: no such file", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        raise  # (a reader that left, not bad input: see _run)
    except OSError as exc:
        print(f"terrasynth-cli: error: {exc.filename or ''}: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("terrasynth-cli: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _with_option(message: str, args: argparse.Namespace) -> str:
    """``message`` with the option to change named after a library
    parameter it names (``parameter patch_size=3`` -> ``(--patch-size)``,
    ``band=1..3`` -> ``--band``)."""
    import re

    match = re.match(r"parameter (\w+)=", message)
    if match and getattr(args, match.group(1), None) is not None:  # (given: not a project's own)
        message += f" (--{match.group(1).replace('_', '-')})"
    if hasattr(args, "band"):
        message = re.sub(r"\bwith band=", "with --band ", message)
    return message


if __name__ == "__main__":
    sys.exit(main())
