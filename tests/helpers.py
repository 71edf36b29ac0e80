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
    """`RollProblem.from_sea` of the default ship in ITTC(hs, t01), head seas, zero speed (cached)."""
    return jxr.RollProblem.from_sea(SHIP, jxr.ITTC(hs, t01), excitation=excitation, dt=dt)


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
    for name, var in ds.variables.items():
        assert var.attrs.get("long_name"), f"{stem}.nc: {name} has no long_name"
        if var.dtype.kind not in "USO":  # text labels have no unit
            assert var.attrs.get("units"), f"{stem}.nc: {name} has no units"
    labels = {str(v) for c in ds.coords.values() if c.dtype.kind in "US" for v in c.values}
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


def _same_number(key: str, value) -> bool:
    try:
        return float(key) == float(value)
    except (TypeError, ValueError):
        return False
