"""scripts/digests.py records the numerical environment with its digests and
names what moved when a comparison's environment is not the reference's."""

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
import digests  # noqa: E402


def test_environment_names_the_libraries_and_their_blas():
    env = digests.environment()
    for name in digests.PACKAGES:
        assert env[name]  # a version, or "absent"
    assert env["numpy"] != "absent" and env["scipy"] != "absent"
    blas = [value for key, value in env.items() if key.startswith("blas in ")]
    assert blas, "numpy and scipy wheels bring a BLAS; threadpoolctl should see it"


def test_differences_name_what_moved():
    here = digests.environment()
    assert digests.environment_differences({digests.ENVIRONMENT: here}) == []
    there = {**here, "scipy": "0.0.1"}
    assert digests.environment_differences({digests.ENVIRONMENT: there}) == [
        f"scipy: 0.0.1 there, {here['scipy']} here"]
    assert digests.environment_differences({}) == ["the reference does not record its environment"]


def test_the_reference_records_its_environment():
    reference = json.loads((Path(digests.__file__).parent / "digests_reference.json").read_text())
    assert set(reference[digests.ENVIRONMENT]) >= set(digests.PACKAGES)
    assert len([k for k in reference if k != digests.ENVIRONMENT]) == len(digests.CASES)
