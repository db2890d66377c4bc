"""Project files: one ``.tsproj`` zip holding a whole design.

Layout of the zip::

    project.json        format, version, examples, params, sketch shape,
                        styles, water level, height range, pins, stamps,
                        result metadata (cell size, georeference, report,
                        feature graphs)
    sketch_ridge.npy    uint8 (rows, cols) stroke intensities
    sketch_valley.npy   uint8 (rows, cols)
    sketch_style.npy    int16 (rows, cols) style ids, -1 none (version 2)
    sketch_water.npy    bool (rows, cols) (version 2)
    selection.npy       bool (rows, cols), when cells are selected (version 3)
    result_heights.npy  float32 (rows, cols), when there is a result
    result_patch_id.npy int32
    result_seams.npy    bool

Version 1 files (before styles, water, pins and stamps) and version 2 files
(before the result's georeference and the selection) still load, without
them.  Every damage gives one :class:`~terrasynth_core.errors.ProjectError`
naming the file, and layer sizes are checked from the ``.npy`` headers
before anything is allocated.  Writes go to a temporary file in the
target's folder that then replaces the target, so a crash mid-save never
leaves a truncated project, and an interruption (Ctrl-C, SIGTERM turned
into an exception) removes the temporary file.

The app (``terrasynth_app.model.project``) turns a :class:`ProjectData` into
its document and back; ``terrasynth-cli synth --project`` runs
:meth:`ProjectData.run_spec`.
"""

from __future__ import annotations

import io
import json
import os
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ProjectError, TerraSynthError
from ..features import FeatureGraph, FeatureMaps
from ..heightfield import GeoReference
from ..io import atomic_outputs, open_new
from ..synthesis import Pin, SynthesisParams
from .refs import ExampleRef
from .run import RunSpec, run_spec
from .specs import StampSpec, StyleSpec

__all__ = ["FORMAT_NAME", "FORMAT_VERSION", "MAX_LAYER_CELLS", "PROJECT_EXTENSION", "ProjectData", "ProjectResult",
           "read_project", "write_project"]

#: Extension of project files.
PROJECT_EXTENSION = ".tsproj"
FORMAT_NAME = "terrasynth-project"
FORMAT_VERSION = 3
#: Largest side of a layer a project may hold, cells (the core's 64 M-cell output limit).
MAX_SIDE = 8000
#: Largest layer a project may hold, in cells.
MAX_LAYER_CELLS = MAX_SIDE * MAX_SIDE


@dataclass(frozen=True, eq=False)
class ProjectResult:
    """The last terrain a project keeps.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Metres.
    patch_id : ndarray of int32, shape (rows, cols)
        Patch each cell came from, -1 for none.
    seam_mask : ndarray of bool, shape (rows, cols)
    cell_size : (dy, dx) or None
        Ground size of a cell, metres.
    report : dict
        The run's JSON-ready summary.
    sketch_features : FeatureMaps or None
        The networks the run followed.
    georef : GeoReference or None
        The terrain's place on the map (the run's local projection).
    """

    heights: np.ndarray
    patch_id: np.ndarray
    seam_mask: np.ndarray
    cell_size: tuple[float, float] | None = None
    report: dict = field(default_factory=dict)
    sketch_features: FeatureMaps | None = None
    georef: GeoReference | None = None


@dataclass(frozen=True, eq=False)
class ProjectData:
    """Everything a project file holds, Qt-free and app-free.

    Parameters
    ----------
    ridge, valley : ndarray of uint8, shape (rows, cols)
        Stroke intensities.
    style : ndarray of int16, shape (rows, cols)
        Style id per cell, -1 none.
    water : ndarray of bool, shape (rows, cols)
    examples : tuple of ExampleRef
    params : SynthesisParams
    styles : tuple of StyleSpec
    next_style_id : int
        Lowest id a new style may take (ids are never reused).
    water_level : float
        Metres.
    height_range : (low, high) or None
    pins : tuple of Pin
    stamps : tuple of StampSpec
    result : ProjectResult or None
    selection : ndarray of bool, shape (rows, cols), or None
        Cells chosen for re-synthesis.
    """

    ridge: np.ndarray
    valley: np.ndarray
    style: np.ndarray
    water: np.ndarray
    examples: tuple[ExampleRef, ...]
    params: SynthesisParams
    styles: tuple[StyleSpec, ...] = ()
    next_style_id: int = 0
    water_level: float = 0.0
    height_range: tuple[float, float] | None = None
    pins: tuple[Pin, ...] = ()
    stamps: tuple[StampSpec, ...] = ()
    result: ProjectResult | None = None
    selection: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the sketch: the output's size."""
        return tuple(self.ridge.shape)

    def run_spec(self) -> RunSpec:
        """The run the app's *Synthesize* would make of this project.

        Raises
        ------
        ParamsError
            When no example is chosen and styles do not cover every cell.
        """
        return run_spec(ridge=self.ridge, valley=self.valley, style=self.style, water=self.water,
                        examples=self.examples, params=self.params, styles=self.styles,
                        water_level=self.water_level, height_range=self.height_range, pins=self.pins,
                        stamps=self.stamps)


