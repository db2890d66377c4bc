"""Child process of ``test_app_process.py``: the app's window in a process of
its own, so the test can kill it or signal it.

``python app_process_child.py MODE FOLDER [SIGNAL]``; the window autosaves
to ``FOLDER/recovery`` and its handlers for SIGTERM and SIGINT are
installed as ``terrasynth`` installs them.  Modes:

``autosave``
    Draw a valley, print ``AUTOSAVED`` once the recovery file is written,
    then wait (for SIGKILL).
``save``
    Draw a valley and save the project to ``FOLDER/mine.tsproj`` on the GUI
    thread; the project writer's first ``np.save`` sends SIGNAL to the
    process half-way through.
``export``
    Export a terrain to ``FOLDER/terrain.npy`` on the thread pool; the write
    sends SIGNAL to the process half-way and then hangs, as a long write
    does.

Not a test module itself.
"""

import os
import signal
import sys
import threading
from pathlib import Path

import numpy as np
from PySide6.QtCore import QSettings, QTimer
from PySide6.QtWidgets import QApplication

sys.path.insert(0, str(Path(__file__).parent))
from conftest import small_document  # noqa: E402


def _signal_half_way(signum: int, *, hang: bool) -> None:
    """Make the first ``np.save`` into a file write part of it, then signal."""
    real_save = np.save
    fired = threading.Event()

    def save(file, array, *args, **kwargs):
        if fired.is_set():
            return real_save(file, array, *args, **kwargs)
        fired.set()
        file.write(b"\x93NUMPY half-written")
        if hasattr(file, "flush"):
            file.flush()
        os.kill(os.getpid(), signum)
        if hang:
            threading.Event().wait()
        return real_save(file, array, *args, **kwargs)

    np.save = save


def main(mode: str, folder: str, signame: str = "SIGTERM") -> None:
    app = QApplication(sys.argv[:1])
    from terrasynth_app.model import RecoveryStore, TerrainResult
    from terrasynth_app.views.main_window import MainWindow

    folder = Path(folder)
    window = MainWindow(small_document(), settings=QSettings(str(folder / "settings.ini"), QSettings.IniFormat),
                        recovery=RecoveryStore(folder / "recovery"),
                        # Autosave soon only where it is tested, so no autosave's write comes first elsewhere.
                        autosave_ms=50 if mode == "autosave" else 3_600_000)
    window.autosave.handle_termination()
    window.show()
    doc = window.document
    doc.sketch.draw_polyline([(5, 5), (5, 150)], "valley", radius=2, hardness=1.0)
    signum = signal.Signals[signame]
    if mode == "autosave":
        def said(message, _msecs):
            if message == "Autosaved":
                print("AUTOSAVED", flush=True)

        window.autosave.status.connect(said)
    elif mode == "save":
        _signal_half_way(signum, hang=False)
        QTimer.singleShot(0, lambda: window.file_controller.save_to(folder / "mine.tsproj"))
    elif mode == "export":
        heights = np.linspace(0, 500, 160 * 160, dtype=np.float32).reshape(160, 160)
        result = TerrainResult(heights, np.zeros((160, 160), np.int32), np.zeros((160, 160), bool),
                               cell_size=(30.0, 30.0))
        _signal_half_way(signum, hang=True)
        QTimer.singleShot(0, lambda: window.file_controller.export(result, str(folder / "terrain.npy")))
    print("READY", flush=True)
    sys.exit(app.exec())


if __name__ == "__main__":
    main(*sys.argv[1:])
