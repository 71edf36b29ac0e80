r"""Simplified Ikeda roll damping (Kawahara, Maekawa & Ikeda), with bilge keels → the ship file's b1, b2.

Source: Y. Kawahara, K. Maekawa, Y. Ikeda, "A simple prediction formula of roll damping of conventional cargo
ships on the basis of Ikeda's method and its limitation", J. Shipping and Ocean Engineering 2 (2012) 201–210
(STAB 2009; often cited as Kawahara, Maekawa & Ikeda 2011); the regression coefficients are those of the
authors' Fortran `Roll_Damping.for` (Osaka Prefecture University, 2009-07-08) as published in the Python port
of M. Alexandersson (martinlarsalbert/rolldecay-estimators, `simplified_ikeda.py`, cross-checked there against
P. Piehl's independent port). Own implementation; reference value reproduced to 1e-9 (tests/test_ikeda.py).

Components (non-dimensional B̂ = B44 / (ρ ∇ B²) · √(B/(2g)), at roll amplitude φa and frequency ω):
friction B̂_F (Kato), wave B̂_W, eddy B̂_E, bilge keel B̂_BK; zero speed (no lift or speed correction).

Validity (the regression's ranges): C_B 0.5–0.85, B/d 2.5–4.5, OG/d −1.5–0.2, C_m 0.9–0.99,
b_BK/B 0.01–0.06, l_BK/L 0.05–0.4, ω̂ = ω √(B/(2g)) ≤ 1.0. OG is the distance from the still-water level down
to the roll axis (≈ G): OG = d − KG, negative when G is above the waterline.

**jaxroll's damping.** The roll equation per unit roll inertia has b1 φ̇ + b2 φ̇|φ̇|. With (I + A) = ρ g ∇ GM / ω0²,
the equivalent linear coefficient at amplitude φa is b_eq = B44 ω0² / (ρ g ∇ GM) [1/s], and by equal energy
per cycle b_eq(φa) = b1 + (8/(3π)) ω0 φa b2. [`ikeda_damping`][] fits that straight line over a range of
amplitudes (least squares) and returns b1 [1/s], b2 [1/rad], b3 = 0 with the damping source as text.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._hydrostatics import GRAVITY

KINEMATIC_VISCOSITY = 1.14e-6
"""ν [m²/s] used by the authors' program (sea water, ~15 °C)."""

VALIDITY = {
    "CB": (0.5, 0.85),
    "B/d": (2.5, 4.5),
    "OG/d": (-1.5, 0.2),
    "CM": (0.9, 0.99),
    "bBK/B": (0.01, 0.06),
    "lBK/L": (0.05, 0.4),
    "omega_hat": (0.0, 1.0),
}
"""Ranges of the regression (Kawahara et al.); outside them the formula extrapolates."""


IKEDA_SOURCE = (
    "simplified Ikeda method (Kawahara, Maekawa & Ikeda 2009/2012; coefficients of the authors' program), "
    "zero speed"
)
"""The damping source recorded in ship files whose b1, b2 come from [`ikeda_damping`][]."""


class IkedaRangeError(ValueError):
    """The simplified Ikeda estimate is not usable (negative damping): the hull is outside the regression's range."""


def _negative_damping_message(comps, b_eq, amplitudes, values: dict, out_of_range: list) -> str:
    i = int(np.argmin(b_eq))
    c = comps[i]
    parts = [
        f"{k} = {values[k]:.3f} (range {VALIDITY[k][0]:g}–{VALIDITY[k][1]:g})"
        for k in out_of_range
        if k in values
    ]
    where = (
        "outside its validity range: " + ", ".join(parts)
        if parts
        else "inside the ranges it checks, yet the regression gives a negative sum"
    )
    return (
        f"the simplified Ikeda roll damping is {where}; it extrapolates to a NEGATIVE damping (equivalent linear "
        f"b_eq = {b_eq[i]:.4g} 1/s at {math.degrees(amplitudes[i]):.0f}° roll: friction {c.friction:.3g}, wave "
        f"{c.wave:.3g}, eddy {c.eddy:.3g}, bilge keel {c.bilge_keel:.3g}, non-dimensional), which would feed energy "
        "into the roll. Give the roll damping of this hull yourself: CLI --damping B1 B2 B3 (b1 [1/s], b2 [1/rad], "
        "b3 [s/rad²], e.g. from a roll-decay test: `jaxroll calibrate`), Python damping=(b1, b2, b3)."
    )


@dataclass
class IkedaDamping:
    """Non-dimensional roll damping B̂ = B44/(ρ∇B²)·√(B/2g) [-] and its components."""

    total: float
    friction: float
    wave: float
    eddy: float
    bilge_keel: float
    out_of_range: list