# -- writing ------------------------------------------------------------------------
def write_project(data: ProjectData, path: str | os.PathLike) -> Path:
    """Write ``data`` to ``path`` atomically.

    DEM paths are stored absolute and relative to the project's folder, so
    the project finds them after moving alone or together with them.

    Returns
    -------
    Path

    Raises
    ------
    ProjectError
        When the file cannot be written (no file and no temporary is left).
    """
    path = Path(path)
    folder = path.parent
    arrays = {"sketch_ridge": data.ridge, "sketch_valley": data.valley, "sketch_style": data.style,
              "sketch_water": data.water}
    if data.selection is not None:
        arrays["selection"] = data.selection
    meta: dict = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "examples": [_example_entry(ref, folder) for ref in data.examples],
        "params": data.params.to_dict(),
        "sketch": {"shape": list(data.shape)},
        "styles": [dict(spec.to_dict(), example=_example_entry(spec.example, folder)) for spec in data.styles],
        "next_style_id": int(data.next_style_id),
        "water_level": float(data.water_level),
        "height_range": list(data.height_range) if data.height_range is not None else None,
        "pins": [{"row": p.row, "col": p.col, "height": p.height} for p in data.pins],
        "stamps": [dict(spec.to_dict(), example=_example_entry(spec.example, folder)) for spec in data.stamps],
        "result": None,
    }
    result = data.result
    if result is not None:
        arrays.update(result_heights=result.heights, result_patch_id=result.patch_id, result_seams=result.seam_mask)
        meta["result"] = {
            "shape": list(result.heights.shape),
            "cell_size": list(result.cell_size) if result.cell_size is not None else None,
            "georef": _georef_entry(result.georef),
            "report": result.report,
            "sketch_features": result.sketch_features.to_dict() if result.sketch_features is not None else None,
        }
    _write_zip(path, meta, arrays)
    return path


