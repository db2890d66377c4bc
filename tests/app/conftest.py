"""Shared set-up of the app tests: headless Qt unless a platform is chosen.

The platform must be set before Qt is imported anywhere, hence at the top of
this conftest.  The 3D view needs a real X display; its test runs a child
process on the ``xcb`` platform (see ``test_view3d.py``).
"""

import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import pytest


class DialogRecorder:
    """Stands in for QMessageBox's static functions: records, never blocks.

    ``answers`` is the button ``question`` returns next (default Discard,
    so closing a window with unsaved changes never waits for a click).
    """

    def __init__(self):
        self.calls: list[tuple[str, str, str]] = []
        self.answers: list = []

    def messages(self, kind: str) -> list[str]:
        return [text for k, _title, text in self.calls if k == kind]


@pytest.fixture
def dialogs(monkeypatch):
    from PySide6.QtWidgets import QMessageBox

    recorder = DialogRecorder()

    def record(kind, default):
        def show(_parent, title, text, *args, **kwargs):
            recorder.calls.append((kind, title, text))
            return recorder.answers.pop(0) if kind == "question" and recorder.answers else default

        return show

    monkeypatch.setattr(QMessageBox, "critical", record("critical", QMessageBox.Ok))
    monkeypatch.setattr(QMessageBox, "warning", record("warning", QMessageBox.Ok))
    monkeypatch.setattr(QMessageBox, "information", record("information", QMessageBox.Ok))
    monkeypatch.setattr(QMessageBox, "question", record("question", QMessageBox.Discard))
    return recorder


def small_document():
    """A 160x160 sketch (a forked ridge and a valley) on a 300x300 crop of a
    built-in example, with 32-cell patches: a run of a few seconds."""
    from terrasynth_core.synthesis import SynthesisParams
    from terrasynth_app.model import Document, ExampleRef, Sketch

    sketch = Sketch.blank((160, 160))
    sketch.draw_polyline([(20, 80), (80, 80), (140, 30)], "ridge", radius=2, hardness=1.0)
    sketch.draw_polyline([(80, 80), (140, 130)], "ridge", radius=2, hardness=1.0)
    sketch.draw_polyline([(30, 20), (120, 10)], "valley", radius=2, hardness=1.0)
    sketch.history.clear()
    return Document(sketch, [ExampleRef(builtin="white-mountains", crop=(400, 700, 400, 700))],
                    params=SynthesisParams(patch_size=32, k=3, seed=3))


@pytest.fixture(scope="session")
def new_small_document():
    """:func:`small_document`, for test modules (which cannot import a conftest)."""
    return small_document


@pytest.fixture
def window(qtbot, tmp_path, dialogs):
    from PySide6.QtCore import QSettings
    from terrasynth_app.model import RecoveryStore
    from terrasynth_app.views.main_window import MainWindow

    settings = QSettings(str(tmp_path / "settings.ini"), QSettings.IniFormat)
    win = MainWindow(small_document(), settings=settings, recovery=RecoveryStore(tmp_path / "recovery"))
    qtbot.addWidget(win)
    win.show()
    qtbot.waitExposed(win)
    yield win
    win.synthesis.wait()


def viewport_pos(canvas, row: float, col: float):
    """Viewport pixel of sketch cell ``(row, col)``."""
    from PySide6.QtCore import QPointF

    scene = canvas.view_box.mapViewToScene(QPointF(col + 0.5, row + 0.5))
    return canvas.view.mapFromScene(scene)


@pytest.fixture
def cell_pos():
    return viewport_pos


@pytest.fixture
def drag(qtbot):
    """``drag(canvas, cells, modifier)``: press on the first cell, move
    through the others, release on the last."""
    from PySide6.QtCore import Qt

    def drag(canvas, cells, modifier=Qt.NoModifier):
        viewport = canvas.view.viewport()
        qtbot.mousePress(viewport, Qt.LeftButton, modifier, viewport_pos(canvas, *cells[0]))
        for cell in cells[1:]:
            qtbot.mouseMove(viewport, viewport_pos(canvas, *cell))
        qtbot.mouseRelease(viewport, Qt.LeftButton, modifier, viewport_pos(canvas, *cells[-1]))

    return drag



def _bit_rot(path, member="sketch_ridge.npy"):
    """Flip bytes inside the deflated data of ``member`` of the zip at ``path`` (not its header)."""
    import zipfile

    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo(member)
    raw = bytearray(path.read_bytes())
    start = info.header_offset + 30 + len(info.filename.encode()) + len(info.extra)
    for i in range(start + 2, start + min(info.compress_size, 40)):
        raw[i] ^= 0x5A
    path.write_bytes(bytes(raw))


@pytest.fixture
def bit_rot():
    """``bit_rot(path, member=...)``: damage a member of a project zip as bit-rot would."""
    return _bit_rot
