"""Issue 13: 50 runs back to back in the window leak neither memory nor threads.

Small runs (a 64x64 sketch, 32-cell patches) so the whole test takes
seconds; the figures go to the test report (``record_property``) and the
README's Reliability section.
"""

import gc
import os
import threading

from PySide6.QtCore import QSettings

RUNS = 50
WARM_UP = 10
RUN_TIMEOUT_MS = 60_000
#: Resident memory may grow this much from run 10 to run 50 (allocator noise, Qt caches).
RSS_SLACK_MB = 40
#: Native threads may differ by this much (Qt's pool retires idle threads after 30 s).
THREAD_SLACK = 2


def _rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _native_threads() -> int:
    return len(os.listdir("/proc/self/task"))


def _tiny_document():
    from terrasynth_core.synthesis import SynthesisParams
    from terrasynth_app.model import Document, ExampleRef, Sketch

    sketch = Sketch.blank((64, 64))
    sketch.draw_polyline([(10, 32), (54, 32)], "ridge", radius=2, hardness=1.0)
    sketch.history.clear()
    return Document(sketch, [ExampleRef(builtin="white-mountains", crop=(400, 650, 400, 650))],
                    params=SynthesisParams(patch_size=32, k=3, seed=1))


def _python_threads() -> int:
    # The fill's reusable worker pool (loky) is one per process, not per
    # run; its two manager threads come and go with its work.
    return sum(t.name not in ("ExecutorManagerThread", "QueueFeederThread") for t in threading.enumerate())


def test_fifty_runs_back_to_back_keep_memory_and_threads_flat(qtbot, tmp_path, dialogs, record_property):
    from terrasynth_app.views.main_window import MainWindow

    window = MainWindow(_tiny_document(), settings=QSettings(str(tmp_path / "s.ini"), QSettings.IniFormat))
    qtbot.addWidget(window)
    window.show()
    samples = []
    for run in range(1, RUNS + 1):
        with qtbot.waitSignal(window.synthesis.finished, timeout=RUN_TIMEOUT_MS):
            window.synthesize()
        qtbot.waitUntil(lambda: not window.synthesis.running, timeout=RUN_TIMEOUT_MS)
        if run in (WARM_UP, RUNS):
            gc.collect()
            samples.append((_rss_mb(), _native_threads(), _python_threads()))
    (rss0, native0, py0), (rss1, native1, py1) = samples
    record_property("rss_mb", f"{rss0:.0f} -> {rss1:.0f}")
    record_property("native_threads", f"{native0} -> {native1}")
    record_property("python_threads", f"{py0} -> {py1}")
    assert window.document.result is not None and window.document.result.shape == (64, 64)
    assert rss1 - rss0 < RSS_SLACK_MB, f"resident memory grew {rss1 - rss0:.1f} MB over {RUNS - WARM_UP} runs"
    assert native1 - native0 <= THREAD_SLACK, f"native threads {native0} -> {native1}"
    assert py1 == py0, f"Python threads {py0} -> {py1}"
    assert dialogs.calls == []
    window.synthesis.wait()
