"""Small numerical helpers and input checks shared by the amplitude laws and the extremes."""

import math

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._compiled import require

_LOG_HALF = -math.log(2.0)
_GL_NODES, _GL_WEIGHTS = (np.asarray(v) for v in np.polynomial.legendre.leggauss(8))
_BISECTION_STEPS = 110  # halves the bracket to below one ulp from any float64 starting width
_DOUBLING_STEPS = 64
_UPPER_TAIL = 1e-20  # E[max] integrals stop where N0·F̄ has fallen to this
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def _log1mexp(y):
    """log(1 − e^y) for y ≤ 0, accurate at both ends (Mächler 2012)."""
    y = jnp.minimum(y, 0.0)
    near = y > _LOG_HALF
    y_near = jnp.where(near, y, _LOG_HALF)
    y_far = jnp.where(near, _LOG_HALF, y)
    return jnp.where(near, jnp.log(-jnp.expm1(y_near)), jnp.log1p(-jnp.exp(y_far)))


def _is_traced(x) -> bool:
    return isinstance(x, jax.core.Tracer)


def _scalar(value, name: str) -> Float[Array, ""]:
    arr = jnp.asarray(value, dtype=float)
    if arr.shape != ():
        raise ValueError(f"`{name}` must be a scalar; got shape {arr.shape}.")
    return arr


def _positive(value, name: str, unit: str, hint: str = ""):
    arr = _scalar(value, name)
    shown = "a traced value" if _is_traced(arr) else f"{float(arr)!r}"
    return require(arr, ~(arr > 0), f"`{name}` must be > 0 {unit}; got {shown}.{hint}")


def _count_n0(n0, name: str = "n0"):
    arr = _scalar(n0, name)
    shown = "a traced value" if _is_traced(arr) else f"{float(arr)!r}"
    return require(
        arr,
        ~(arr >= 1),
        f"`{name}` (the number of amplitudes whose maximum is taken) must be >= 1; got {shown}.",
    )


def _probability_levels(q, name: str = "q"):
    arr = jnp.asarray(q, dtype=float)
    shown = "a traced value" if _is_traced(arr) else f"{np.asarray(arr)!r}"
    return require(arr, ~((arr > 0) & (arr < 1)), f"`{name}` must lie strictly between 0 and 1; got {shown}.")


def _gauss_legendre(f, a, b, num_panels: int):
    """Composite 8-point Gauss–Legendre quadrature of a vectorised `f` on [a, b]."""
    edges = jnp.linspace(a, b, num_panels + 1)
    mid = 0.5 * (edges[1:] + edges[:-1])
    half = 0.5 * (edges[1:] - edges[:-1])
    x = mid[:, None] + half[:, None] * _GL_NODES[None, :]
    return jnp.sum(f(x) * (half[:, None] * _GL_WEIGHTS[None, :]))


_NEG_PDF_HINT = (
    " Small negative values from interpolation or smoothing can be clipped with jnp.clip(pdf, 0); large "
    "ones mean the PDF is wrong."
)


def _first_bad_message(values, bad, name: str, requirement: str, hint: str = "") -> str:
    if _is_traced(bad) or _is_traced(values):
        return f"`{name}` {requirement}.{hint}"
    bad_np = np.atleast_1d(np.asarray(bad))
    if not bad_np.any():
        return ""
    idx = int(np.argmax(bad_np))
    value = np.atleast_1d(np.asarray(values))[idx]
    count = int(bad_np.sum())
    return f"`{name}` {requirement}; {name}[{idx}] = {float(value)!r} ({count} offending value(s)).{hint}"


def _check_table(grid, values, name: str, allow_neg_inf: bool = False):
    grid = jnp.asarray(grid, dtype=float)
    values = jnp.asarray(values, dtype=float)
    if grid.ndim != 1 or values.shape != grid.shape:
        raise ValueError(
            f"`grid` and `{name}` must be 1-D arrays of the same length; got shapes {grid.shape} and "
            f"{values.shape}. Tabulate the PDF at the grid points."
        )
    if grid.shape[0] < 3:
        raise ValueError(
            f"A tabulated distribution needs at least 3 grid points; got {grid.shape[0]}. Tabulate the PDF "
            "on a grid of a few hundred points that reaches far into the tail."
        )
    bad = ~jnp.isfinite(grid)
    grid = require(grid, bad, _first_bad_message(grid, bad, "grid", "must be finite"))
    bad = jnp.isnan(values) | (values == jnp.inf) if allow_neg_inf else ~jnp.isfinite(values)
    req = "must not be NaN or +inf" if allow_neg_inf else "must be finite (no NaN or inf)"
    values = require(values, bad, _first_bad_message(values, bad, name, req))
    d = jnp.diff(grid)
    grid = require(
        grid,
        d <= 0,
        _first_bad_message(
            d,
            d <= 0,
            "diff(grid)",
            "must be > 0",
            " The grid must be strictly increasing: sort it and remove duplicate points.",
        ),
    )
    grid = require(
        grid,
        grid[0] < 0,
        f"Amplitudes are non-negative, but grid[0] = "
        f"{'a traced value' if _is_traced(grid) else repr(float(grid[0]))} < 0. "
        "Start the grid at 0 or above.",
    )
    return grid, values


def error_line(error: Exception) -> str:
    """The user-facing line of an error (the `EquinoxRuntimeError:` text under jit, else the first line)."""
    text = str(error)
    marker = "EquinoxRuntimeError: "
    if marker in text:
        text = text.split(marker, 1)[1]
    return text.strip().splitlines()[0] if text.strip() else type(error).__name__
