"""Ship parameters: the roll model's coefficients, their validation and the default ship.

A `Ship` holds everything the 1-DOF roll equation needs, at full scale and in SI units:

    φ̈ + b1 φ̇ + b2 φ̇|φ̇| + b3 φ̇³ + a1 φ + a3 φ³ + … + a9 φ⁹ + P(t) φ = 0,
    P(t) = r · (ω0² / GM0) · ΔGM(ζ_mid(t)),   ΔGM(ζ) = Σ_k C_k ζᵏ,   r = σ_obs/σ_thr.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._compiled import as_float
from .._display import module_repr

if TYPE_CHECKING:
    from ._restoring_surface import RestoringSurface
    from ._wave_moment import WaveMoment

DEFAULT_SHIP_NOTE = (
    "C11 (representative): the particulars are the paper's Table 1 (Katsumura et al., arXiv 2407.02728); "
    "restoring, damping and ΔGM coefficients are representative values chosen to show the paper's regime, "
    "not the real C11 data, which are unpublished."
)


class Ship(eqx.Module):
    """Roll-model parameters of one ship at full scale (SI units, radians)."""

    def __repr__(self) -> str:
        return module_repr(self)  # the particulars and coefficients as numbers, not `f64[]`

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
    wave_moment: WaveMoment | None
    restoring_surface: RestoringSurface | None
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
        wave_moment: WaveMoment | None = None,
        restoring_surface: RestoringSurface | None = None,
        name: str = "unnamed ship",
        provenance: str = "",
    ):
        """Keyword arguments, SI units (docs/ship_file.md): the particulars `lpp`, `breadth`, `depth`, `draught`
        [m], `displacement` [kg], `block_coefficient` [-], `gm0` [m], `roll_period` Tφ [s]; `restoring` (a3, a5,
        a7, a9), `damping` (b1 [1/s], b2 [1/rad], b3 [s/rad²]), `delta_gm` (C0 … C6 [m^(1−k)]), `gm_correction`
        σ_obs/σ_thr; `wave_moment`: optional direct wave roll moment of the hull
        ([`WaveMoment`][jaxroll.ship.WaveMoment], `jaxroll.ship.wave_moment`), which every run at a heading with
        |cos χ| < 1 adds to the roll equation (docs/wave_moment.md; None: the paper's parametric-only model);
        `restoring_surface`: optional GZ(φ, ζ_mid) surface of the hull in waves
        ([`RestoringSurface`][jaxroll.ship.RestoringSurface]), used in the roll equation in place of
        GZ_calm(φ) + ΔGM(ζ)φ (docs/hydrostatics.md; None: the polynomial model)."""
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
        for key, value, size in (
            ("restoring", restoring, 4),
            ("damping", damping, 3),
            ("delta_gm", delta_gm, 7),
        ):
            arr = as_float(value)
            if arr.shape != (size,):
                raise ValueError(f"Ship `{key}` must have shape ({size},); got {arr.shape}.")
            setattr(self, key, arr)
        self.wave_moment = wave_moment
        self.restoring_surface = restoring_surface
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
            (
                "Lpp, B, D, d",
                ", ".join(f"{f(getattr(self, k)):g}" for k in ("lpp", "breadth", "depth", "draught")),
                "m",
            ),
            ("displacement mass", f(self.displacement), "kg"),
            ("block coefficient Cb", f(self.block_coefficient), "-"),
            ("GM0", f(self.gm0), "m"),
            ("natural roll period Tφ", f(self.roll_period), "s"),
            ("damping b1, b2, b3", ", ".join(f"{float(b):.5g}" for b in self.damping), "1/s, 1/rad, s/rad²"),
            (
                "restoring a3, a5, a7, a9 (a1 = ω0²)",
                ", ".join(f"{float(a):.5g}" for a in self.restoring),
                "1/s² · rad^(1−n)",
            ),
            ("ΔGM(ζ) C0 … C6", ", ".join(f"{float(c):.4g}" for c in self.delta_gm), "m · m^−k"),
            ("GM correction σobs/σthr", f(self.gm_correction), "-"),
        ]
        return html_table(
            f"Ship: {self.name}", rows, header=("", "value", "unit"), note=self.provenance or None
        )

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

            warnings.warn(
                f"ship {ship.name!r}: roll period {period:g} s is unusual (ships: ~5-60 s).", stacklevel=2
            )
    if not problems:
        problems = _impossible(d)
    if not problems:
        import warnings

        from ._restoring import vanishing_angle

        vanishing = float(vanishing_angle(ship))
        if vanishing >= math.pi - 1e-9:
            warnings.warn(
                f"ship {ship.name!r}: GZ never returns to zero for 0 < φ < 180°, so there is no angle of vanishing "
                "stability and capsize is never detected; check the GZ coefficients (the highest-order one is "
                "usually negative) unless a linear-restoring model is intended.",
                stacklevel=2,
            )
        for message in implausible(d, vanishing):
            warnings.warn(f"ship {ship.name!r}: {message}", stacklevel=2)
    if problems:
        raise ValueError(f"Invalid ship {ship.name!r}: " + "; ".join(problems) + ".")


# ----------------------------------------------------------------------------------------------------------------
# Plausibility: values no ship can have (refused) and values no ship is likely to have (warned), each message
# naming the value and the unit slip that would explain it (docs/ship_file.md, "Plausibility checks").
# ----------------------------------------------------------------------------------------------------------------

#: The longest ship ever built (Seawise Giant / Knock Nevis) was 458 m between perpendiculars; nothing afloat is
#: a kilometre long, so a longer Lpp is a unit slip.
MAX_LPP_M = 1000.0


def _slip(value: float, plausible: tuple[float, float]) -> str:
    """The unit slip that would explain a length `value` [m] outside any ship: the first of mm, cm, km that brings
    it into `plausible` [m], e.g. 'typed in mm it is 1.93 m'."""
    for factor, unit in ((1e-3, "mm"), (1e-2, "cm"), (1e3, "km")):
        if plausible[0] <= value * factor <= plausible[1]:
            return f"a unit slip? typed in {unit}, it would be {value * factor:.4g} m"
    return "check its unit (metres)"


def max_possible_gm(breadth: float, draught: float, block_coefficient: float) -> float:
    """The largest GM0 [m] a hull of breadth B, draught d and block coefficient C_b can have: KB ≤ d, BM = I_T/∇ ≤
    (L B³/12)/(C_b L B d) = B²/(12 C_b d) (no waterplane is wider than a rectangle) and KG ≥ 0, so GM0 ≤ d +
    B²/(12 C_b d)."""
    return draught + breadth**2 / (12 * block_coefficient * draught)


def _impossible(d: dict[str, dict[str, float]]) -> list[str]:
    """Values no ship can have: refused (a unit slip, never a design)."""
    p = d["particulars"]
    out = []
    if p["lpp_m"] > MAX_LPP_M:
        out.append(
            f"lpp_m = {p['lpp_m']:g} m is beyond any ship (the longest ever built was 458 m; nothing afloat is "
            f"{MAX_LPP_M:g} m long): {_slip(p['lpp_m'], (24.0, 500.0))}"
        )
    bound = max_possible_gm(p["breadth_m"], p["draught_m"], p["block_coefficient"])
    if p["gm0_m"] > bound:
        out.append(
            f"gm0_m = {p['gm0_m']:g} m is more than any hull of these particulars can have: GM0 <= KB + BM <= d + "
            f"B²/(12 C_b d) = {bound:.3g} m (B {p['breadth_m']:g} m, d {p['draught_m']:g} m, C_b "
            f"{p['block_coefficient']:g}, KG >= 0): {_slip(p['gm0_m'], (0.05, 0.3 * p['breadth_m']))}"
        )
    return out


#: Bands outside which a ship file's value is warned about (docs/ship_file.md): wide enough for every ship type
#: (barges, pontoons, destroyers, yachts), so that only a slip or a wrong coefficient falls outside.
PLAUSIBLE = {
    "lpp_m": (10.0, MAX_LPP_M),  # below 10 m: a model-scale file
    "length_breadth": (2.0, 15.0),  # ships 3-10 (barges 3-5, destroyers 9-11)
    "displacement_ratio": (0.8, 1.25),  # Δ / (ρ C_b L B d), ρ = 1025 kg/m³ (fresh water 0.976)
    "gyradius_breadth": (0.2, 0.8),  # k_φ/B = Tφ √(g GM0) / (2π B); IMO weather criterion C ≈ 0.3-0.45
    "vanishing_angle_deg": 20.0,  # the IS Code asks for GZ >= 0.2 m at 30° and its maximum beyond 25°
    "damping_ratio": 0.5,  # equivalent linear damping ratio at 20° roll; ships 0.02-0.2
    "gm_ratio": (0.2, 5.0),  # σ_obs/σ_thr corrects ΔGM by tens of per cent (the paper: 0.6-1.1)
}


def implausible(d: dict[str, dict[str, float]], vanishing_angle: float) -> list[str]:
    """Warnings for values no ship is likely to have (`PLAUSIBLE`), each naming the value, the band and the unit
    slip or mistake that would explain it. `d`: the ship's parameter tables (`_parameter_tables`);
    `vanishing_angle` [rad]."""
    from ._hydrostatics import GRAVITY, SEAWATER_DENSITY

    p, a, b, c = d["particulars"], d["restoring"], d["damping"], d["delta_gm"]
    lpp, beam, draught, gm0, period = (
        p["lpp_m"],
        p["breadth_m"],
        p["draught_m"],
        p["gm0_m"],
        p["roll_period_s"],
    )
    out = []
    if lpp < PLAUSIBLE["lpp_m"][0]:
        out.append(
            f"lpp_m = {lpp:g} m is a model, not a ship: ship files are full scale (tank records are scaled by "
            "Froude's law on loading, docs/records.md); check the scale and the unit (in cm or mm the value would "
            "be 100 or 1000 times larger)"
        )
    lo, hi = PLAUSIBLE["length_breadth"]
    if not lo <= lpp / beam <= hi:
        out.append(
            f"L/B = {lpp:g} m / {beam:g} m = {lpp / beam:.3g} is outside {lo:g}-{hi:g} (ships 3-10): check the units "
            "of lpp_m and breadth_m (both in metres)"
        )
    expected = SEAWATER_DENSITY * p["block_coefficient"] * lpp * beam * draught
    ratio = p["displacement_kg"] / expected
    lo, hi = PLAUSIBLE["displacement_ratio"]
    if not lo <= ratio <= hi:
        out.append(
            f"displacement_kg = {p['displacement_kg']:.4g} kg is {ratio:.3g} × ρ C_b L B d = {expected:.4g} kg "
            f"(ρ = {SEAWATER_DENSITY:g} kg/m³; expected {lo:g}-{hi:g}): one of lpp_m, breadth_m, draught_m, "
            "block_coefficient, displacement_kg is in another unit (displacement in tonnes is 1000 × too small, a "
            "length in mm 1000 × too large) or belongs to another loading condition"
        )
    gyradius = period * math.sqrt(GRAVITY * gm0) / (2 * math.pi)
    lo, hi = PLAUSIBLE["gyradius_breadth"]
    if not lo <= gyradius / beam <= hi:
        expected_t = 2 * math.pi * 0.4 * beam / math.sqrt(GRAVITY * gm0)
        out.append(
            f"roll_period_s = {period:g} s and gm0_m = {gm0:g} m imply a roll radius of gyration k = Tφ √(g GM0)/(2π) "
            f"= {gyradius:.3g} m = {gyradius / beam:.3g} B (ships {lo:g}-{hi:g} B; with k = 0.4 B this GM gives Tφ ≈ "
            f"{expected_t:.3g} s): one of them is wrong (GM0 in mm or cm? a roll period in other units?)"
        )
    if vanishing_angle < math.radians(PLAUSIBLE["vanishing_angle_deg"]):
        a1 = (2 * math.pi / period) ** 2
        out.append(
            f"the angle of vanishing stability is {math.degrees(vanishing_angle):.3g}° (a3 = {a['a3']:g}, a5 = "
            f"{a['a5']:g}, a7 = {a['a7']:g}, a9 = {a['a9']:g}; a1 = ω0² = {a1:.4g}), below "
            f"{PLAUSIBLE['vanishing_angle_deg']:g}°: every trial beyond it counts as a capsize. The restoring "
            "coefficients are per unit roll inertia, a_n = ω0² g_n / GM0 [1/(s² rad^(n-1))] with φ in radians: a "
            f"GZ coefficient g_n in metres typed as a_n is {gm0 / a1:.3g} × too large"
        )
    omega0 = 2 * math.pi / period
    amp = math.radians(20.0)
    zeta = b["b1"] / (2 * omega0) + 4 * b["b2"] * amp / (3 * math.pi) + 3 * b["b3"] * amp**2 * omega0 / 8
    if zeta > PLAUSIBLE["damping_ratio"]:
        inertia = p["displacement_kg"] * GRAVITY * gm0 / omega0**2
        out.append(
            f"the roll damping ratio at 20° is {zeta:.4g} (b1 = {b['b1']:g} 1/s, b2 = {b['b2']:g} 1/rad, b3 = "
            f"{b['b3']:g} s/rad²; ships 0.02-0.2, above {PLAUSIBLE['damping_ratio']:g} the roll hardly oscillates and "
            "no parametric roll can build up). b1..b3 are per unit roll inertia: b1 = 2ζω0 = "
            f"{2 * 0.05 * omega0:.3g} 1/s for ζ = 0.05; a damping moment coefficient [N·m·s] must be divided by the "
            f"roll inertia ≈ Δ g GM0/ω0² = {inertia:.3g} kg·m²"
        )
    zmax = min(draught, p["depth_m"] - draught) / 2  # ζ_mid of a steep sea; hull fits hold ±6 m for C11
    z = np.linspace(-zmax, zmax, 201)
    coeffs = [c[f"c{k}"] for k in range(7)]
    dgm = np.polynomial.polynomial.polyval(z, coeffs)
    bound = max_possible_gm(beam, draught, p["block_coefficient"])
    worst = int(np.argmax(np.abs(dgm)))
    if abs(dgm[worst]) > bound:
        k = int(np.argmax([abs(ck) * zmax**i for i, ck in enumerate(coeffs)]))
        out.append(
            f"ΔGM(ζ_mid) reaches {dgm[worst]:.4g} m at ζ_mid = {z[worst]:.3g} m (within ±min(draught, freeboard)/2 = "
            f"±{zmax:.3g} m), beyond the largest GM this hull can have ({bound:.3g} m): check c{k} = {coeffs[k]:g} — "
            "c_k are in m^(1-k) with ζ_mid in metres (ΔGM in mm would make every c_k 1000 × too large)"
        )
    r = d["correction"]["gm_ratio"]
    lo, hi = PLAUSIBLE["gm_ratio"]
    if r > 0 and not lo <= r <= hi:
        out.append(
            f"gm_ratio = {r:.4g} is outside {lo:g}-{hi:g}: σ_obs/σ_thr corrects ΔGM by tens of per cent (the paper: "
            "0.6-1.1); a ratio this far from 1 comes from records with a unit slip (a wave or ΔGM column in mm "
            "labelled m) or from a ΔGM polynomial in other units"
        )
    return out


def restoring_fields_from_gz(gz_coefficients, gm0: float, roll_period: float) -> np.ndarray:
    """Convert a GZ polynomial [m] GZ = GM0 φ + g3 φ³ + … + g9 φ⁹ to (a3, a5, a7, a9) = ω0² g_n / GM0."""
    omega0 = 2 * np.pi / roll_period
    g = np.asarray(gz_coefficients, dtype=float)
    return omega0**2 * g / gm0
