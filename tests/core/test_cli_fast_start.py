"""Fast start: ``terrasynth-cli --help`` loads no numerical library, and the
packages' public names still import (lazily, terrasynth_core._lazy).

A check of what is loaded, not a timing (timings flake on a shared machine):
numpy alone costs 0.1-0.4 s to import, scipy.ndimage about 1 s.
"""

import argparse
import importlib
import json
import subprocess
import sys

import pytest

#: Modules ``--help`` must not load.
HEAVY = ("numpy", "scipy", "skimage", "maxflow", "rasterio", "PIL", "tqdm", "OpenEXR", "pyfqmr")

#: Every package with lazily exported names.
PACKAGES = ("terrasynth_core", "terrasynth_core.blending", "terrasynth_core.controls", "terrasynth_core.exemplars",
            "terrasynth_core.export", "terrasynth_core.features", "terrasynth_core.matching",
            "terrasynth_core.order", "terrasynth_core.pictures", "terrasynth_core.placing",
            "terrasynth_core.project", "terrasynth_core.synthesis", "terrasynth_core.warping")

#: Builds the parser, formats the help of every subcommand and lists the
#: heavy modules loaded by then, in a fresh interpreter.
_PROBE = """
import json, sys
from terrasynth_core.cli.main import build_parser
parser = build_parser()
helps = [parser.format_help()]
for action in parser._subparsers._group_actions:
    helps += [sub.format_help() for sub in action.choices.values()]
heavy = sorted({m.split(".")[0] for m in sys.modules} & set(json.loads(sys.argv[1])))
print(json.dumps({"heavy": heavy, "helps": len(helps)}))
"""


def test_the_parser_and_every_help_load_no_numerical_library():
    done = subprocess.run([sys.executable, "-c", _PROBE, json.dumps(HEAVY)], capture_output=True, text=True,
                          check=True)
    report = json.loads(done.stdout)
    assert report["heavy"] == []
    assert report["helps"] >= 8  # the top level and every subcommand


def test_importing_the_packages_loads_none_of_their_stages():
    probe = ("import importlib, json, sys\n"
             "for package in json.loads(sys.argv[2]): importlib.import_module(package)\n"
             "print(json.dumps(sorted({m.split('.')[0] for m in sys.modules} & set(json.loads(sys.argv[1])))))")
    done = subprocess.run([sys.executable, "-c", probe, json.dumps(HEAVY), json.dumps(PACKAGES)],
                          capture_output=True, text=True, check=True)
    assert json.loads(done.stdout) == []


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_still_imports(package):
    module = importlib.import_module(package)
    assert module.__all__
    for name in module.__all__:
        value = getattr(module, name)
        assert name in dir(module)
        # Stored in the package after the first look-up.
        assert module.__dict__[name] is value
    with pytest.raises(AttributeError, match="no_such_name"):
        module.no_such_name  # noqa: B018


def test_public_names_and_submodules_import_as_before():
    from terrasynth_core.features import extract_features, ppa
    from terrasynth_core.synthesis import Session, session

    assert Session is session.Session
    assert extract_features is ppa.extract_features


def test_the_parsers_preset_and_mask_names_are_the_exports():
    from terrasynth_core.cli.main import MASK_FORMATS, PRESET_NAMES, build_parser
    from terrasynth_core.export import MASK_FORMATS as EXPORT_MASK_FORMATS
    from terrasynth_core.export import preset_names

    assert PRESET_NAMES == preset_names()
    assert MASK_FORMATS == EXPORT_MASK_FORMATS
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    preset = {a.dest: a for a in sub.choices["export"]._actions}["preset"]
    assert tuple(preset.choices) == preset_names()
