"""A tiled run's task wrapper: the task's value or error, and its freed memory
handed back."""

import platform

import pytest

from terrasynth_core.tiled import task


def test_run_task_returns_the_value_and_trims(monkeypatch):
    calls = []
    monkeypatch.setattr(task, "release_freed_memory", lambda: calls.append("trim"))
    assert task.run_task(lambda a, b: a + b, 2, 3) == 5
    assert calls == ["trim"]


def test_run_task_trims_after_an_error_too(monkeypatch):
    calls = []
    monkeypatch.setattr(task, "release_freed_memory", lambda: calls.append("trim"))

    def fails():
        raise ValueError("the task's own error")

    with pytest.raises(ValueError, match="the task's own error"):
        task.run_task(fails)
    assert calls == ["trim"]


@pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc", reason="glibc only")
def test_malloc_trim_found_on_glibc():
    assert task._malloc_trim() is not None
    task.release_freed_memory()  # returns, whatever it hands back