def _poly(x, *c):
    """c[0] x^n + … + c[n] (Horner)."""
    out = 0.0
    for ci in c:
        out = out * x + ci
    return out


def simplified_ikeda(
    *,
    lpp: float,
    breadth: float,
    draught: float,
    block_coefficient: float,
    midship_coefficient: float,
    og: float,
    roll_amplitude: float,
    omega: float,
    bilge_keel_length: float = 0.0,
    bilge_keel_breadth: float = 0.0,
    gravity: float = GRAVITY,
) -> IkedaDamping:
    """Simplified Ikeda roll damping at zero speed.

    **Arguments:** `lpp`, `breadth`, `draught` [m]; `block_coefficient`, `midship_coefficient` [-]; `og` [m]
    (still-water level down to the roll axis, = d − KG); `roll_amplitude` φa [rad]; `omega` ω [rad/s];
    `bilge_keel_length` l_BK and `bilge_keel_breadth` (height) b_BK [m] (0: no bilge keels); `gravity` g
    [m/s²] (the authors' program uses 9.81).

    **Returns:** `IkedaDamping` (non-dimensional), with the names of the inputs outside the regression ranges.
    """
    L, B, d, cb, cm = lpp, breadth, draught, block_coefficient, midship_coefficient
    phi_deg = math.degrees(roll_amplitude)
    phi = roll_amplitude
    bd, ogd = B / d, og / d
    w_hat = omega * math.sqrt(B / (2 * gravity))
    period = 2 * math.pi / omega
    lbkl, bbkb = bilge_keel_length / L, bilge_keel_breadth / B
    checks = {"CB": cb, "B/d": bd, "OG/d": ogd, "CM": cm, "omega_hat": w_hat}
    if bilge_keel_length > 0:
        checks |= {"bBK/B": bbkb, "lBK/L": lbkl}
    out = [k for k, v in checks.items() if not VALIDITY[k][0] - 1e-9 <= v <= VALIDITY[k][1] + 1e-9]
    vol = L * B * d * cb

    # --- friction (Kato), B_F = (4/3π) ρ S_F r_f³ φa ω C_f
    rf = d * ((0.887 + 0.145 * cb) * (1.7 + cb * bd) - 2.0 * ogd) / math.pi
    sf = L * (1.75 * d + cb * B)
    cf = 1.328 * (3.22 * rf**2 * phi**2 / (period * KINEMATIC_VISCOSITY)) ** -0.5
    bf = 4.0 / (3.0 * math.pi) * sf * rf**3 * phi * omega * cf  # / ρ
    bf_hat = bf / (vol * B**2) * math.sqrt(B / (2 * gravity))

    # --- wave
    x1, x2, x3, x4, x5 = bd, cb, cm, 1 - ogd, w_hat
    a111 = _poly(x1, -0.002222, 0.040871, -0.286866, 0.599424)
    a112 = _poly(x1, 0.010185, -0.161176, 0.904989, -1.641389)
    a113 = _poly(x1, -0.015422, 0.220371, -1.084987, 1.834167)
    a121 = _poly(x1, -0.0628667, 0.4989259, 0.52735, -10.7918672, 16.616327)
    a122 = _poly(x1, 0.1140667, -0.8108963, -2.2186833, 25.1269741, -37.7729778)
    a123 = _poly(x1, -0.0589333, 0.2639704, 3.1949667, -21.8126569, 31.4113508)
    a124 = _poly(x1, 0.0107667, 0.0018704, -1.2494083, 6.9427931, -10.2018992)
    a131 = _poly(x1, 0.192207, -2.787462, 12.507855, -14.764856)
    a132 = _poly(x1, -0.350563, 5.222348, -23.974852, 29.007851)
    a133 = _poly(x1, 0.237096, -3.535062, 16.368376, -20.539908)
    a134 = _poly(x1, -0.067119, 0.966362, -4.407535, 5.894703)
    a11 = _poly(x2, a111, a112, a113)
    a12 = _poly(x2, a121, a122, a123, a124)
    a13 = _poly(x2, a131, a132, a133, a134)
    aa11 = _poly(x2, _poly(x1, 17.945, -166.294, 489.799, -493.142), _poly(x1, -25.507, 236.275, -698.683, 701.494),
                 _poly(x1, 9.077, -84.332, 249.983, -250.787))  # fmt: skip
    aa12 = _poly(x2, _poly(x1, -16.872, 156.399, -460.689, 463.848), _poly(x1, 24.015, -222.507, 658.027, -660.665),
                 _poly(x1, -8.56, 79.549, -235.827, 236.579))  # fmt: skip
    aa1 = (aa11 * x3 + aa12) * (1 - x4) + 1.0
    a1 = (a11 * x4**2 + a12 * x4 + a13) * aa1
    a2 = _poly(x4, -1.402, 7.189, -10.993, 9.45)
    a31 = _poly(x2, -7686.0287, 30131.5678, -49048.9664, 42480.7709, -20665.147, 5355.2035, -577.8827)
    a32 = _poly(x2, 61639.9103, -241201.0598, 392579.5937, -340629.4699, 166348.6917, -43358.7938, 4714.7918)
    a33 = _poly(
        x2, -130677.4903, 507996.2604, -826728.7127, 722677.104, -358360.7392, 95501.4948, -10682.8619
    )
    a34 = _poly(x2, -110034.6584, 446051.22, -724186.4643, 599411.9264, -264294.7189, 58039.7328, -4774.6414)
    a35 = _poly(
        x2, 709672.0656, -2803850.2395, 4553780.5017, -3888378.9905, 1839829.259, -457313.6939, 46600.823
    )
    a36 = _poly(
        x2, -822735.9289, 3238899.7308, -5256636.5472, 4500543.147, -2143487.3508, 538548.1194, -55751.1528
    )
    a37 = _poly(
        x2, 299122.8727, -1175773.1606, 1907356.1357, -1634256.8172, 780020.9393, -196679.7143, 20467.0904
    )
    aa311 = _poly(x2, -17.102, 41.495, -33.234, 8.8007) * x4 + _poly(x2, 36.566, -89.203, 71.8, -18.108)
    aa31 = _poly(x1, -0.3767, 3.39, -10.356, 11.588) * aa311
    aa32 = _poly(x1, -0.0727, 0.7, -1.2818)
    xx4 = x4 - aa32
    aa3 = aa31 * (
        _poly(
            xx4,
            -1.05584,
            12.688,
            -63.70534,
            172.84571,
            -274.05701,
            257.68705,
            -141.40915,
            44.13177,
            -7.1654,
            0.0,
        )
        + _poly(x1, -0.0495, 0.4518, -0.61655)
    )
    a3 = _poly(x4, a31, a32, a33, a34, a35, a36, a37) + aa3
    bw_hat = a1 / x5 * math.exp(-a2 * (math.log(x5) - a3) ** 2 / 1.44)

    # --- eddy
    fe1 = (-0.0182 * cb + 0.0155) * (bd - 1.8) ** 3
    fe2 = _poly(cb, -79.414, 215.695, -215.883, 93.894, -14.848)
    ae = fe1 + fe2
    be1 = (
        (3.98 * cb - 5.1525)
        * (-0.2 * bd + 1.6)
        * ogd
        * ((0.9717 * cb**2 - 1.55 * cb + 0.723) * ogd + 0.04567 * cb + 0.9408)
    )
    be2 = (0.25 * ogd + 0.95) * ogd - 219.2 * cb**3 + 443.7 * cb**2 - 283.3 * cb + 59.6
    be3 = -15 * cb * bd + 46.5 * cb + 11.2 * bd - 28.6
    cr = ae * math.exp(be1 + be2 * cm**be3)
    be_hat = 4.0 * w_hat * phi / (3.0 * math.pi * cb * bd**3) * cr

    # --- bilge keels
    if lbkl > 0:
        fbk1 = (-0.3651 * cb + 0.3907) * (bd - 2.83) ** 2 - 2.21 * cb + 2.632
        fbk2 = 0.00255 * phi_deg**2 + 0.122 * phi_deg + 0.4794
        fbk3 = (-0.8913 * bbkb**2 - 0.0733 * bbkb) * lbkl**2 + (
            5.2857 * bbkb**2 - 0.01185 * bbkb + 0.00189
        ) * lbkl
        abk = fbk1 * fbk2 * fbk3
        bbk1 = (5.0 * bbkb + 0.3 * bd - 0.2 * lbkl + 0.00125 * phi_deg**2 - 0.0425 * phi_deg - 1.86) * ogd
        bbk2 = -15.0 * bbkb + 1.2 * cb - 0.1 * bd - 0.0657 * ogd**2 + 0.0586 * ogd + 1.6164
        bbk3 = 2.5 * ogd + 15.75
        bbk_hat = abk * math.exp(bbk1 + bbk2 * cm**bbk3) * w_hat
    else:
        bbk_hat = 0.0
    total = bf_hat + bw_hat + be_hat + bbk_hat
    return IkedaDamping(total, bf_hat, bw_hat, be_hat, bbk_hat, out)


