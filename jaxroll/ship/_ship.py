"""Ship parameters: the roll model's coefficients, their validation and the default ship.

A `Ship` holds everything the 1-DOF roll equation needs, at full scale and in SI units:

    φ̈ + b1 φ̇ + b2 φ̇|φ̇| + b3 φ̇³ + a1 φ + a3 φ³ + … + a9 φ⁹ + P(t) φ = 0,
    P(t) = r · (ω0² / GM0) · ΔGM(ζ_mid(t)),   ΔGM(ζ) = Σ_k C_k ζᵏ,   r = σ_obs/σ_thr.
"""

from __future__ import annotations

import math
from typing import Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._compiled import as_float

DEFAULT_SHIP_NOTE = (
    "C11 (representative): the particulars are the paper's Table 1 (Katsumura et al., arXiv 2407.02728); "
    "restoring, damping and ΔGM coefficients are representative values chosen to show the paper's regime, "
    "not the real C11 data, which are unpublished."
)


class Ship(eqx.Module):
    """Roll-model parameters of one ship at full scale (SI units, radians)."""

    lpp: Float[Array, ""]
    breadth: Float[Array, ""]
    depth: Float[Array, ""]
    draught: Float[Array, ""]
    displacement: Float[Array, ""]
    block_coefficient: Float[Array, ""]
    gm0: Float[Array, ""]
    roll_period: Float[Array, ""]
    restoring: Float[Array, " 4"]
    damping: Float[Array, " 3"]
    delta_gm: Float[Array, " 7"]
    gm_correction: Float[Array, ""]
    name: str = eqx.field(static=True, default="unnamed ship")
    provenance: str = eqx.field(static=True, default="")

    def __init__(
        self,
        *,
        lpp,
        breadth,
        depth,
        draught,
        displacement,
        block_coefficient,
        gm0,
        roll_period,
        restoring,
        damping,
        delta_gm,
        gm_correction=1.0,
        name: str = "unnamed ship",
        provenance: str = "",
    ):
        scalars = dict(
            lpp=lpp,
            breadth=breadth,
            depth=depth,
            draught=draught,
            displacement=displacement,
            block_coefficient=block_coefficient,
            gm0=gm0,
            roll_period=roll_period,
            gm_correction=gm_correction,
        )
        for key, value in scalars.items():
            arr = as_float(value)
            if arr.shape != ():
                raise ValueError(f"Ship `{key}` must be a scalar; got shape {arr.shape}.")
            setattr(self, key, arr)
        for key, value, size in (("restoring", restoring, 4), ("damping", damping, 3), ("delta_gm", delta_gm, 7)):
            arr = as_float(value)
            if arr.shape != (size,):
                raise ValueError(f"Ship `{key}` must have shape ({size},); got {arr.shape}.")
            setattr(self, key, arr)
        self.name = name
        self.provenance = provenance

    def _repr_html_(self) -> str | None:
        """Jupyter's view: the particulars, the roll model's coefficients and the provenance; None (the plain
        repr) for a batch of ships."""
        from .._display import html_table

        if any(np.ndim(getattr(self, k)) for k in ("lpp", "gm0", "roll_period", "gm_correction")):
            return None
        f = lambda x: float(x)  # noqa: E731
        rows = [
            ("Lpp, B, D, d", ", ".join(f"{f(getattr(self, k)):g}" for k in ("lpp", "breadth", "depth", "draught")), "m"),
            ("displacement mass", f(self.displacement), "kg"),
            ("block coefficient Cb", f(self.block_coefficient), "-"),
            ("GM0", f(self.gm0), "m"),
            ("natural roll period Tφ", f(self.roll_period), "s"),
            ("damping b1, b2, b3", ", ".join(f"{float(b):.5g}" for b in self.damping), "1/s, 1/rad, s/rad²"),
            ("restoring a3, a5, a7, a9 (a1 = ω0²)", ", ".join(f"{float(a):.5g}" for a in self.restoring),
             "1/s² · rad^(1−n)"),
            ("ΔGM(ζ) C0 … C6", ", ".join(f"{float(c):.4g}" for c in self.delta_gm), "m · m^−k"),
            ("GM correction σobs/σthr", f(self.gm_correction), "-"),
        ]
        return html_table(f"Ship: {self.name}", rows, header=("", "value", "unit"), note=self.provenance or None)

    @property
    def omega0(self) -> Float[Array, ""]:
        """Natural roll frequency ω0 = 2π/Tφ [rad/s]."""
        return 2 * jnp.pi / self.roll_period

    @property
    def restoring_coefficients(self) -> Float[Array, " 5"]:
        """(a1, a3, a5, a7, a9) of the restoring polynomial per unit inertia [1/s² · rad^(1−n)], a1 = ω0²."""
        return jnp.concatenate([self.omega0[None] ** 2, self.restoring])


def _default_ship() -> Ship:
    omega0 = 2 * math.pi / 24.4
    return Ship(
        lpp=262.0,
        breadth=40.0,
        depth=24.45,
        draught=11.5,
        displacement=6.7247e7,
        block_coefficient=0.56,
        gm0=1.9299,
        roll_period=24.4,
        restoring=[-0.25 * omega0**2, -0.25 * omega0**2, 0.0, 0.0],
        damping=[2 * 0.015 * omega0, 0.5, 0.0],
        delta_gm=[0.0, 0.55, 0.05, -0.004, 0.0, 0.0, 0.0],
        gm_correction=1.0,
        name="C11 (representative)",
        provenance=DEFAULT_SHIP_NOTE,
    )


