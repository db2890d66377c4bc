"""The built-in example library: every example loads clean, has a thumbnail,
lives in the installed package, and ships in a built wheel."""

import fnmatch
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import terrasynth_core.resources
from terrasynth_core.errors import DEMFormatError
from terrasynth_core.examples import (
    BUILTIN_EXAMPLES,
    DEFAULT_EXAMPLE,
    DEFAULT_SKETCH,
    builtin_example,
    builtin_sketches,
    resolve_dem,
    resource_path,
)

REPO = Path(__file__).resolve().parents[2]
KEYS = [ex.key for ex in BUILTIN_EXAMPLES]


@pytest.mark.parametrize("key", KEYS)
def test_builtin_example_loads_without_nodata_margins(key):
    field = builtin_example(key).load()
    assert field.heights.dtype == np.float32
    valid = ~field.nodata
    # Every row and column holds real heights; voids only inside (the
    # Himalayan basin clip, kept whole: the engine keeps patches off them).
    assert valid.any(axis=0).all() and valid.any(axis=1).all()
    assert valid.mean() > (0.5 if key == "himalaya" else 0.999)
    rows, cols = field.shape
    assert rows >= 250 and cols >= 250, f"{key} is only {rows}x{cols} after cropping to valid cells"
    assert field.max - field.min > 100, f"{key} has almost no relief"
    assert field.cell_size is not None and all(10 < v < 200 for v in field.cell_size)


@pytest.mark.parametrize("key", KEYS)
def test_builtin_example_has_png_thumbnail(key):
    path = builtin_example(key).thumbnail_path
    assert path.is_file()
    with Image.open(path) as image:
        assert image.format == "PNG"
        assert min(image.size) >= 32


def test_builtin_keys_are_unique_and_defaults_exist():
    assert len(set(KEYS)) == len(KEYS) == 5
    assert DEFAULT_EXAMPLE in KEYS
    assert DEFAULT_SKETCH in [p.name for p in builtin_sketches()]


def test_builtin_sketches_are_the_shipped_pngs():
    names = [p.name for p in builtin_sketches()]
    shipped = (REPO / "resources" / "sketches").glob("*.png")
    assert names == sorted(p.name for p in shipped if not p.stem.endswith(("_styles", "_water")))
    assert "middle_earth_sketch.png" in names
    assert "y_junction_512.png" in names and "ring_cross_512.png" in names


def test_unknown_builtin_lists_valid_keys():
    with pytest.raises(DEMFormatError, match="'nope'") as exc:
        resolve_dem("builtin:nope")
    message = str(exc.value)
    assert "\n" not in message
    for key in KEYS:
        assert key in message


def test_resolve_dem_trims_builtins_but_not_files():
    """A built-in loses its nodata margins (the ragged St. Helens quadrangle
    is cropped to its largest valid rectangle); the Himalayan basin, whose
    rectangle would hold half its valid cells, keeps them all.  A file is
    read as it is."""
    helens = resolve_dem("builtin:st-helens")
    raw = resolve_dem(builtin_example("st-helens").path)
    assert helens.nodata_count == 0 and raw.nodata_count > 0
    assert helens.shape[0] < raw.shape[0] and helens.shape[1] < raw.shape[1]
    np.testing.assert_array_equal(helens.heights, builtin_example("st-helens").load().heights)
    basin = resolve_dem("builtin:himalaya")
    raw = resolve_dem(builtin_example("himalaya").path)
    assert (~basin.nodata).sum() == (~raw.nodata).sum() > 200_000


def test_resource_path_is_inside_installed_package():
    package_dir = Path(terrasynth_core.resources.__file__).resolve().parent
    path = resource_path("dems", "N44W072.hgt")
    assert path.is_file()
    assert path.resolve().parent.parent == package_dir
    assert Path(str(resources.files("terrasynth_core.resources"))).resolve() == package_dir
    for ex in BUILTIN_EXAMPLES:
        assert ex.path.is_file() and ex.path.resolve().is_relative_to(package_dir)


# -- packaging ----------------------------------------------------------------
# A wheel cannot be built offline here (the venv's setuptools is older than
# the pyproject's "setuptools>=69" and 'wheel' is absent, so
# `pip wheel --no-build-isolation` fails), so this checks the setuptools
# configuration that decides the wheel's contents instead.
def _setuptools_config() -> dict:
    with open(REPO / "pyproject.toml", "rb") as f:
        return tomllib.load(f)


def _package_folder(name: str, package_dir: dict[str, str]) -> Path:
    """Folder of dotted package ``name`` by setuptools' package-dir rules."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        prefix = ".".join(parts[:i])
        if prefix in package_dir:
            return REPO / package_dir[prefix] / Path(*parts[i:])
    return REPO / Path(*parts)


def test_wheel_config_lists_every_subpackage():
    tool = _setuptools_config()["tool"]["setuptools"]
    packages, package_dir = tool["packages"], tool["package-dir"]
    for top in ("terrasynth_core", "terrasynth_app", "terrasynth_core.resources"):
        assert top in packages
    missing = []
    for top in ("terrasynth_core", "terrasynth_app"):
        root = _package_folder(top, package_dir)
        for init in sorted(root.rglob("__init__.py")):
            rel = init.parent.relative_to(root)
            if "__pycache__" in rel.parts:
                continue
            name = ".".join((top, *rel.parts))
            if name not in packages:
                missing.append(name)
    assert not missing, f"packages left out of the wheel by pyproject.toml: {', '.join(missing)}"


def _shipped(path: Path, tool: dict) -> bool:
    """True when a package-data glob of a listed package matches ``path``
    (globs are relative to their package's folder; ``*`` stays in one folder)."""
    for package, globs in tool["package-data"].items():
        folder = _package_folder(package, tool["package-dir"])
        if package not in tool["packages"] or not path.is_relative_to(folder):
            continue
        rel = path.relative_to(folder).as_posix()
        if any(fnmatch.fnmatch(rel, g) and rel.count("/") == g.count("/") for g in globs):
            return True
    return False


def test_wheel_config_ships_resources():
    config = _setuptools_config()
    tool = config["tool"]["setuptools"]
    root = _package_folder("terrasynth_core.resources", tool["package-dir"])
    assert root == REPO / "resources"
    wanted = ["dems/Mandakini.hdr", "README.md"]
    wanted += [f"dems/{ex.filename}" for ex in BUILTIN_EXAMPLES]
    wanted += [f"thumbnails/{ex.key}.png" for ex in BUILTIN_EXAMPLES]
    wanted += [f"sketches/{p.name}" for p in builtin_sketches()]
    assert "dems/N44W072.hgt" in wanted
    for rel in wanted:
        assert (root / rel).is_file(), rel
        assert _shipped(root / rel, tool), f"resources/{rel} is not in the wheel's package-data"
    assert config["project"]["scripts"]["terrasynth-cli"] == "terrasynth_core.cli:main"


def test_a_bare_builtin_key_says_how_to_name_it(tmp_path, monkeypatch):
    from terrasynth_core.errors import DEMFormatError
    from terrasynth_core.examples import resolve_dem

    monkeypatch.chdir(tmp_path)
    with pytest.raises(DEMFormatError, match="builtin:himalaya"):
        resolve_dem("himalaya")
