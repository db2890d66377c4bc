"""Screenshots of the app for the docs: mid-synthesis and finished.

Run under a display, e.g.::

    xvfb-run -a -s "-screen 0 1600x1000x24" .venv/bin/python scripts/screenshots.py

Writes ``docs/images/app_running.png`` and ``docs/images/app_finished.png``:
the main window on the default example and sketch, grabbed when a third of
the patches are placed and when the run is done.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from PySide6.QtCore import QSettings, QTimer
from PySide6.QtWidgets import QApplication

REPO = Path(__file__).resolve().parent.parent


def grab_window(window, path: Path) -> None:
    """Save the window; the 3D view is painted by OpenGL, outside what
    ``QWidget.grab`` sees, so its own screenshot is pasted over it."""
    from PySide6.QtCore import QPoint
    from PySide6.QtGui import QImage, QPainter

    pixmap = window.grab()
    view3d = window.view3d
    if view3d.isVisible() and view3d.plotter is not None:
        shot = view3d.plotter.screenshot(None, return_img=True)
        image = QImage(shot.data, shot.shape[1], shot.shape[0], 3 * shot.shape[1], QImage.Format_RGB888).copy()
        target = view3d.plotter.mapTo(window, QPoint(0, 0))
        painter = QPainter(pixmap)
        painter.drawImage(target, image.scaled(view3d.plotter.size()))
        painter.end()
    path.parent.mkdir(parents=True, exist_ok=True)
    if not pixmap.save(str(path)):
        raise OSError(f"cannot write {path}")
    print(f"wrote {path}", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images", help="output folder")
    parser.add_argument("--tab", choices=["2d", "3d"], default="2d", help="result tab to show")
    args = parser.parse_args(argv)

    app = QApplication(sys.argv[:1])
    from terrasynth_app.views.main_window import MainWindow

    settings = QSettings(str(Path(tempfile.mkdtemp()) / "settings.ini"), QSettings.IniFormat)
    window = MainWindow(settings=settings, recovery=None)
    window.resize(1600, 950)
    window.show()
    if args.tab == "3d":
        window.result_tabs.setCurrentWidget(window.view3d)
    state = {"grabbed": False, "status": 0}

    def patch_placed(event) -> None:
        if not state["grabbed"] and event.index + 1 >= event.total / 3:
            state["grabbed"] = True
            # Let the throttled views catch up before grabbing.
            QTimer.singleShot(300, lambda: grab_window(window, args.out / "app_running.png"))

    def finish() -> None:
        grab_window(window, args.out / "app_finished.png")
        # exit(), not quit(): quit() closes the window, which would ask to
        # save the unsaved terrain.
        app.exit(0)

    def finished(_result) -> None:
        QTimer.singleShot(500, finish)

    def failed(message: str) -> None:
        print(f"synthesis failed: {message}", file=sys.stderr)
        state["status"] = 1
        app.exit(1)

    window.runner.patch_placed.connect(patch_placed)
    window.runner.synthesis_finished.connect(finished)
    window.runner.synthesis_failed.connect(failed)
    QTimer.singleShot(500, window.synthesize)
    app.exec()
    window.runner.wait()
    if window.view3d.plotter is not None:
        window.view3d.plotter.close()
    return state["status"]


if __name__ == "__main__":
    sys.exit(main())