def c11_representative() -> Ship:
    """The default ship "C11 (representative)".

    Table-1 particulars of the paper's C11 post-Panamax container ship (Lpp 262 m, GM0 1.9299 m, Tφ 24.4 s) with
    *representative* restoring, damping and ΔGM coefficients (docs/conventions.md): they reproduce the paper's
    regime but are not the real C11 data, which are unpublished.
    """
    return _default_ship()


# ----------------------------------------------------------------------------------------------------------------
# The parameters by name and unit
# ----------------------------------------------------------------------------------------------------------------

# (section, key, Ship attribute or (attribute, index), unit) — the one description of the ship's parameters, by the
# names and units of the ship file (docs/ship_file.md, written and read by jaxroll.io._ship_file).
_FIELDS: tuple[tuple[str, str, Any, str], ...] = (
    ("particulars", "lpp_m", "lpp", "m"),
    ("particulars", "breadth_m", "breadth", "m"),
    ("particulars", "depth_m", "depth", "m"),
    ("particulars", "draught_m", "draught", "m"),
    ("particulars", "displacement_kg", "displacement", "kg"),
    ("particulars", "block_coefficient", "block_coefficient", "-"),
    ("particulars", "gm0_m", "gm0", "m"),
    ("particulars", "roll_period_s", "roll_period", "s"),
    ("restoring", "a3", ("restoring", 0), "1/(s² rad²)"),
    ("restoring", "a5", ("restoring", 1), "1/(s² rad⁴)"),
    ("restoring", "a7", ("restoring", 2), "1/(s² rad⁶)"),
    ("restoring", "a9", ("restoring", 3), "1/(s² rad⁸)"),
    ("damping", "b1", ("damping", 0), "1/s"),
    ("damping", "b2", ("damping", 1), "1/rad"),
    ("damping", "b3", ("damping", 2), "s/rad²"),
    *(("delta_gm", f"c{k}", ("delta_gm", k), f"m^{1 - k}") for k in range(7)),
    ("correction", "gm_ratio", "gm_correction", "-"),
)
_POSITIVE = {"lpp_m", "breadth_m", "depth_m", "draught_m", "displacement_kg", "gm0_m", "roll_period_s"}


def _get(ship: Ship, attr) -> float:
    if isinstance(attr, tuple):
        return float(np.asarray(getattr(ship, attr[0]))[attr[1]])  # indexed on the host: no eager XLA program
    return float(getattr(ship, attr))


def _parameter_tables(ship: Ship) -> dict[str, dict[str, float]]:
    """The ship's parameters as `{section: {key: value}}` in the order of `_FIELDS` (SI units)."""
    out: dict[str, dict[str, float]] = {}
    for section, key, attr, _ in _FIELDS:
        out.setdefault(section, {})[key] = _get(ship, attr)
    return out


def validate_ship(ship: Ship) -> None:
    """Raise `ValueError` if the ship's values are physically invalid (concrete values only)."""
    d = _parameter_tables(ship)
    problems = []
    for section, key, _, unit in _FIELDS:
        v = d[section][key]
        if not math.isfinite(v):
            problems.append(f"[{section}] {key} is {v}; it must be a finite number ({unit})")
        elif key in _POSITIVE and v <= 0:
            problems.append(f"[{section}] {key} = {v} must be > 0 ({unit})")
    p = d["particulars"]
    if math.isfinite(p["draught_m"]) and math.isfinite(p["depth_m"]) and p["draught_m"] >= p["depth_m"] > 0:
        problems.append(f"draught_m = {p['draught_m']} must be below depth_m = {p['depth_m']}")
    if not 0 < p["block_coefficient"] <= 1:
        problems.append(f"block_coefficient = {p['block_coefficient']} must be in (0, 1]")
    b = d["damping"]
    if min(b["b1"], b["b2"], b["b3"]) < 0:
        problems.append(
            f"damping coefficients must be >= 0 (got b1={b['b1']}, b2={b['b2']}, b3={b['b3']}); "
            "negative damping feeds energy into the roll"
        )
    if d["correction"]["gm_ratio"] < 0:
        problems.append(f"[correction] gm_ratio = {d['correction']['gm_ratio']} must be >= 0")
    period = _get(ship, "roll_period")
    if math.isfinite(period) and period > 0:
        if period > 100.0:
            problems.append(
                f"roll period {period:g} s is beyond any ship (ship roll periods are ~5-60 s); check the units"
            )
        elif not 3.0 <= period <= 60.0:
            import warnings

            warnings.warn(f"ship {ship.name!r}: roll period {period:g} s is unusual (ships: ~5-60 s).", stacklevel=2)
    if not problems:
        from ._restoring import vanishing_angle

        if float(vanishing_angle(ship)) >= math.pi - 1e-9:
            import warnings

            warnings.warn(
                f"ship {ship.name!r}: GZ never returns to zero for 0 < φ < 180°, so there is no angle of vanishing "
                "stability and capsize is never detected; check the GZ coefficients (the highest-order one is "
                "usually negative) unless a linear-restoring model is intended.",
                stacklevel=2,
            )
    if problems:
        raise ValueError(f"Invalid ship {ship.name!r}: " + "; ".join(problems) + ".")


def restoring_fields_from_gz(gz_coefficients, gm0: float, roll_period: float) -> np.ndarray:
    """Convert a GZ polynomial [m] GZ = GM0 φ + g3 φ³ + … + g9 φ⁹ to (a3, a5, a7, a9) = ω0² g_n / GM0."""
    omega0 = 2 * np.pi / roll_period
    g = np.asarray(gz_coefficients, dtype=float)
    return omega0**2 * g / gm0
