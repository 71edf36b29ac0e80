"""The ship with the calibrated values from decay, captive and free-running roll fits."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..ship._ship import Ship
from ._captive import CaptiveFit
from ._decay import DecayFit, _decay_ship
from ._least_squares import _set_params
from ._roll_pdf import RollFit
from ._time_domain import TIME_DOMAIN_PARAMETERS, ship_with
from ._time_domain_results import TimeDomainFit


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
    noise intensities; negative fitted damping is clipped to 0 as for `decay`)."""
    out = ship
    notes = []
    if decay is not None:
        b = jnp.asarray(np.maximum(decay.b, 0.0))
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
        values = [roll.estimates[n].value for n in names]
        values = [max(v, 0.0) if n in ("b1", "b2", "b3") else v for n, v in zip(names, values)]
        out = ship_with(out, names, jnp.asarray(values, dtype=float))
        notes.append(f"{', '.join(names)} from free-running roll records ({roll.method})")
    elif roll is not None:
        out = _set_params(out, list(roll.estimates), [e.value for e in roll.estimates.values()])
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
