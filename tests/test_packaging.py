"""Honest packaging: the dependency floors CI installs are the ones pyproject.toml declares, the package ships its
licence, changelog and type marker, every JSON output records the versions that produced it, and the netCDF
round trip works on the libraries installed (the oldest-versions step of .ci/run runs this file)."""

import json
import re
import tomllib
from pathlib import Path

import numpy as np
from packaging.version import Version

import jaxroll

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
OLDEST = ROOT / ".ci" / "oldest.txt"


def _name(requirement: str) -> str:
    return re.split(r"[<>=!~;\[ ]", requirement, maxsplit=1)[0].lower().replace("_", "-")


def _pins() -> dict[str, str]:
    pins = {}
    for line in OLDEST.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            name, version = line.split("==")
            pins[_name(name)] = version.strip()
    return pins


def test_every_floor_is_pinned_in_the_oldest_versions_ci_installs():
    """Each runtime dependency has a floor (`>=`), and .ci/oldest.txt pins exactly that version (the CI step that
    installs them and runs tests proves the floor); jaxlib's floor is jax's."""
    pins = _pins()
    floors = {}
    for requirement in PYPROJECT["project"]["dependencies"]:
        match = re.search(r">=\s*([0-9][^,;\s]*)", requirement)
        assert match, f"{requirement!r} has no floor"
        floors[_name(requirement)] = match.group(1)
    assert {k: Version(v) for k, v in floors.items()} == {
        k: Version(v) for k, v in pins.items() if k in floors
    }
    assert set(pins) - set(floors) == {"jaxlib"} and pins["jaxlib"] == pins["jax"]


def test_package_metadata():
    project = PYPROJECT["project"]
    assert project["version"] == "0.2.0"
    assert project["license"] == "Apache-2.0" and "LICENSE" in project["license-files"]
    assert (
        "Apache License" in (ROOT / "LICENSE").read_text()
        and "Version 2.0, January 2004" in (ROOT / "LICENSE").read_text()
    )
    assert f"## {project['version']}" in (ROOT / "CHANGELOG.md").read_text()
    assert (ROOT / "jaxroll" / "py.typed").is_file()
    assert "Typing :: Typed" in project["classifiers"]
    assert "ruff" in " ".join(project["optional-dependencies"]["dev"])


def test_json_outputs_record_versions(tmp_path, monkeypatch):
    import warnings

    import jaxroll._cli as cli
    from jaxroll._cli._common import WARNINGS, write_json

    # A command run in this process before leaves none of its warnings behind (the JSON below once got an earlier
    # test's `warnings`, by the order the test workers took the files in).
    seen = []

    def command(args):
        warnings.simplefilter("always")  # inside main's catch_warnings: pytest's "error" comes back after it
        warnings.warn("a warning of the command")
        seen.extend(WARNINGS)
        return 0

    monkeypatch.setattr(cli, "_run", command)
    assert cli.main(["ship", "show"]) == 0
    assert seen == ["a warning of the command"] and WARNINGS == []

    write_json(tmp_path / "out.json", {"config": {"hs_m": 7.0}, "mean_amplitude_deg": 9.8})
    data = json.loads((tmp_path / "out.json").read_text())
    assert list(data) == [
        "jaxroll_version",
        "config",
        "mean_amplitude_deg",
        "versions",
    ]  # names stable, first first
    v = data["versions"]
    assert v == jaxroll.io.provenance()
    assert v["jaxroll_version"] == data["jaxroll_version"] == jaxroll.__version__
    import jax

    assert (
        v["jax_version"] == jax.__version__ and v["backend"] == jax.default_backend() and v["x64"] == "true"
    )
    assert {
        "jaxlib_version",
        "equinox_version",
        "diffrax_version",
        "optimistix_version",
        "numpy_version",
        "device_kind",
    } <= set(v)


def test_netcdf_round_trip(tmp_path):
    """xarray, h5netcdf and h5py as installed (the floors in the oldest-versions CI step) write and read a dataset
    with units, a boolean variable and the provenance attributes."""
    import xarray as xr

    ds = xr.Dataset(
        {
            "pdf": (
                "amplitude_deg",
                np.array([0.1, 0.5, 0.4]),
                {"units": "1/deg", "long_name": "amplitude PDF"},
            ),
            "capsized": ("trial", np.array([True, False])),
        },
        coords={"amplitude_deg": [1.0, 2.0, 3.0]},
        attrs=jaxroll.io.dataset_attrs({"hs_m": 7.0}),
    )
    jaxroll.io.write_dataset(tmp_path / "r.nc", ds)
    back = jaxroll.io.read_dataset(tmp_path / "r.nc")
    np.testing.assert_array_equal(back["pdf"].values, ds["pdf"].values)
    assert back["capsized"].dtype == bool and back["capsized"].values.tolist() == [True, False]
    assert back["pdf"].attrs["units"] == "1/deg" and json.loads(back.attrs["config_json"]) == {"hs_m": 7.0}
    assert back.attrs["jax_version"] == jaxroll.io.provenance()["jax_version"]
