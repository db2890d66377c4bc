"""The app as a process (issue 13): unsaved work survives ``kill -9``
(autosave, then recovery on the next start), and SIGTERM or SIGINT during a
save or an export leaves no temporary file and no changed user file.

The app runs in a child process (``app_process_child.py``) on the offscreen
platform; nothing sleeps: the test reads the child's lines with a deadline
and waits for its exit.
"""

import hashlib
import os
import selectors
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

CHILD = Path(__file__).with_name("app_process_child.py")
DEADLINE_S = 120


def _spawn(mode: str, folder: Path, signame: str = "SIGTERM") -> subprocess.Popen:
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
    return subprocess.Popen([sys.executable, str(CHILD), mode, str(folder), signame], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)


def _wait_for_line(child: subprocess.Popen, wanted: str) -> None:
    """Read the child's stdout until ``wanted``; fail at the deadline or if it ends."""
    deadline = time.monotonic() + DEADLINE_S
    with selectors.DefaultSelector() as sel:
        sel.register(child.stdout, selectors.EVENT_READ)
        while time.monotonic() < deadline:
            if not sel.select(timeout=deadline - time.monotonic()):
                break
            line = child.stdout.readline()
            if not line:
                pytest.fail(f"the app ended before saying {wanted}: {child.stderr.read()}")
            if line.strip() == wanted:
                return
    child.kill()
    pytest.fail(f"the app did not say {wanted} within {DEADLINE_S} s")


def _digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _temporaries(folder: Path) -> list[str]:
    return [p.name for p in folder.rglob("*.tmp")]


def _drawn_valley():
    """The valley the child draws, on the same document (the app tests' conftest,
    loaded by path: ``conftest`` alone may name another folder's in a full run)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("app_tests_conftest", Path(__file__).with_name("conftest.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    doc = module.small_document()
    doc.sketch.draw_polyline([(5, 5), (5, 150)], "valley", radius=2, hardness=1.0)
    return doc.sketch.valley.copy()


def test_work_is_recovered_after_the_app_is_killed(qtbot, tmp_path, dialogs):
    from PySide6.QtCore import QSettings
    from PySide6.QtWidgets import QMessageBox

    from terrasynth_app.model import RecoveryStore
    from terrasynth_app.views.main_window import MainWindow

    child = _spawn("autosave", tmp_path)
    try:
        _wait_for_line(child, "AUTOSAVED")
    finally:
        child.send_signal(signal.SIGKILL)
        child.communicate(timeout=DEADLINE_S)
    assert child.returncode == -signal.SIGKILL
    assert _temporaries(tmp_path) == []
    window = MainWindow(settings=QSettings(str(tmp_path / "next.ini"), QSettings.IniFormat),
                        recovery=RecoveryStore(tmp_path / "recovery"))
    qtbot.addWidget(window)
    dialogs.answers = [QMessageBox.Yes]
    assert window.files.offer_recovery()
    assert "Unsaved work on an untitled project" in dialogs.messages("question")[0]
    np.testing.assert_array_equal(window.document.sketch.valley, _drawn_valley())
    assert window.document.dirty


# One signal each (both take the same path; a child app costs seconds).
@pytest.mark.parametrize("signame", ["SIGTERM"])
def test_a_signal_during_a_save_on_the_gui_thread(tmp_path, signame):
    from terrasynth_app.model import RecoveryStore, load_project

    (tmp_path / "mine.tsproj").write_bytes(b"the user's older project")
    before = _digests(tmp_path)
    child = _spawn("save", tmp_path, signame)
    _, err = child.communicate(timeout=DEADLINE_S)
    assert child.returncode == 128 + signal.Signals[signame], err
    assert f"stopped by {signame}; unsaved work kept for recovery" in err and "Traceback" not in err
    assert _temporaries(tmp_path) == []
    after = _digests(tmp_path)
    assert after["mine.tsproj"] == before["mine.tsproj"]
    recovered = RecoveryStore(tmp_path / "recovery").load()
    np.testing.assert_array_equal(recovered.sketch.valley, _drawn_valley())
    assert load_project(tmp_path / "recovery" / "recovery.tsproj").sketch.shape == (160, 160)


@pytest.mark.parametrize("signame", ["SIGINT"])
def test_a_signal_during_an_export_on_a_pool_thread(tmp_path, signame):
    child = _spawn("export", tmp_path, signame)
    _, err = child.communicate(timeout=DEADLINE_S)
    assert child.returncode == 128 + signal.Signals[signame], err
    assert "Traceback" not in err
    assert _temporaries(tmp_path) == []
    assert not (tmp_path / "terrain.npy").exists() and not (tmp_path / "terrain.json").exists()
