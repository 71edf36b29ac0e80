"""Moment method, continuation: follow one closure's branch of stationary moments along a path of sea states or
ships (H1/3, r, …), and find where it folds.

The closed moment equations of order N have a stable non-trivial fixed point only over part of the map (order 6
on the default ship: H1/3 ≳ 6.3 m at r = 1). `moment_pdf_first_stable` then falls back to order 4 and the
result jumps. `moment_branch` instead keeps the closure fixed, steps along the path with Newton from the
neighbouring point (secant predictor), checks every point (converged, stable: every Jacobian eigenvalue in the
left half plane, physical, amplitude fit), and where the branch ends bisects the last step to locate the fold.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from .._config import require_float64
from ._moment_equations import roll_sde
from ._moment_solver import RESULTS, continue_moments
from ._moments import _amplitude_law, _shaping_filter, roll_moments

_FIT_OK = 1e-6


@dataclasses.dataclass(frozen=True)
class MomentBranch:
    """One closure order's branch of stationary moments along a path (NumPy arrays, radians).

    - `values`: the path parameter at each point (e.g. H1/3 [m] or r [-]), as given.
    - `closure_order`: the cumulant-neglect order of every point (never switched along the branch).
    - `on_branch`: the point lies on the followed branch and its fixed point is stable and physical.
    - `mean_amplitude` [rad], `e_phi2` [rad²], `sf_20deg` (P(A > 20°), envelope law): NaN off the branch.
    - `max_real_eigenvalue` [1/s]: of the moment equations' Jacobian (< 0: stable; NaN where Newton failed).
    - `message`: why a point is off the branch ("" on it).
    - `start`: index of the point the branch was started from (a full relaxation solve).
    - `folds`: `(value, lower, upper)` per end of the branch inside the path: the fold's location (bisected)
      and its bracket; empty when the branch spans the whole path.
    """

    values: np.ndarray
    closure_order: int
    on_branch: np.ndarray
    mean_amplitude: np.ndarray
    e_phi2: np.ndarray
    sf_20deg: np.ndarray
    max_real_eigenvalue: np.ndarray
    message: tuple[str, ...]
    start: int
    folds: tuple[tuple[float, float, float], ...]

    def table(self) -> list[dict]:
        """One row per point for JSON: value, closure, on_branch, stable flag, mean [deg], P(A > 20°), message."""
        return [
            {
                "value": float(v),
                "closure_order": self.closure_order,
                "on_branch": bool(ok),
                "stable": bool(np.isfinite(lam) and lam < 0),
                "mean_amplitude_deg": float(np.rad2deg(m)),
                "E_phi2_rad2": float(e2),
                "P_exceed_20deg": float(p),
                "max_real_eigenvalue_per_s": float(lam),
                "message": msg,
            }
            for v, ok, m, e2, p, lam, msg in zip(
                self.values,
                self.on_branch,
                self.mean_amplitude,
                self.e_phi2,
                self.sf_20deg,
                self.max_real_eigenvalue,
                self.message,
            )
        ]


@dataclasses.dataclass
class _Point:
    ok: bool
    values: object  # unknown moments (for the next Newton start)
    tables: object
    mean: float
    e_phi2: float
    sf20: float
    max_re: float
    message: str


def _evaluate(mom, ship, envelope: str, tables) -> _Point:
    amp, family, res, fit_result = _amplitude_law(mom, ship.omega0, envelope)
    solved = bool(mom.result == RESULTS.successful)
    fit_ok = bool(jnp.isfinite(res)) and float(res) < _FIT_OK
    ok = solved and fit_ok
    if ok:
        message = ""
    elif not solved:
        message = RESULTS[mom.result]
    else:
        message = RESULTS[RESULTS.fit_failed]
    e2 = float(mom.moment((2, 0) + (0,) * (tables.dim - 2)))
    return _Point(
        ok,
        mom.values,
        tables,
        float(family.mean()) if ok else math.nan,
        e2 if ok else math.nan,
        float(family.sf(math.radians(20.0))) if ok else math.nan,
        float(mom.max_real_eigenvalue),
        message,
    )


def moment_branch(
    path: Callable,
    values: Sequence[float] | np.ndarray,
    *,
    closure_order: int = 6,
    filter_order: int = 4,
    damping: str = "cubic",
    envelope: str = "phase_averaged",
    start: int | None = None,
    fold_bisections: int = 6,
) -> MomentBranch:
    """Follow the moment method's branch of closure order `closure_order` along `values` and locate its folds.

    **Arguments:**

    - `path`: `value -> (ship, wave)`, e.g. `lambda hs: (ship, EffectiveWave(ITTC(hs, 10.0), ship.lpp))` for
      H1/3 [m], or a ship with `gm_correction` = r for r.
    - `values`: the path parameter, a 1-D grid in the order to follow (monotone).
    - `closure_order`, `filter_order`, `damping`, `envelope`: as in `moment_pdf`; kept fixed along the branch.
    - `start`: index of the point to start from with the full solve (relaxation from a Gaussian start, order
      4 then the higher orders); default: the first point (in the order of `values`) where that succeeds.
    - `fold_bisections`: bisections of the last step before a fold (its location to 2^-n of a grid step).

    **Returns:** `MomentBranch`: per point whether it is on the branch (stable, physical, fitted), the mean
    amplitude, E[φ²], P(A > 20°), the largest real eigenvalue, and the folds found. The amplitude statistics
    are continuous along the branch; no other closure is ever substituted.
    """
    require_float64("jaxroll.theory.moment_branch")
    grid = np.asarray(values, dtype=float)
    if grid.ndim != 1 or grid.size < 1 or not np.all(np.isfinite(grid)):
        raise ValueError(f"`values` must be a non-empty 1-D grid of finite numbers; got {values!r}.")
    if not (isinstance(closure_order, int) and closure_order >= 4):
        raise ValueError(f"`closure_order` must be an integer >= 4; got {closure_order!r}.")
    n = grid.size

    def sde_at(v):
        ship, wave = path(float(v))
        sde = roll_sde(ship, _shaping_filter(ship, wave, None, filter_order), damping=damping)
        return ship, wave, sde

    def full(v) -> _Point:
        ship, wave, sde = sde_at(v)
        mom = roll_moments(
            ship, wave, filter_order=filter_order, closure_order=closure_order, damping=damping, throw=False
        )
        return _evaluate(mom, ship, envelope, mom.equations.tables)

    def newton(v, guess: _Point) -> _Point:
        ship, _, sde = sde_at(v)
        tau = 2 * jnp.pi / jax.lax.stop_gradient(ship.omega0)
        mom = continue_moments(sde, guess.values, closure_order=closure_order, time_scale=tau)
        if mom.equations.tables is not guess.tables:  # another term structure: restart rather than map
            return full(v)
        return _evaluate(mom, ship, envelope, mom.equations.tables)

    points: list[_Point | None] = [None] * n
    if start is None:
        for i in range(n):
            points[i] = full(grid[i])
            if points[i].ok:
                start = i
                break
        if start is None:
            raise ValueError(
                f"no point of the path has a stable closure-{closure_order} solution to start the branch from "
                f"({points[-1].message})."
            )
    else:
        if not 0 <= start < n:
            raise ValueError(f"`start` must be an index into `values` (0…{n - 1}); got {start}.")
        points[start] = full(grid[start])
        if not points[start].ok:
            raise ValueError(
                f"closure order {closure_order} has no stable solution at the start point {grid[start]:g} "
                f"({points[start].message})."
            )
    folds = []
    for step in (1, -1):
        last, before = start, None
        i = start + step
        while 0 <= i < n:
            guess = points[last]
            if before is not None:  # secant predictor
                w = (grid[i] - grid[last]) / (grid[last] - grid[before])
                guess = dataclasses.replace(
                    guess, values=guess.values + w * (guess.values - points[before].values)
                )
            p = newton(grid[i], guess)
            points[i] = p
            if not p.ok:
                folds.append(_bisect(newton, grid[last], grid[i], points[last], fold_bisections))
                for j in range(i + step, n if step > 0 else -1, step):
                    points[j] = dataclasses.replace(
                        p, ok=False, mean=math.nan, e_phi2=math.nan, sf20=math.nan, max_re=math.nan,
                        message=f"beyond the fold of the closure-{closure_order} branch",
                    )  # fmt: skip
                break
            before, last, i = last, i, i + step
    return MomentBranch(
        values=grid,
        closure_order=closure_order,
        on_branch=np.array([p.ok for p in points]),
        mean_amplitude=np.array([p.mean for p in points]),
        e_phi2=np.array([p.e_phi2 for p in points]),
        sf_20deg=np.array([p.sf20 for p in points]),
        max_real_eigenvalue=np.array([p.max_re for p in points]),
        message=tuple(p.message for p in points),
        start=int(start),
        folds=tuple(sorted(folds, key=lambda f: f[0])),
    )


def _bisect(newton, good: float, bad: float, point, n: int) -> tuple[float, float, float]:
    """Bisect [good, bad] for the end of the branch, Newton from the last good point each time."""
    for _ in range(n):
        mid = 0.5 * (good + bad)
        p = newton(mid, point)
        if p.ok:
            good, point = mid, p
        else:
            bad = mid
    return (0.5 * (good + bad), min(good, bad), max(good, bad))
