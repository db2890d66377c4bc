"""Project files: one ``.tsproj`` zip holding a whole document.

Layout of the zip::

    project.json        format, version, examples, params, sketch shape,
                        styles, water level, height range, pins, stamps,
                        result metadata (cell size, report, feature graphs)
    sketch_ridge.npy    uint8 (rows, cols) stroke intensities
    sketch_valley.npy   uint8 (rows, cols)
    sketch_style.npy    int16 (rows, cols) style ids, -1 none (version 2)
    sketch_water.npy    bool (rows, cols) (version 2)
    result_heights.npy  float32 (rows, cols), when there is a result
    result_patch_id.npy int32
    result_seams.npy    bool

Version 1 files (before styles, water, pins and stamps) still load, with
none of them.  Writes go to a temporary file in the target's folder that then replaces the
target, so a crash mid-save never leaves a truncated project.
"""

from __future__ import annotations

import io
import json
import os
import secrets
import zipfile
import zlib
from pathlib import Path

import numpy as np

from terrasynth_core.errors import TerraSynthError
from terrasynth_core.features import FeatureGraph, FeatureMaps
from terrasynth_core.synthesis import Pin, SynthesisParams

from .control_specs import StampSpec, StyleSpec
from .document import Document
from .example_library import ExampleRef
from .result import TerrainResult
from .sketch_layers import MAX_SIDE, Sketch

#: Extension of project files.
PROJECT_EXTENSION = ".tsproj"
FORMAT_NAME = "terrasynth-project"
FORMAT_VERSION = 2


class ProjectError(TerraSynthError):
    """A project file cannot be read or written."""


def save_project(document: Document, path: str | os.PathLike, *, mark_saved: bool = True) -> Path:
    """Write ``document`` to ``path`` atomically.

    Parameters
    ----------
    document : Document
    path : str or path-like
        Target file; ``.tsproj`` is the usual extension.
    mark_saved : bool, default True
        Record ``path`` as the document's file and clear its unsaved flag
        (False for autosave copies).

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    ProjectError
        When the file cannot be written.
    """
    path = Path(path)
    sketch = document.sketch
    arrays = {"sketch_ridge": np.asarray(sketch.ridge), "sketch_valley": np.asarray(sketch.valley),
              "sketch_style": np.asarray(sketch.style), "sketch_water": np.asarray(sketch.water)}
    meta: dict = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "examples": [_example_entry(ref, path.parent) for ref in document.examples],
        "params": document.params.to_dict(),
        "sketch": {"shape": list(sketch.shape)},
        "styles": [dict(spec.to_dict(), example=_example_entry(spec.example, path.parent))
                   for spec in document.styles],
        "next_style_id": document.next_style_id,
        "water_level": document.water_level,
        "height_range": list(document.height_range) if document.height_range is not None else None,
        "pins": [{"row": p.row, "col": p.col, "height": p.height} for p in document.pins],
        "stamps": [dict(spec.to_dict(), example=_example_entry(spec.example, path.parent))
                   for spec in document.stamps],
        "result": None,
    }
    result = document.result
    if result is not None:
        arrays.update(result_heights=result.heights, result_patch_id=result.patch_id, result_seams=result.seam_mask)
        meta["result"] = {
            "shape": list(result.shape),
            "cell_size": list(result.cell_size) if result.cell_size is not None else None,
            "report": result.report,
            "sketch_features": result.sketch_features.to_dict() if result.sketch_features is not None else None,
        }
    _write_zip(path, meta, arrays)
    if mark_saved:
        document.mark_saved(path)
    return path


