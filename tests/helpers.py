"""Shared test helpers: the default ship and problems (built once per session, so their filter fits and compiled
kernels are shared across test files), relative errors, and standard-error tolerances."""

import functools
import math
from pathlib import Path

import numpy as np

import jaxroll as jxr

SHIP = jxr.c11_representative()


@functools.lru_cache(maxsize=16)
def default_problem(hs: float = 7.0, t01: float = 10.0, *, excitation: str = "filter", dt: float = 0.5):
    """`RollProblem.from_sea` of the default ship in ITTC(hs, t01), head seas, zero speed, with the paper's order-4
    filter (the kernel's tests are about the integrator and its streams, pinned on that filter; the default order
    is tested in test_effective_wave.py, test_validation.py and the CLI's tests) (cached)."""
    import warnings

    with warnings.catch_warnings():  # the order-4 filter's band warning (docs/validation.md)
        warnings.filterwarnings(
            "ignore", message=".*shaping filter's spectrum is .* off the effective wave's"
        )
        return jxr.RollProblem.from_sea(SHIP, jxr.ITTC(hs, t01), excitation=excitation, dt=dt, filter_order=4)


def rel(a, b) -> float:
    """Relative difference a/b − 1 of two scalars."""
    return float(a) / float(b) - 1.0


def standard_error_of_mean(sums, counts) -> float:
    """Standard error of a ratio estimator Σsums/Σcounts over independent realizations (delta method)."""
    sums, counts = np.asarray(sums, float), np.asarray(counts, float)
    keep = counts > 0
    sums, counts = sums[keep], counts[keep]
    m = sums.sum() / counts.sum()
    resid = sums - m * counts
    n = counts.size
    return math.sqrt(n / (n - 1) * np.sum(resid**2)) / counts.sum()


def assert_within_se(value, reference, se, k: float = 3.0, what: str = "") -> None:
    """|value − reference| ≤ k·se, with a message that shows the numbers."""
    assert abs(float(value) - float(reference)) <= k * float(se), (
        f"{what}: {float(value):.6g} vs {float(reference):.6g}, |Δ| = {abs(float(value) - float(reference)):.3g} "
        f"> {k} × SE {float(se):.3g}"
    )


NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"


