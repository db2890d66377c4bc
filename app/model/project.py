"""Project files of the app: a :class:`Document` written to and read from a
``.tsproj`` file.

The file format, its checks and its atomic write live in the core
(:mod:`terrasynth_core.project.file`), so ``terrasynth-cli synth --project``
reads the same files without the app; here a document becomes a
:class:`~terrasynth_core.project.ProjectData` and back.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from terrasynth_core.errors import ProjectError
from terrasynth_core.project import (PROJECT_EXTENSION, ProjectData, ProjectResult, read_project,
                                     write_project)

from .document import Document
from .result import TerrainResult
from .sketch_layers import Sketch

__all__ = ["PROJECT_EXTENSION", "ProjectError", "document_of", "load_project", "project_data", "save_project"]


def project_data(document: Document) -> ProjectData:
    """What a project file holds of ``document`` (arrays shared, not copied:
    the caller hands a snapshot when it writes on another thread)."""
    sketch = document.sketch
    result = document.result
    saved_result = None
    if result is not None:
        saved_result = ProjectResult(result.heights, result.patch_id, result.seam_mask, cell_size=result.cell_size,
                                     report=result.report, sketch_features=result.sketch_features,
                                     georef=result.georef)
    selection = document.selection
    return ProjectData(
        np.asarray(sketch.ridge), np.asarray(sketch.valley), np.asarray(sketch.style), np.asarray(sketch.water),
        examples=tuple(document.examples), params=document.params, styles=tuple(document.styles),
        next_style_id=document.next_style_id, water_level=document.water_level,
        height_range=document.height_range, pins=tuple(document.pins), stamps=tuple(document.stamps),
        result=saved_result, selection=None if selection is None else np.asarray(selection))


def document_of(data: ProjectData, path: Path | None = None) -> Document:
    """A new, clean document holding ``data``.

    Raises
    ------
    TerraSynthError
        When the layers or controls are inconsistent (a damaged file).
    """
    sketch = Sketch(data.ridge, data.valley, style=data.style, water=data.water)
    result = None
    if data.result is not None:
        r = data.result
        result = TerrainResult(r.heights, r.patch_id, r.seam_mask, sketch_features=r.sketch_features,
                               cell_size=r.cell_size, report=r.report,
                               pin_errors=TerrainResult.pin_errors_of(r.report), georef=r.georef)
    document = Document(sketch, list(data.examples), params=data.params, result=result, path=path,
                        styles=data.styles, water_level=data.water_level, height_range=data.height_range,
                        pins=data.pins, stamps=data.stamps, next_style_id=data.next_style_id)
    if data.selection is not None:
        document.set_selection(data.selection)
    return document


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
    path = write_project(project_data(document), path)
    if mark_saved:
        document.mark_saved(path)
    return path


def load_project(path: str | os.PathLike) -> Document:
    """Read a project file into a new, clean :class:`Document`.

    Raises
    ------
    ProjectError
        One line naming the file: missing, not a TerraSynth project, of a
        newer version, or damaged.
    """
    path = Path(path)
    data = read_project(path)
    try:
        document = document_of(data, path)
    except ProjectError:
        raise
    except (ValueError, TypeError) as exc:  # TerraSynthError is a ValueError
        raise ProjectError(f"{path} is damaged: {' '.join(str(exc).split())}") from None
    document.mark_saved(path)
    return document
