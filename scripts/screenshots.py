"""Screenshots of the app for the docs: mid-synthesis, finished, and the
Middle-earth example map.

Run under a display, e.g.::

    xvfb-run -a -s "-screen 0 1600x1000x24" .venv/bin/python scripts/screenshots.py [--only middle-earth]

Writes, under ``docs/images``:

* ``app_running.png`` and ``app_finished.png``: the main window on the
  default example and sketch, grabbed when a third of the patches are
  placed and when the run is done;
* ``app_middle_earth.png``: a 1400x900 window with the built-in
  Middle-earth map opened (File > Open example map) and synthesized: the
  sketch with its style regions, water, stamp and pins beside the 2D
  result with its water, height legend and drowning banner, the Regions
  panel (styles, water level) above the Pins and stamps panel;
* ``app_linked.png``: the same, zoomed into the lake and the river on the
  sketch (the 2D terrain follows: linked views), the mouse over a cell of
  the terrain (the readout in the status bar), only water connected to
  the painted water drawn;
* ``app_3d_water.png``: the same terrain in the 3D tab with its water
  surface.

Every picture is kept under 400 KB (quantized to 256 colours when needed).
"""

from __future__ import annotations

import argparse
import io
import sys
import tempfile
from pathlib import Path

from PIL import Image
from PySide6.QtCore import QBuffer, QSettings, Qt, QTimer
from PySide6.QtWidgets import QApplication

from terrasynth_core.pictures import save_png

REPO = Path(__file__).resolve().parent.parent
MAX_BYTES = 400_000
#: Pictures to make: name -> what it shows.
PICTURES = {"default": "app_running.png and app_finished.png",
            "middle-earth": "app_middle_earth.png, app_linked.png and app_3d_water.png"}
#: The part of the Middle-earth map app_linked.png zooms into: rows, cols.
LINKED_WINDOW = ((150, 450), (180, 600))
#: The cell the mouse rests on in app_linked.png.
HOVER_CELL = (300, 420)


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
    save_small(pixmap, path)


def grabbed(window, path: Path, fail) -> bool:
    """:func:`grab_window`, its error handed to ``fail`` (a Qt callback
    must not raise: the event loop would go on waiting)."""
    try:
        grab_window(window, path)
    except (OSError, RuntimeError) as exc:
        fail(str(exc))
        return False
    return True


def save_small(pixmap, path: Path) -> None:
    """Save ``pixmap`` as a PNG under ``MAX_BYTES``, quantizing to 256 colours if needed."""
    buffer = QBuffer()
    buffer.open(QBuffer.WriteOnly)
    if not pixmap.save(buffer, "PNG"):
        raise OSError(f"cannot encode the screenshot for {path}")
    image = Image.open(io.BytesIO(bytes(buffer.data()))).convert("RGB")
    path.parent.mkdir(parents=True, exist_ok=True)
    size = save_png(image, path, max_bytes=MAX_BYTES).stat().st_size
    print(f"wrote {path} ({size // 1000} KB, {pixmap.width()}x{pixmap.height()})", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images", help="output folder")
    parser.add_argument("--tab", choices=["2d", "3d"], default="2d",
                        help="result tab of the default-example pictures")
    parser.add_argument("--only", choices=list(PICTURES), action="append",
                        help="make only these pictures (repeatable): " +
                             "; ".join(f"{k}: {v}" for k, v in PICTURES.items()))
    args = parser.parse_args(argv)
    wanted = args.only or list(PICTURES)

    app = QApplication(sys.argv[:1])
    from terrasynth_app.views.main_window import MainWindow

    settings = QSettings(str(Path(tempfile.mkdtemp()) / "settings.ini"), QSettings.IniFormat)
    windows = []
    state = {"status": 0}

    def fail(message: str) -> None:
        print(f"failed: {message}", file=sys.stderr)
        state["status"] = 1
        # exit(), not quit(): quit() closes the windows, which would ask to
        # save the unsaved terrains.
        app.exit(1)

    def next_picture() -> None:
        if not wanted:
            app.exit(0)
            return
        for window in windows:
            window.hide()
        make = {"default": default_pictures, "middle-earth": middle_earth_picture}[wanted.pop(0)]
        windows.append(make(MainWindow(settings=settings, recovery=None), args, fail, next_picture))

    QTimer.singleShot(0, next_picture)
    app.exec()
    for window in windows:
        window.synthesis.wait()
        if window.view3d.plotter is not None:
            window.view3d.plotter.close()
    return state["status"]


def default_pictures(window, args, fail, done):
    """The default example and sketch: mid-run and finished."""
    window.resize(1600, 950)
    window.show()
    if args.tab == "3d":
        window.result_tabs.setCurrentWidget(window.view3d)
    state = {"grabbed": False}

    def patch_placed(event) -> None:
        if not state["grabbed"] and event.index + 1 >= event.total / 3:
            state["grabbed"] = True
            # Let the throttled views catch up before grabbing.
            QTimer.singleShot(300, lambda: grabbed(window, args.out / "app_running.png", fail))

    def finish() -> None:
        if grabbed(window, args.out / "app_finished.png", fail):
            done()

    window.synthesis.patch_placed.connect(patch_placed)
    window.synthesis.finished.connect(lambda _result: QTimer.singleShot(500, finish))
    window.synthesis.failed.connect(fail)
    QTimer.singleShot(500, window.synthesize)
    return window


def middle_earth_picture(window, args, fail, done):
    """The Middle-earth example map opened from the menu and synthesized,
    the 2D result beside the painted map; then zoomed in, and in 3D."""
    window.resize(1400, 900)
    window.show()
    window.result_tabs.setCurrentWidget(window.heightmap)

    def finish() -> None:
        if grabbed(window, args.out / "app_middle_earth.png", fail):
            QTimer.singleShot(0, zoomed)

    def zoomed() -> None:
        from PySide6.QtCore import QPointF
        from PySide6.QtTest import QTest

        (r0, r1), (c0, c1) = LINKED_WINDOW
        window.heightmap.connected_water_check.setChecked(True)
        window.canvas.view_box.setRange(xRange=(c0, c1), yRange=(r0, r1), padding=0)
        view = window.heightmap
        scene = view.view_box.mapViewToScene(QPointF(HOVER_CELL[1] + 0.5, HOVER_CELL[0] + 0.5))
        QTest.mouseMove(view.view.viewport(), view.view.mapFromScene(scene))
        QTimer.singleShot(300, lambda: grabbed(window, args.out / "app_linked.png", fail) and three_d())

    def three_d() -> None:
        window.result_tabs.setCurrentWidget(window.view3d)
        QTimer.singleShot(1500, lambda: grabbed(window, args.out / "app_3d_water.png", fail) and done())

    def opened(_key) -> None:
        # The pins' table and their misses after the run below the Regions
        # panel, which gets as much height as the docks below allow.
        window.docks["pins_stamps_dock"].raise_()
        window.resizeDocks([window.docks["regions_dock"], window.docks["pins_stamps_dock"]], [600, 200],
                           Qt.Vertical)
        QTimer.singleShot(300, window.synthesize)

    window.example_map_opened.connect(opened)
    window.synthesis.finished.connect(lambda _result: QTimer.singleShot(500, finish))
    window.synthesis.failed.connect(fail)
    QTimer.singleShot(500, window.actions.example_maps["middle-earth"].trigger)
    return window


if __name__ == "__main__":
    sys.exit(main())