def load_project(path: str | os.PathLike) -> Document:
    """Read a project file into a new, clean :class:`Document`.

    Raises
    ------
    ProjectError
        When the file is missing, not a TerraSynth project, of a newer
        version, or damaged.
    """
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as zf:
            meta = json.loads(zf.read("project.json"))
            if not isinstance(meta, dict):
                raise ProjectError(f"{path} is damaged: its project.json holds a {type(meta).__name__}, "
                                   "not an object")
            if meta.get("format") != FORMAT_NAME:
                raise ProjectError(f"{path} is not a TerraSynth project (format {meta.get('format')!r})")
            if int(meta.get("version", 0)) > FORMAT_VERSION:
                raise ProjectError(
                    f"{path} is a version {meta['version']} project; this TerraSynth reads up to version "
                    f"{FORMAT_VERSION}"
                )
            _check_meta(meta, path)
            names = set(zf.namelist())
            regions = {name: _array(zf, f"sketch_{name}") for name in ("style", "water")
                       if f"sketch_{name}.npy" in names}
            sketch = Sketch(_array(zf, "sketch_ridge"), _array(zf, "sketch_valley"), **regions)
            result = None
            if meta.get("result") is not None:
                info = meta["result"]
                features = info.get("sketch_features")
                shape = tuple(info["shape"])
                result = TerrainResult(
                    _array(zf, "result_heights"),
                    _array(zf, "result_patch_id"),
                    _array(zf, "result_seams"),
                    sketch_features=_feature_maps(features, shape) if features is not None else None,
                    cell_size=tuple(info["cell_size"]) if info.get("cell_size") is not None else None,
                    report=info.get("report") or {},
                    pin_errors=TerrainResult.pin_errors_of(info.get("report") or {}),
                )
        examples = [_example_ref(entry, path.parent) for entry in meta["examples"]]
        params = SynthesisParams.from_dict(meta["params"])
        styles = [StyleSpec.from_dict(entry, _example_ref(entry["example"], path.parent))
                  for entry in meta.get("styles", [])]
        stamps = [StampSpec.from_dict(entry, _example_ref(entry["example"], path.parent))
                  for entry in meta.get("stamps", [])]
        pins = [Pin(int(p["row"]), int(p["col"]), float(p["height"])) for p in meta.get("pins", [])]
        height_range = meta.get("height_range")
        document = Document(sketch, examples, params=params, result=result, path=path, styles=styles,
                            water_level=float(meta.get("water_level", 0.0)),
                            height_range=tuple(height_range) if height_range is not None else None,
                            pins=pins, stamps=stamps, next_style_id=int(meta.get("next_style_id", 0)))
    except ProjectError:
        raise
    except TerraSynthError as exc:
        raise ProjectError(f"{path}: {exc}") from None
    except FileNotFoundError:
        raise ProjectError(f"project file {path} does not exist") from None
    except IsADirectoryError:
        raise ProjectError(f"{path} is a folder, not a project file") from None
    except (OSError, zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError, RuntimeError, KeyError,
            ValueError, TypeError, AttributeError, OverflowError, MemoryError) as exc:
        # Bit-rot in a member raises zlib.error or BadZipFile (CRC), an encrypted or
        # unknown-method member RuntimeError or NotImplementedError, a wrong type
        # of JSON value AttributeError or TypeError: all are a damaged file here.
        detail = " ".join(str(exc).split()) or type(exc).__name__
        raise ProjectError(f"{path} is damaged or not a TerraSynth project: {detail}") from None
    document.mark_saved(path)
    return document


# -- helpers --------------------------------------------------------------------
def _write_zip(path: Path, meta: dict, arrays: dict[str, np.ndarray]) -> None:
    directory = path.parent if str(path.parent) else Path(".")
    tmp = directory / f".{path.name}.{secrets.token_hex(6)}.tmp"
    try:
        # Not mkstemp: its files are 0600; a project gets the mode any file the user makes gets (umask).
        fh = open(tmp, "xb")
    except OSError as exc:
        raise ProjectError(f"cannot write project {path}: {exc.strerror or exc}") from None
    try:
        with fh:
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
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise ProjectError(f"cannot write project {path}: {exc.strerror or exc}") from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


#: Largest layer a project may hold, in cells (the core's output limit).
MAX_LAYER_CELLS = MAX_SIDE * MAX_SIDE

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


def _array(zf: zipfile.ZipFile, name: str) -> np.ndarray:
    """A layer, its size checked from the ``.npy`` header before anything is allocated."""
    member = f"{name}.npy"
    with zf.open(member) as fh:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
        else:
            shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
    if len(shape) != 2 or dtype.hasobject:
        raise ProjectError(f"{zf.filename} is damaged: {member} holds an array of shape {shape} and type "
                           f"{dtype}; expected a 2-D grid")
    if shape[0] * shape[1] > MAX_LAYER_CELLS:
        raise ProjectError(f"{zf.filename} is damaged or too large: {member} is {shape[0]} x {shape[1]} cells; "
                           f"at most {MAX_LAYER_CELLS} cells ({MAX_SIDE} x {MAX_SIDE}) are read")
    return np.load(io.BytesIO(zf.read(member)), allow_pickle=False)


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


def _example_ref(entry: dict, folder: Path) -> ExampleRef:
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
