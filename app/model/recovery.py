"""Crash recovery: the document autosaved to a file beside the user's settings."""

from __future__ import annotations

import json
import os
from datetime import datetime
from pathlib import Path

from terrasynth_core.io import atomic_outputs, open_new

from .document import Document
from .project import load_project, save_project

RECOVERY_NAME = "recovery.tsproj"
_INFO_NAME = "recovery.json"


class RecoveryStore:
    """Where unsaved work is autosaved and found again after a crash.

    Parameters
    ----------
    directory : path-like
        Folder for the recovery files (created on first save).
    """

    def __init__(self, directory: str | os.PathLike) -> None:
        self.directory = Path(directory)
        self.path = self.directory / RECOVERY_NAME
        self._info = self.directory / _INFO_NAME

    def save(self, document: Document) -> None:
        """Autosave ``document`` without touching its file or unsaved flag."""
        self.directory.mkdir(parents=True, exist_ok=True)
        save_project(document, self.path, mark_saved=False)
        info = {"original": str(document.path) if document.path is not None else None,
                "saved_at": datetime.now().isoformat(timespec="seconds")}
        with atomic_outputs(self._info) as (tmp,), open_new(tmp) as fh:
            fh.write(json.dumps(info).encode("utf-8"))

    def exists(self) -> bool:
        return self.path.is_file()

    def _read_info(self) -> dict:
        """``recovery.json``'s ``original`` and ``saved_at`` strings; a damaged file gives neither."""
        try:
            info = json.loads(self._info.read_text())
        except (OSError, ValueError):
            return {}
        if not isinstance(info, dict):
            return {}
        return {key: info[key] for key in ("original", "saved_at") if isinstance(info.get(key), str)}

    def describe(self) -> str:
        """One line for the recovery prompt: when, and which project."""
        info = self._read_info()
        what = Path(info["original"]).name if info.get("original") else "an untitled project"
        when = info.get("saved_at", "an unknown time").replace("T", " ")
        return f"Unsaved work on {what}, autosaved at {when}"

    def load(self) -> Document:
        """The recovered document: unsaved, attached to its original file if any.

        Raises
        ------
        ProjectError
            When the recovery file is damaged.
        """
        document = load_project(self.path)
        original = self._read_info().get("original")
        recovered = document.snapshot(path=Path(original) if original else None)
        recovered.mark_unsaved()
        return recovered

    def discard(self) -> None:
        """Delete the recovery files (after a clean save or exit)."""
        self.path.unlink(missing_ok=True)
        self._info.unlink(missing_ok=True)

