"""Small pieces the panels share: rows, the red error line, the DEM file
dialog and document edits that report their error under the panel."""

from __future__ import annotations

from typing import Callable

from PySide6.QtWidgets import QFileDialog, QHBoxLayout, QLabel, QWidget

from terrasynth_core.errors import TerraSynthError
from terrasynth_core.io import READ_EXTENSIONS


def hbox(*items) -> QHBoxLayout:
    """A row of widgets; a ``(widget, stretch)`` pair gives that widget a stretch factor."""
    layout = QHBoxLayout()
    for item in items:
        widget, stretch = item if isinstance(item, tuple) else (item, 0)
        layout.addWidget(widget, stretch)
    return layout


def error_label() -> QLabel:
    """The red, word-wrapped line a panel shows its last refused edit in."""
    label = QLabel(wordWrap=True)
    label.setStyleSheet("color: #c00000")
    return label


def ask_dem_file(parent: QWidget, title: str, *, any_file: bool = False) -> str | None:
    """Ask for a DEM file to read; None when the user cancels.  ``any_file``
    also offers files of any extension (the readers sniff some formats)."""
    patterns = " ".join(f"*{ext}" for ext in READ_EXTENSIONS)
    file_filter = f"DEM files ({patterns})" + (";;All files (*)" if any_file else "")
    path, _ = QFileDialog.getOpenFileName(parent, title, "", file_filter)
    return path or None


def apply_edit(errors: QLabel, edit: Callable[[], object]) -> bool:
    """Make a document edit; its error goes to ``errors``, which a success clears.

    Returns
    -------
    bool
        True when the edit was made.
    """
    try:
        edit()
    except TerraSynthError as exc:
        errors.setText(str(exc))
        return False
    errors.clear()
    return True
