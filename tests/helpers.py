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
    settings = {s: getattr(jax.config, s) for s in
                ("jax_compilation_cache_dir", "jax_persistent_cache_min_compile_time_secs")}
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