def run_notebook(name: str, tmp_path, monkeypatch) -> dict:
    """Run notebooks/`name` top to bottom in smoke mode (`JAXROLL_SMOKE=1`, figures to Agg, working folder
    `tmp_path`) and return its namespace; a failing cell fails the test with the cell's error.

    The cells run in this process, in a fresh IPython shell (IPython's own cell execution: magics, display, the
    last expression shown), so a notebook reuses what the tests before it traced and compiled instead of starting a
    kernel that imports and compiles everything again (3–4 s of each notebook test). The notebook sees what a
    user's kernel sees: JAX's standard dtype promotion (the tests run strict), warnings that do not stop it (kept
    out of the test's report); the JAX settings it changes (`enable_compilation_cache`) and the interpreter's hooks
    are put back afterwards."""
    import sys
    import warnings

    import jax
    import matplotlib.pyplot as plt
    import nbformat
    from IPython.core.interactiveshell import InteractiveShell
    from traitlets.config import Config

    nb = nbformat.read(NOTEBOOKS / name, as_version=4)
    cells = [c for c in nb.cells if c.cell_type == "code"]
    assert all(not c.get("outputs") for c in cells), "store notebooks without outputs"
    monkeypatch.setenv("JAXROLL_SMOKE", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("IPYTHONDIR", str(tmp_path / ".ipython"))
    monkeypatch.chdir(tmp_path)
    settings = {
        s: getattr(jax.config, s)
        for s in ("jax_compilation_cache_dir", "jax_persistent_cache_min_compile_time_secs")
    }
    hooks = (sys.displayhook, sys.excepthook)
    config = Config()
    config.HistoryManager.enabled = False
    shell = InteractiveShell(config=config)
    try:
        with jax.numpy_dtype_promotion("standard"), warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            for i, cell in enumerate(cells):
                result = shell.run_cell(cell.source, store_history=False)
                error = result.error_before_exec or result.error_in_exec
                if error is not None:
                    raise AssertionError(f"{name}, code cell {i + 1} failed:\n{cell.source}") from error
        return dict(shell.user_ns)
    finally:
        for s, v in settings.items():
            jax.config.update(s, v)
        sys.displayhook, sys.excepthook = hooks
        plt.close("all")


def assert_labelled_output(folder, stem: str) -> None:
    """A command's netCDF (`<stem>.nc`) beside its JSON (`<stem>.json`): it opens with plain
    `xarray.open_dataset`, every variable and coordinate has a long name and (numbers) units, the attributes hold
    the versions and the configuration, and it round-trips the JSON's numbers: each variable's values equal the
    JSON field its `json_path` names (label by label), and every number of the JSON (outside `config`) is in a
    variable, in a text attribute, or in a field the file declares not stored (`json_fields_not_stored`)."""
    import json

    import xarray as xr

    folder = Path(folder)
    payload = json.loads((folder / f"{stem}.json").read_text())
    with xr.open_dataset(folder / f"{stem}.nc") as ds:
        ds = ds.load()
    for key in ("jaxroll_version", "jax_version", "jaxlib_version", "backend", "device_kind"):
        assert ds.attrs.get(key), f"{stem}.nc has no {key} attribute"
    assert ds.attrs["jaxroll_version"] == payload["jaxroll_version"] == jxr.__version__
    assert json.loads(ds.attrs["config_json"]) == payload["config"]
    assert_cf(ds, payload["config"], stem)
    ds = ds.isel({d: 0 for d in ds.attrs["input_dims"].split()})  # the run's inputs: length-1 dimensions
    assert json.loads(ds.run_config.item()) == payload["config"]
    labels = {str(v) for c in ds.coords.values() if c.dtype.kind in "US" for v in np.atleast_1d(c.values)}
    seen = set()

    def values_at(node, parts, dims, index, concrete):
        """(value, concrete path) of the JSON at `parts`, `{dim}` taken from the coordinate at `index`."""
        for part in parts:
            if part.startswith("{"):
                dim = part[1:-1]
                want = ds[dim].values[index[dim]].item() if dim in ds.coords else index[dim]
                if isinstance(node, list):
                    if not isinstance(want, int) or want >= len(node):
                        return None, None
                    key = want
                else:
                    keys = [k for k in node if k == str(want) or _same_number(k, want)]
                    if not keys:
                        return None, None
                    key = keys[0]
                node, concrete = node[key], (*concrete, str(key))
            else:
                if not isinstance(node, dict) or part not in node:
                    return None, None
                node, concrete = node[part], (*concrete, part)
        return node, concrete

    for name, var in ds.variables.items():
        path = var.attrs.get("json_path")
        if path is None:
            continue
        parts = path.split("/")
        label_dims = [p[1:-1] for p in parts if p.startswith("{")]
        for idx in np.ndindex(*(ds.sizes[d] for d in label_dims)):
            index = dict(zip(label_dims, idx, strict=True))
            node, concrete = values_at(payload, parts, label_dims, index, ())
            got = var.isel({d: i for d, i in index.items()}).values
            if concrete is None:  # a label this field does not have (e.g. a theory without closure order)
                assert got.dtype.kind in "US" or np.all(np.isnan(np.asarray(got, float))), (stem, name, index)
                continue
            if got.dtype.kind in "US":
                assert list(np.atleast_1d(got)) == (node if isinstance(node, list) else [node]), (stem, name)
            else:
                expect = np.array(node, dtype=float) if node is not None else np.full(got.shape, np.nan)
                np.testing.assert_array_equal(
                    np.where(np.isfinite(got), got, np.nan).astype(float),
                    expect,
                    err_msg=f"{stem}.nc {name} at {index} vs {'/'.join(concrete)}",
                )
            seen.add(concrete)
    skipped = set(json.loads(ds.attrs.get("json_fields_not_stored", "{}")))

    def numbers(node, path):
        if isinstance(node, dict):
            for k, v in node.items():
                yield from numbers(v, (*path, str(k)))
        elif isinstance(node, list) and node and all(isinstance(v, dict) for v in node):
            for i, v in enumerate(node):
                yield from numbers(v, (*path, str(i)))
        elif isinstance(node, bool | int | float) or (
            isinstance(node, list) and any(isinstance(v, bool | int | float | list) for v in node)
        ):
            yield path

    missing = []
    for path in numbers({k: v for k, v in payload.items() if k not in ("config", "jaxroll_version")}, ()):
        if any(path[: len(p)] == p for p in seen) or "/".join(path[:1]) in skipped:
            continue
        kept = [p for p in path if p not in labels and not p.isdigit()]
        if any("_".join(kept[:k]) in ds.attrs for k in range(1, len(kept) + 1)):  # stored as JSON text
            continue
        missing.append("/".join(path))
    assert not missing, f"{stem}.json numbers not in {stem}.nc: {missing[:10]}"


#: The inputs a command's netCDF has as length-1 dimensions where its `config` gives them (issue 45).
INPUTS = {"hs_m": ("sea", "hs_m"), "t01_s": ("sea", "t01_s"), "heading_deg": ("heading_deg",),
          "speed_m_s": ("speed_m_s",), "seed": ("seed",), "ship": ("ship", "name")}  # fmt: skip


def assert_cf_variables(ds, where: str = "dataset") -> None:
    """Every variable and coordinate has a `long_name`; every number a UDUNITS `units` (no `1/s`, no `^`) that pint
    parses (cf-xarray's UDUNITS registry) to the dimensions its name states (a variable mixing units along a label
    says so in `comment` instead); `standard_name`s are what cf-xarray finds."""
    import cf_xarray  # noqa: F401  (the `.cf` accessor)
    import pint
    from cf_xarray.units import units as ureg

    from jaxroll._labels._units import units_from_name

    for name, var in ds.variables.items():
        assert var.attrs.get("long_name"), f"{where}: {name} has no long_name"
        if var.dtype.kind in "USO":  # text labels have no unit
            continue
        units = var.attrs.get("units")
        if units is None:
            assert var.attrs.get("comment", "").startswith("units: mixed"), f"{where}: {name} has no units"
            continue
        assert "/" not in units and "^" not in units and units == units.strip(), (where, name, units)
        try:
            parsed = ureg.Unit(units)
        except (pint.errors.PintError, ValueError, TypeError) as e:
            raise AssertionError(f"{where}: {name}: pint cannot parse units {units!r} ({e})") from None
        named = units_from_name(str(name))  # the unit the name states (`_deg`, `_m_s`, `_per_s`, …)
        if named is not None and named != "1":
            assert parsed.dimensionality == ureg.Unit(named).dimensionality, (where, name, units, named)
        if named == "degree":  # `_deg`: degrees, written one way
            assert units == "degree", (where, name, units)
        if units == "degree":  # and degrees say so (docs/conventions.md: one angle rule)
            assert "_deg" in str(name), (where, name, units)
        if "standard_name" in var.attrs:
            assert name in ds.cf.standard_names[var.attrs["standard_name"]], (where, name)
    for name in ("unit", "parameter_unit", "statistic_unit"):  # each label's unit, where units are mixed
        if name in ds.variables:
            for u in np.atleast_1d(ds[name].values):
                ureg.Unit(str(u))


def assert_cf(ds, config: dict, stem: str) -> None:
    """A command's netCDF as CF tools read it: `Conventions`, `history` (time and command line), its variables as
    `assert_cf_variables` says, and the inputs its `config` gives as length-1 dimension coordinates."""
    import re

    assert ds.attrs["Conventions"] == "CF-1.10", stem
    assert re.match(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ: jaxroll", ds.attrs["history"]), ds.attrs["history"]
    assert_cf_variables(ds, f"{stem}.nc")
    for dim, path in INPUTS.items():
        node = config
        for key in path:
            node = node.get(key) if isinstance(node, dict) else None
        if node is not None and not isinstance(node, bool) and isinstance(node, int | float | str):
            assert dim in ds.dims or dim in ds.variables, f"{stem}.nc lacks the input {dim}"
            if dim in ds.attrs["input_dims"].split():
                assert ds.sizes[dim] == 1 and ds[dim].item() == node, (stem, dim)
                assert ds.run_config.dims == tuple(ds.attrs["input_dims"].split()), stem
    for dim in ("hs_m", "hs"):
        if dim in ds.dims:
            assert dim in ds.cf["sea_surface_wave_significant_height"].dims


def _same_number(key: str, value) -> bool:
    try:
        return float(key) == float(value)
    except (TypeError, ValueError):
        return False