def dimensional_damping(
    b_hat: float, *, volume: float, breadth: float, water_density: float = 1025.0
) -> float:
    """B44 [N m s] = B̂ ρ ∇ B² √(2g/B)."""
    return b_hat * water_density * volume * breadth**2 * math.sqrt(2 * GRAVITY / breadth)


def equivalent_linear_damping(
    b_hat: float, *, volume: float, breadth: float, gm: float, omega0: float
) -> float:
    """b_eq = B44 ω0²/(ρ g ∇ GM) [1/s] (per unit roll inertia, I + A = ρ g ∇ GM / ω0²); ρ cancels."""
    return (
        b_hat * volume * breadth**2 * math.sqrt(2 * GRAVITY / breadth) * omega0**2 / (GRAVITY * volume * gm)
    )


def ikeda_damping(
    *,
    lpp: float,
    breadth: float,
    draught: float,
    block_coefficient: float,
    midship_coefficient: float,
    kg: float,
    gm: float,
    roll_period: float,
    bilge_keel_length: float = 0.0,
    bilge_keel_breadth: float = 0.0,
    amplitudes: np.ndarray | None = None,
) -> dict:
    """(b1 [1/s], b2 [1/rad], b3 = 0) for jaxroll's roll equation from the simplified Ikeda method at ω0.

    b_eq(φa) = B44(φa) ω0²/(ρ g ∇ GM) is computed at `amplitudes` [rad] (default 2°–30°, the range parametric roll
    lives in) and fitted by b1 + (8/(3π)) ω0 φa b2 (least squares, b2 ≥ 0). Also returns the fit's RMS
    residual, the equivalent damping ratio ζ_eq = b_eq/(2ω0) at each amplitude, and the out-of-range inputs.

    **Raises:** `ValueError` for non-positive or non-finite inputs; `IkedaRangeError` (a `ValueError`) when the
    regression gives a damping <= 0 at any amplitude (a hull outside its range, e.g. a box barge, C_B = C_m = 1):
    the message names the parameters outside their ranges and points to the damping option.
    """
    inputs = dict(lpp=lpp, breadth=breadth, draught=draught, block_coefficient=block_coefficient,
                  midship_coefficient=midship_coefficient, gm=gm, roll_period=roll_period)  # fmt: skip
    for key, v in inputs.items():
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"ikeda_damping: `{key}` must be a finite number > 0 (SI units); got {v}.")
    for key, v in (("bilge_keel_length", bilge_keel_length), ("bilge_keel_breadth", bilge_keel_breadth)):
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"ikeda_damping: `{key}` must be a finite length >= 0 [m]; got {v}.")
    omega0 = 2 * math.pi / roll_period
    if amplitudes is None:
        amplitudes = np.radians(np.linspace(2.0, 30.0, 15))
    amplitudes = np.asarray(amplitudes, float)
    vol = lpp * breadth * draught * block_coefficient
    comps = [
        simplified_ikeda(
            lpp=lpp, breadth=breadth, draught=draught, block_coefficient=block_coefficient,
            midship_coefficient=midship_coefficient, og=draught - kg, roll_amplitude=a, omega=omega0,
            bilge_keel_length=bilge_keel_length, bilge_keel_breadth=bilge_keel_breadth,
        )
        for a in amplitudes
    ]  # fmt: skip
    b_eq = np.array(
        [equivalent_linear_damping(c.total, volume=vol, breadth=breadth, gm=gm, omega0=omega0) for c in comps]
    )
    out_of_range = sorted({k for c in comps for k in c.out_of_range})
    if not np.all(b_eq > 0):
        raise IkedaRangeError(_negative_damping_message(comps, b_eq, amplitudes, dict(
            CB=block_coefficient, CM=midship_coefficient, **{"B/d": breadth / draught, "OG/d": (draught - kg) / draught,
            "omega_hat": omega0 * math.sqrt(breadth / (2 * GRAVITY))}), out_of_range))  # fmt: skip
    x = 8 / (3 * math.pi) * omega0 * amplitudes
    design = np.stack([np.ones_like(x), x], axis=1)
    (b1, b2), *_ = np.linalg.lstsq(design, b_eq, rcond=None)
    if b2 < 0:
        b1, b2 = float(np.mean(b_eq)), 0.0
    rms = float(np.sqrt(np.mean((design @ np.array([b1, b2]) - b_eq) ** 2)))
    source = IKEDA_SOURCE + (
        f", bilge keels {bilge_keel_length:g} m x {bilge_keel_breadth:g} m"
        if bilge_keel_length > 0 and bilge_keel_breadth > 0
        else ", no bilge keels"
    )
    return dict(
        source=source,
        b1=float(b1),
        b2=float(b2),
        b3=0.0,
        fit_rms=rms,
        amplitudes_deg=np.degrees(amplitudes).tolist(),
        b_eq=b_eq.tolist(),
        zeta_eq=(b_eq / (2 * omega0)).tolist(),
        b_hat=[c.total for c in comps],
        components_at_max=vars(comps[-1]),
        out_of_range=out_of_range,
    )