def _write_zip(path: Path, meta: dict, arrays: dict[str, np.ndarray]) -> None:
    try:
        # The core's atomic write: a temporary beside the target (mode from the
        # umask, not mkstemp's 0600), removed on any failure or interruption and
        # listed for io.remove_unfinished (the app's signal handler).
        with atomic_outputs(path) as (tmp,), open_new(tmp) as fh:
            # Level 1: strokes and seam masks shrink a lot, heights little, and
            # speed matters more (autosave runs while the user works).
            with zipfile.ZipFile(fh, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
                zf.writestr("project.json", json.dumps(meta, indent=1))
                for name, array in arrays.items():
                    buf = io.BytesIO()
                    np.save(buf, np.ascontiguousarray(array), allow_pickle=False)
                    zf.writestr(f"{name}.npy", buf.getvalue())
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as exc:
        raise ProjectError(f"cannot write project {path}: {exc.strerror or exc}") from None


def _example_entry(ref: ExampleRef, folder: Path) -> dict:
    entry = ref.to_dict()
    if ref.path is not None:
        # Both forms: the absolute path survives moving the project alone,
        # the relative one moving the project together with its DEMs.
        entry["path"] = os.path.abspath(ref.path)
        try:
            entry["relative_path"] = os.path.relpath(entry["path"], folder.resolve())
        except ValueError:  # another drive on Windows
            pass
    return entry


def _georef_entry(georef: GeoReference | None) -> dict | None:
    if georef is None:
        return None
    return {"x_origin": georef.x_origin, "y_origin": georef.y_origin, "x_step": georef.x_step,
            "y_step": georef.y_step, "epsg": georef.epsg, "crs_wkt": georef.crs_wkt}


# -- reading ------------------------------------------------------------------------
def read_project(path: str | os.PathLike) -> ProjectData:
    """Read a project file.

    Raises
    ------
    ProjectError
        One line naming the file: missing, a folder, not a TerraSynth
        project, of a newer version, damaged, or holding layers larger than
        :data:`MAX_LAYER_CELLS` (refused before they are read).
    """
    path = Path(path)
    try:
        return _read(path)
    except ProjectError:
        raise
    except TerraSynthError as exc:
        raise ProjectError(f"{path}: {exc}") from None
    except FileNotFoundError:
        raise ProjectError(f"project file {path} does not exist") from None
    except IsADirectoryError:
        raise ProjectError(f"{path} is a folder, not a project file") from None
    except (OSError, zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError, RuntimeError, KeyError,
            IndexError, ValueError, TypeError, AttributeError, OverflowError, MemoryError) as exc:
        # Bit-rot in a member raises zlib.error or BadZipFile (CRC), an encrypted or
        # unknown-method member RuntimeError or NotImplementedError, a wrong type
        # of JSON value AttributeError or TypeError: all are a damaged file here.
        detail = " ".join(str(exc).split()) or type(exc).__name__
        raise ProjectError(f"{path} is damaged or not a TerraSynth project: {detail}") from None


def _read(path: Path) -> ProjectData:
    with zipfile.ZipFile(path) as zf:
        meta = json.loads(zf.read("project.json"))
        if not isinstance(meta, dict):
            raise ProjectError(f"{path} is damaged: its project.json holds a {type(meta).__name__}, not an object")
        if meta.get("format") != FORMAT_NAME:
            raise ProjectError(f"{path} is not a TerraSynth project (format {meta.get('format')!r})")
        if int(meta.get("version", 0)) > FORMAT_VERSION:
            raise ProjectError(f"{path} is a version {meta['version']} project; this TerraSynth reads up to "
                               f"version {FORMAT_VERSION}")
        _check_meta(meta, path)
        names = set(zf.namelist())
        ridge, valley = _array(zf, "sketch_ridge"), _array(zf, "sketch_valley")
        shape = ridge.shape
        if valley.shape != shape or min(shape) < 2:
            raise ProjectError(f"{path} is damaged: its sketch layers are {ridge.shape} and {valley.shape}; "
                               "expected two grids of one shape, at least 2x2")
        layers = {"ridge": ridge.astype(np.uint8), "valley": valley.astype(np.uint8),
                  "style": np.full(shape, -1, np.int16), "water": np.zeros(shape, bool)}
        for name, dtype in (("style", np.int16), ("water", bool)):
            if f"sketch_{name}.npy" in names:
                layers[name] = _layer(zf, f"sketch_{name}", shape, dtype)
        if layers["style"].size and (layers["style"].min() < -1):
            raise ProjectError(f"{path} is damaged: sketch_style.npy holds style id {layers['style'].min()}; "
                               "expected -1 or more")
        selection = _layer(zf, "selection", shape, bool) if "selection.npy" in names else None
        result = _result(zf, meta["result"]) if meta.get("result") is not None else None
    folder = path.parent
    height_range = meta.get("height_range")
    return ProjectData(
        **layers,
        examples=tuple(_example_ref(entry, folder) for entry in meta["examples"]),
        params=SynthesisParams.from_dict(meta["params"]),
        styles=tuple(StyleSpec.from_dict(entry, _example_ref(entry["example"], folder))
                     for entry in meta.get("styles") or []),
        next_style_id=int(meta.get("next_style_id", 0)),
        water_level=_finite(meta.get("water_level", 0.0), "water_level", path),
        height_range=(_finite(height_range[0], "height_range", path), _finite(height_range[1], "height_range", path))
        if height_range is not None else None,
        pins=tuple(Pin(int(p["row"]), int(p["col"]), _finite(p["height"], "a pin's height", path))
                   for p in meta.get("pins") or []),
        stamps=tuple(StampSpec.from_dict(entry, _example_ref(entry["example"], folder))
                     for entry in meta.get("stamps") or []),
        result=result,
        selection=selection if selection is not None and selection.any() else None,
    )


def _finite(value, what: str, path: Path) -> float:
    value = float(value)
    if not np.isfinite(value):
        raise ProjectError(f"{path} is damaged: {what} in project.json is {value}; expected a finite number")
    return value


def _result(zf: zipfile.ZipFile, info: dict) -> ProjectResult:
    heights = _array(zf, "result_heights")
    shape = heights.shape
    features = info.get("sketch_features")
    cell = info.get("cell_size")
    georef = info.get("georef")
    return ProjectResult(
        heights.astype(np.float32),
        _layer(zf, "result_patch_id", shape, np.int32),
        _layer(zf, "result_seams", shape, bool),
        cell_size=(float(cell[0]), float(cell[1])) if cell is not None else None,
        report=info.get("report") or {},
        sketch_features=_feature_maps(features, shape) if features is not None else None,
        georef=GeoReference(**georef) if georef is not None else None,
    )


#: Keys of ``project.json`` and the JSON type each must have.
_META_TYPES = {"examples": list, "params": dict, "sketch": dict}
_OPTIONAL_META_TYPES = {"styles": list, "stamps": list, "pins": list, "result": dict, "height_range": list}


def _check_meta(meta: dict, path: Path) -> None:
    """Refuse a ``project.json`` whose keys are missing or of the wrong JSON type."""
    for key, kind in _META_TYPES.items():
        if key not in meta:
            raise ProjectError(f"{path} is damaged: project.json has no {key!r}")
        if not isinstance(meta[key], kind):
            raise ProjectError(f"{path} is damaged: {key!r} in project.json is not a JSON {kind.__name__}")
    for key, kind in _OPTIONAL_META_TYPES.items():
        if meta.get(key) is not None and not isinstance(meta[key], kind):
            raise ProjectError(f"{path} is damaged: {key!r} in project.json is not a JSON {kind.__name__}")
    for key in ("examples", "styles", "stamps", "pins"):
        if any(not isinstance(entry, dict) for entry in meta.get(key) or []):
            raise ProjectError(f"{path} is damaged: an entry of {key!r} in project.json is not an object")
    result = meta.get("result")
    if result is not None and result.get("georef") is not None and not isinstance(result["georef"], dict):
        raise ProjectError(f"{path} is damaged: the result's 'georef' in project.json is not a JSON dict")


def _array(zf: zipfile.ZipFile, name: str) -> np.ndarray:
    """A layer, its size checked from the ``.npy`` header before anything is allocated."""
    member = f"{name}.npy"
    with zf.open(member) as fh:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
        else:
            shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
    if len(shape) != 2 or dtype.hasobject or dtype.kind not in "biuf":
        raise ProjectError(f"{zf.filename} is damaged: {member} holds an array of shape {shape} and type "
                           f"{dtype}; expected a 2-D grid of numbers")
    if shape[0] * shape[1] > MAX_LAYER_CELLS:
        raise ProjectError(f"{zf.filename} is damaged or too large: {member} is {shape[0]} x {shape[1]} cells; "
                           f"at most {MAX_LAYER_CELLS} cells ({MAX_SIDE} x {MAX_SIDE}) are read")
    return np.load(io.BytesIO(zf.read(member)), allow_pickle=False)


def _layer(zf: zipfile.ZipFile, name: str, shape: tuple[int, int], dtype) -> np.ndarray:
    """A layer that must have the sketch's ``shape``, converted to ``dtype``."""
    array = _array(zf, name)
    if array.shape != tuple(shape):
        raise ProjectError(f"{zf.filename} is damaged: {name}.npy is {array.shape[0]} x {array.shape[1]} cells "
                           f"but the sketch is {shape[0]} x {shape[1]}")
    return array.astype(dtype)


def _example_ref(entry: dict, folder: Path) -> ExampleRef:
    if not isinstance(entry, dict):
        raise ProjectError(f"an example entry {entry!r} is not an object")
    entry = dict(entry)
    relative = entry.pop("relative_path", None)
    if entry.get("path") and not os.path.exists(entry["path"]) and relative is not None:
        candidate = folder / relative
        if candidate.exists():
            entry["path"] = str(candidate)
    return ExampleRef.from_dict(entry)


def _feature_maps(data: dict, shape: tuple[int, int]) -> FeatureMaps:
    return FeatureMaps(FeatureGraph.from_dict(data["ridges"], "ridge", shape),
                       FeatureGraph.from_dict(data["valleys"], "valley", shape))
