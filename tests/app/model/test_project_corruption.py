"""Damaged project files (issue 13, finding 3): every corruption gives one
:class:`ProjectError` naming the file and the problem, never a raw exception,
and absurd layer sizes are refused before anything is allocated."""

import io
import json
import re
import time
import tracemalloc
import zipfile

import numpy as np
import pytest

from terrasynth_app.model import Document, ExampleRef, ProjectError, RecoveryStore, Sketch, load_project, save_project


def _saved(tmp_path, name="p.tsproj"):
    sketch = Sketch.blank((48, 64))
    sketch.draw_polyline([(10, 5), (10, 50)], "ridge", radius=2)
    doc = Document(sketch, [ExampleRef(builtin="white-mountains", crop=(0, 200, 0, 300))])
    return save_project(doc, tmp_path / name)


def _rewrite(path, **members):
    """Replace (or, with None, drop) members of the zip at ``path``."""
    with zipfile.ZipFile(path) as zf:
        content = {name: zf.read(name) for name in zf.namelist()}
    for name, data in members.items():
        name = name.replace("__", ".")
        if data is None:
            content.pop(name, None)
        else:
            content[name] = data if isinstance(data, bytes) else data.encode()
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, data in content.items():
            zf.writestr(name, data)


def _meta(path):
    with zipfile.ZipFile(path) as zf:
        return json.loads(zf.read("project.json"))


def _huge_layer_header(shape=(40000, 40000), dtype="|u1") -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": dtype, "fortran_order": False, "shape": shape})
    return buf.getvalue() + b"\0" * 64


def c_meta_is_a_list(path):
    _rewrite(path, project__json="[1, 2, 3]")
    return "list"


def c_meta_not_json(path):
    _rewrite(path, project__json="{not json")
    return "damaged"


def c_meta_missing_examples(path):
    meta = _meta(path)
    del meta["examples"]
    _rewrite(path, project__json=json.dumps(meta))
    return "'examples'"


def c_params_is_a_string(path):
    meta = _meta(path)
    meta["params"] = "fast"
    _rewrite(path, project__json=json.dumps(meta))
    return "'params'"


def c_pins_are_numbers(path):
    meta = _meta(path)
    meta["pins"] = [1, 2]
    _rewrite(path, project__json=json.dumps(meta))
    return "'pins'"


def c_example_entry_is_a_string(path):
    meta = _meta(path)
    meta["examples"] = ["white-mountains"]
    _rewrite(path, project__json=json.dumps(meta))
    return "'examples'"


def c_missing_layer(path):
    _rewrite(path, sketch_valley__npy=None)
    return "sketch_valley"


def c_layer_is_3d(path):
    buf = io.BytesIO()
    np.save(buf, np.zeros((2, 3, 4), np.uint8))
    _rewrite(path, sketch_ridge__npy=buf.getvalue())
    return "sketch_ridge.npy.*2-D"


def c_layer_not_npy(path):
    _rewrite(path, sketch_ridge__npy="hello")
    return "damaged"


def c_huge_layers(path):
    _rewrite(path, sketch_ridge__npy=_huge_layer_header(), sketch_valley__npy=_huge_layer_header())
    return "40000 x 40000"


def c_truncated(path):
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    return "damaged"


def c_empty_file(path):
    path.write_bytes(b"")
    return "damaged"


CORRUPTIONS = [c_meta_is_a_list, c_meta_not_json, c_meta_missing_examples, c_params_is_a_string,
               c_pins_are_numbers, c_example_entry_is_a_string, c_missing_layer, c_layer_is_3d, c_layer_not_npy,
               c_huge_layers, c_truncated, c_empty_file]


def _assert_one_project_error(path, pattern):
    tracemalloc.start()
    start = time.perf_counter()
    try:
        with pytest.raises(ProjectError) as exc:
            load_project(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    message = str(exc.value)
    assert path.name in message and "\n" not in message
    assert re.search(pattern, message), message
    # Refused before allocating: two 40000x40000 layers would be 3.2 GB.
    assert peak < 200e6 and time.perf_counter() - start < 10


@pytest.mark.parametrize("corrupt", CORRUPTIONS, ids=lambda f: f.__name__[2:])
def test_every_corruption_is_one_project_error(tmp_path, corrupt):
    path = _saved(tmp_path)
    _assert_one_project_error(path, corrupt(path))


def test_bit_rot_is_one_project_error(tmp_path, bit_rot):
    """Bit-rot inside a member raised zlib.error."""
    path = _saved(tmp_path)
    bit_rot(path)
    _assert_one_project_error(path, "sketch_ridge|damaged")


def test_recovery_info_that_is_not_an_object(tmp_path):
    """A ``recovery.json`` holding a list (or wrong types) neither breaks describe() nor load()."""
    store = RecoveryStore(tmp_path / "rec")
    doc = load_project(_saved(tmp_path))
    store.save(doc)
    for text in ("[1, 2]", '{"original": 5, "saved_at": []}', "{broken"):
        (tmp_path / "rec" / "recovery.json").write_text(text)
        assert store.describe() == "Unsaved work on an untitled project, autosaved at an unknown time"
        recovered = store.load()
        assert recovered.path is None and recovered.dirty


def test_saved_projects_get_the_mode_other_outputs_get(tmp_path):
    """Issue 13, finding 8: projects were 0600 (mkstemp) while every other output follows the umask."""
    import os
    import stat

    old = os.umask(0o022)
    try:
        path = _saved(tmp_path)
        (tmp_path / "other").write_text("x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == stat.S_IMODE((tmp_path / "other").stat().st_mode) == 0o644
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []
