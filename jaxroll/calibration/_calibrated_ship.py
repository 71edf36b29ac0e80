"""The ship with the calibrated values from decay, captive and free-running roll fits."""

from __future__ import annotations

import math
import warnings

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..ship._ship import Ship
from ._captive import CaptiveFit
from ._decay import _decay_ship
from ._decay_results import DecayFit
from ._least_squares import _set_params
from ._roll_pdf import RollFit
from ._time_domain import TIME_DOMAIN_PARAMETERS, ship_with
from ._time_domain_results import TimeDomainFit

_DAMPING = ("b1", "b2", "b3")


def nonnegative_damping(names, values, covariance) -> tuple[np.ndarray, dict[str, dict[str, float]]]:
    """Fitted parameters with negative damping coefficients held at 0 and the others moved to where the fit puts
    them under that constraint, to first order: b_F ← b_F − Σ_FA Σ_AA⁻¹ b_A, b_A ← 0 for the active set A of the
    damping coefficients below zero (repeated while another one goes negative). This minimises (θ − θ̂)ᵀ Σ⁻¹ (θ −
    θ̂) subject to θ_A = 0 — the least-squares fit with those coefficients fixed at 0, exactly so for a fit that is
    linear in its parameters (the extinction curve), to first order otherwise. Negative damping feeds energy into
    the roll and a ship file refuses it; clipping alone would keep the other coefficients at values fitted to
    compensate for it.

    **Arguments:** `names` of the parameters, their fitted `values` and `covariance` (same order).

    **Returns:** `(values, changed)`: the constrained values and, per parameter that changed, `{"fitted",
    "written", "std_error"}`.
    """
    names = list(names)
    theta = np.asarray(values, dtype=float).copy()
    cov = np.asarray(covariance, dtype=float)
    fitted = theta.copy()
    active: list[int] = []
    for _ in range(len(names)):
        new = [i for i, n in enumerate(names) if n in _DAMPING and theta[i] < 0 and i not in active]
        if not new:
            break
        active += new
        free = [i for i in range(len(names)) if i not in active]
        a = np.asarray(active)
        theta = fitted.copy()
        if free and np.all(np.isfinite(cov)):
            f = np.asarray(free)
            theta[f] = (
                fitted[f] - cov[np.ix_(f, a)] @ np.linalg.lstsq(cov[np.ix_(a, a)], fitted[a], rcond=None)[0]
            )
        theta[a] = 0.0
    changed = {
        n: {
            "fitted": float(fitted[i]),
            "written": float(theta[i]),
            "std_error": float(math.sqrt(max(cov[i, i], 0))),
        }
        for i, n in enumerate(names)
        if theta[i] != fitted[i]
    }
    return theta, changed


def _warn_constrained(what: str, changed: dict[str, dict[str, float]], notes: list[str]) -> None:
    """Warn that negative damping was held at 0 (both values), and say so in the provenance `notes`."""
    negative = {n: c for n, c in changed.items() if c["written"] == 0.0 and c["fitted"] < 0}
    if not negative:
        return
    notes.append(", ".join(f"{n} held at 0 (fitted {c['fitted']:.4g})" for n, c in negative.items()))
    parts = []
    for n, c in negative.items():
        z = -c["fitted"] / c["std_error"] if c["std_error"] > 0 else math.inf
        parts.append(f"{n} = {c['fitted']:.4g} ± {c['std_error']:.2g} ({z:.1f} standard errors below 0)")
    moved = [f"{n} {c['fitted']:.5g} → {c['written']:.5g}" for n, c in changed.items() if n not in negative]
    worst = max(-c["fitted"] / c["std_error"] if c["std_error"] > 0 else math.inf for c in negative.values())
    why = (
        "within 2 standard errors of 0, so consistent with no such damping"
        if worst <= 2
        else "significantly below 0: the records' damping is not of the form b1 φ̇ + b2 φ̇|φ̇| + b3 φ̇³ with b >= 0 "
        "(check the roll column's unit, the release of the record and the ship's roll period)"
    )
    warnings.warn(
        f"{what}: {', '.join(parts)}: negative damping feeds energy into the roll and a ship file refuses it, so "
        f"the calibrated ship gets {', '.join(f'{n} = 0' for n in negative)}"
        + (
            f" and {', '.join(moved)} (the least-squares fit under that constraint, from the fit's covariance)"
            if moved
            else ""
        )
        + f". This warning appears because the unconstrained fit is {why}; calibration.json keeps both values "
        "(`estimates` the fitted ones, `written` the ship's).",
        stacklevel=3,
    )


def calibrated_ship(
    ship: Ship,
    *,
    decay: DecayFit | None = None,
    captive: CaptiveFit | None = None,
    roll: RollFit | TimeDomainFit | None = None,
    estimator: str = "std_ratio",
    name: str | None = None,
) -> Ship:
    """`ship` with the calibrated values: damping (and Tφ, for an ODE fit with a fitted period) from `decay`,
    the GM correction from `captive` (`estimator` "std_ratio" or "ls"), then the parameters of `roll` (a
    roll-PDF fit or a time-domain fit; of the latter only the roll model's parameters, not the Kalman filter's
    noise intensities). A negative fitted damping coefficient is held at 0 and the other parameters moved to the
    constrained least-squares fit (`nonnegative_damping`), with a `UserWarning` that gives both values."""
    out = ship
    notes = []
    if decay is not None:
        values, changed = nonnegative_damping(_DAMPING, decay.b, decay.damping_covariance)
        _warn_constrained(f"decay fit ({decay.method})", changed, notes)
        b = jnp.asarray(values)
        if decay.method == "ode" and decay.config.get("fit_period"):
            out = _decay_ship(out, b, decay.roll_period.value / float(out.roll_period))
        else:
            out = eqx.tree_at(lambda s: s.damping, out, b)
        notes.append(f"damping from free decay ({decay.method})")
    if captive is not None:
        out = eqx.tree_at(lambda s: s.gm_correction, out, jnp.asarray(captive.correction(estimator).value))
        notes.append(f"GM correction from captive tests ({estimator})")
    if isinstance(roll, TimeDomainFit):
        names = [n for n in roll.names if n in TIME_DOMAIN_PARAMETERS]
        fitted, changed = nonnegative_damping(
            roll.names, [roll.estimates[n].value for n in roll.names], roll.covariance
        )
        _warn_constrained(f"time-domain fit ({roll.method})", changed, notes)
        values = [float(fitted[roll.names.index(n)]) for n in names]
        out = ship_with(out, names, jnp.asarray(values, dtype=float))
        notes.append(f"{', '.join(names)} from free-running roll records ({roll.method})")
    elif roll is not None:
        names = list(roll.estimates)
        values, changed = nonnegative_damping(
            names, [e.value for e in roll.estimates.values()], roll.covariance
        )
        _warn_constrained("roll-PDF fit", changed, notes)
        out = _set_params(out, names, [float(v) for v in values])
        notes.append(f"{', '.join(roll.estimates)} from free-running roll PDFs")
    provenance = f"{ship.provenance} | calibrated by jaxroll: {'; '.join(notes)}".strip(" |")
    return Ship(
        lpp=out.lpp,
        breadth=out.breadth,
        depth=out.depth,
        draught=out.draught,
        displacement=out.displacement,
        block_coefficient=out.block_coefficient,
        gm0=out.gm0,
        roll_period=out.roll_period,
        restoring=out.restoring,
        damping=out.damping,
        delta_gm=out.delta_gm,
        gm_correction=out.gm_correction,
        name=name or f"{ship.name} (calibrated)",
        provenance=provenance,
    )
