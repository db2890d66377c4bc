"""``terrasynth``: start the TerraSynth desktop app.

Usage: ``terrasynth [FILE]`` where FILE is a project (``.tsproj``) or a
sketch PNG to open.  ``--help`` works without a display.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from terrasynth_core import __version__

EXIT_OK = 0
EXIT_NO_DISPLAY = 1
EXIT_BAD_INPUT = 2


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="terrasynth",
        description="TerraSynth: sketch ridges and valleys, pick real example DEMs and synthesize a terrain.",
    )
    parser.add_argument("file", nargs="?", type=Path,
                        help="a project (.tsproj) or a sketch PNG (red ridges, blue valleys) to open")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    return parser


def has_display() -> bool:
    """True when Qt can open a window: a display server, or a platform chosen explicitly."""
    if sys.platform != "linux":
        return True
    return any(os.environ.get(name) for name in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM"))


def recovery_directory() -> Path:
    from PySide6.QtCore import QStandardPaths

    return Path(QStandardPaths.writableLocation(QStandardPaths.AppDataLocation))


def main(argv: list[str] | None = None) -> int:
    """Parse the arguments, open the window and run the event loop; returns the exit status."""
    args = build_parser().parse_args(argv)
    if args.file is not None and not args.file.is_file():
        print(f"terrasynth: {args.file}: no such file", file=sys.stderr)
        return EXIT_BAD_INPUT
    if not has_display():
        print("terrasynth: no display found (DISPLAY is not set). TerraSynth is a desktop app: run it in a "
              "graphical session, or use terrasynth-cli for scripted synthesis.", file=sys.stderr)
        return EXIT_NO_DISPLAY

    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance() or QApplication(sys.argv[:1])
    app.setApplicationName("TerraSynth")
    app.setOrganizationName("TerraSynth")

    from .model.project import PROJECT_EXTENSION
    from .model.recovery import RecoveryStore
    from .views.main_window import MainWindow
    from .views.terrain_view_3d import importing_ahead
    from .workers import freeze_start_up

    window = MainWindow(recovery=RecoveryStore(recovery_directory()))
    window.autosave.handle_termination()  # SIGTERM/SIGINT: no temporary left, unsaved work kept
    window.show()
    # What the app made to start leaves the cyclic collector for good (no
    # request runs yet), and again what the 3D view's libraries add once
    # their import on a helper thread is done.
    freeze_start_up()

    def once_imported() -> None:
        if importing_ahead() or not freeze_start_up():
            QTimer.singleShot(100, once_imported)

    QTimer.singleShot(100, once_imported)
    if not window.files.offer_recovery() and args.file is not None:
        if args.file.suffix.lower() == PROJECT_EXTENSION:
            window.files.open_project(str(args.file))
        else:
            window.files.open_sketch(str(args.file))
    return app.exec()


if __name__ == "__main__":
    sys.exit(main())
