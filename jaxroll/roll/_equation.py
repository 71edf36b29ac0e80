"""The roll equation for one realization, written once (vmapped by `jaxroll.monte_carlo_*`).

    φ̈ + b1 φ̇ + b2 φ̇|φ̇| + b3 φ̇³ + a1φ + a3φ³ + … + a9φ⁹ + P(t) φ = 0,   P = r (ω0²/GM0) ΔGM(−ζ_G(t)).

Time stepping: classical RK4 at step h = dt. The excitation sources advance m steps at a time (`substeps`): the
shaping filter is stepped exactly every m·dt and ζ_G at the RK4 stage times in between is its Gaussian bridge
(conditional mean, error variance ≤ 1e-6 σ_G²); a record or an FFT superposition gives ζ_G at the step ends with
dζ_G/dt, and at the midpoint by cubic Hermite interpolation (error O(h⁴)). Noise for block j of realization i
comes from `fold_in(fold_in(key, i), j)`, so a realization is the same whatever the chunking, the device count or
the number of steps simulated after it. One realization is written once (`simulate`) and vmapped by the Monte
Carlo (docs/numerics.md, "Monte Carlo kernel").
"""

from __future__ import annotations

import functools
import math
import warnings

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
from jaxtyping import Array, Float, PRNGKeyArray

from .._compiled import filter_jit, is_concrete
from .._config import require_float64
from ..sea._filters import (
    BAND_TOLERANCE,
    FilterFit,
    band_error,
    band_warning,
    check_filter_fit,
    fit_filter,
    fit_filter_in_band,
)
from ..sea._grim import SPECTRUM_GRID, EffectiveWave, spectrum_on_grid
from ..sea._spectra import AbstractWaveSpectrum, heading_cosine
from ..sea._spreading import Spreading
from ..ship._restoring import angle_of_maximum_gz, backbone_frequency, parametric_excitation, vanishing_angle
from ..ship._restoring_surface import (
    in_surface_range,
    refuse_restoring_surface,
    restoring_in_waves,
    wave_restoring_terms,
)
from ..ship._ship import Ship
from ..ship._validity import warn_outside_validity
from ..ship._wave_moment import roll_inertia
from ._excitation import (
    BLOCK,
    AbstractExcitation,
    FilterExcitation,
    SuperpositionExcitation,
    WaveMomentExcitation,
    joint_init,
)
from ._yaw import Yaw, check_yaw_speed


def roll_acceleration(ship: Ship, phi, dphi, p, m=0.0) -> Float[Array, "..."]:
    """φ̈ [rad/s²] at roll φ [rad], rate φ̇ [rad/s], parametric term P [1/s²] and roll moment M_w [rad/s²].

    For a ship with a GZ surface (`ship.restoring_surface`), `p` may be the pair (P, d) that
    `wave_restoring_terms` (`jaxroll.ship._restoring_surface`) gives: the surface's restoring in that wave; a lone P
    is the polynomial model's."""
    b1, b2, b3 = ship.damping[0], ship.damping[1], ship.damping[2]
    damping = dphi * (b1 + b2 * jnp.abs(dphi) + b3 * dphi * dphi)
    return m - damping - restoring_in_waves(ship, phi, p)


def roll_vector_field(t, y, args):
    """Vector field f(t, y, args) of y = (φ, φ̇), args = (ship, P(t) callable) — for diffrax and checks."""
    ship, p_of_t = args
    return jnp.stack([y[1], roll_acceleration(ship, y[0], y[1], p_of_t(t))])


def runtime_one(x):
    """Ones shaped like `x` that XLA cannot know at compile time: x == x, for an `x` known to be finite."""
    return (x == x).astype(x.dtype)


def computed_once(x, one):
    """`x` divided by `one` (from `runtime_one`): the same value, exactly (x / 1 = x), which XLA computes once and
    keeps. XLA counts a division as expensive, so it stores the result for every fused kernel that uses it instead
    of recomputing the chain of operations behind `x` inside each of them (in a loop body, several times over)."""
    return x / one


def rk4_step(ship: Ship, y, p, m, h, one=None):
    """One RK4 step of y = (φ, φ̇) over h [s]; `p`, `m` = (start, middle, end) values of P [1/s²] and M_w
    [rad/s²]. **Returns:** the new (φ, φ̇) as a tuple (or a stacked array when `y` is one).

    `one`: None, or ones shaped like φ that XLA cannot know at compile time (`simulate` passes `runtime_one(φ)`):
    the stage accelerations are then `computed_once`, each kept instead of recomputed inside every fused kernel
    that uses it (φ₁'s and φ̇₁'s). With `simulate`'s P values kept the same way, the Monte Carlo's time loop ran
    0.49 → 0.40 s per 10⁴ × 3600 s on a 2-core CPU, same bits (benchmarks/README.md)."""
    phi, dphi = y[0], y[1]
    h2, h6 = h / 2, h / 6
    keep = (lambda x: x) if one is None else (lambda x: computed_once(x, one))
    k1p, k1v = dphi, keep(roll_acceleration(ship, phi, dphi, p[0], m[0]))
    k2p, k2v = dphi + h2 * k1v, keep(roll_acceleration(ship, phi + h2 * k1p, dphi + h2 * k1v, p[1], m[1]))
    k3p, k3v = dphi + h2 * k2v, keep(roll_acceleration(ship, phi + h2 * k2p, dphi + h2 * k2v, p[1], m[1]))
    k4p, k4v = dphi + h * k3v, roll_acceleration(ship, phi + h * k3p, dphi + h * k3v, p[2], m[2])
    phi1 = phi + h6 * (k1p + 2 * k2p + 2 * k3p + k4p)
    dphi1 = dphi + h6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    return jnp.stack([phi1, dphi1]) if isinstance(y, jax.Array) else (phi1, dphi1)


# ----------------------------------------------------------------------------------------------------------------
# One realization
# ----------------------------------------------------------------------------------------------------------------


def _bandwidth(s, fraction: float) -> float:
    """The frequency of `SPECTRUM_GRID` [rad/s] below which `fraction` of the variance of spectrum `s` lies."""
    w = SPECTRUM_GRID
    s = np.asarray(s)
    cum = np.concatenate([[0.0], np.cumsum((s[1:] + s[:-1]) / 2 * np.diff(w))])
    if not cum[-1] > 0:
        return 0.0  # no excitation (e.g. ζ_G in beam seas)
    return float(np.interp(fraction * cum[-1], cum, w))


def excitation_bandwidth(
    wave: EffectiveWave, fraction: float = 0.999, moment: WaveMomentExcitation | None = None
) -> float:
    """Encounter frequency [rad/s] below which `fraction` of the effective-wave variance lies, and (with a direct
    wave `moment`) of the moment's variance too: the larger of the two."""
    w_max = _bandwidth(spectrum_on_grid(wave), fraction)
    if moment is not None:
        w_max = max(w_max, _bandwidth(moment.spectrum(SPECTRUM_GRID), fraction))
    return w_max


#: Relative margin of `parametric_band` on each side: the roll's own bandwidth and the slow modulation of its
#: frequency by the mean GM in waves.
BAND_MARGIN = 0.1


def parametric_band(ship: Ship) -> tuple[float, float]:
    """The encounter frequencies [rad/s] at which the sea excites this ship's roll parametrically, from small roll
    to the heel of maximum GZ: ((1 − m)·2ω(A_GZmax), (1 + m)·2ω0), ω(A) the backbone frequency
    (`jaxroll.ship.backbone_frequency`), m = `BAND_MARGIN`. A large roll of a softening GZ is slower than ω0, so
    it feels the sea below 2ω0: this is where a shaping filter must follow S_G for the tail to be right
    (`fit_filter_in_band`). Host side, concrete ship. The default ship: 0.416–0.567 rad/s (2ω0 = 0.515)."""
    top = angle_of_maximum_gz(ship)
    w_top, w0 = float(backbone_frequency(ship, top)), float(ship.omega0)
    return (1 - BAND_MARGIN) * 2 * min(w_top, w0), (1 + BAND_MARGIN) * 2 * w0


def _warn_if_off_the_band(fit: FilterFit, ship: Ship, wave: EffectiveWave) -> None:
    """A warning when the filter misses S_G by more than `BAND_TOLERANCE` on `parametric_band`: under "auto"
    (`fit.band_error` set) no order followed it (`band_warning`); a given order is told what "auto" would do."""
    if fit.band_error is not None:
        if float(fit.band_error) > BAND_TOLERANCE:
            warnings.warn(
                band_warning(fit.filter.order, float(fit.band_error), np.asarray(fit.band)), stacklevel=4
            )
        return
    band = parametric_band(ship)
    err = band_error(fit.filter, wave, band)
    if err > BAND_TOLERANCE:
        warnings.warn(
            f"the order-{fit.filter.order} shaping filter's spectrum is {100 * err:.0f} % off the effective wave's "
            f"on {band[0]:.3g}–{band[1]:.3g} rad/s, where the roll is excited parametrically (tolerance "
            f"{100 * BAND_TOLERANCE:g} %): the roll's tail probabilities are biased there (docs/validation.md). "
            "filter_order='auto' (--filter-order auto, the default) raises the order where it must.",
            stacklevel=4,
        )


def check_time_step(
    dt: float, ship: Ship, wave: EffectiveWave, moment: WaveMomentExcitation | None = None
) -> None:
    """Validate the time step [s] against the roll period and the excitation bandwidth.

    Error when dt > Tφ/10 or ω_max·dt > 1 (RK4 loses accuracy and may go unstable); a warning when
    dt > Tφ/40 or ω_max·dt > 0.6 (halving dt may then change the mean amplitude by more than ~1 %). ω_max is the
    encounter frequency below which 99.9 % of the effective-wave variance lies, and of the direct wave moment's
    with a `moment` (`excitation_bandwidth`).
    """
    if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
        raise ValueError(f"`dt` must be a finite number > 0 [s]; got {dt!r}.")
    t_roll = float(ship.roll_period)
    w_max = max(excitation_bandwidth(wave, moment=moment), 1e-12)  # > 0 for the messages (beam seas: none)
    if dt > t_roll / 10 or w_max * dt > 1.0:
        raise ValueError(
            f"dt = {dt} s is too large: it must be <= Tφ/10 = {t_roll / 10:.3g} s and <= 1/ω_max = "
            f"{1 / w_max:.3g} s (ω_max = {w_max:.3g} rad/s holds 99.9 % of the excitation's variance). "
            f"Use dt <= {min(t_roll / 40, 0.6 / w_max):.3g} s for ~1 % accuracy."
        )
    if dt > t_roll / 40 or w_max * dt > 0.6:
        warnings.warn(
            f"dt = {dt} s may bias the amplitudes by more than ~1 %. This warning appears because dt > Tφ/40 = "
            f"{t_roll / 40:.3g} s or ω_max·dt > 0.6 (ω_max = {w_max:.3g} rad/s); use dt <= "
            f"{min(t_roll / 40, 0.6 / w_max):.3g} s.",
            stacklevel=3,
        )


def _moment_excitation(
    ship: Ship, sea, speed, heading, dt, spreading=None, yaw=None
) -> WaveMomentExcitation | None:
    """The direct wave moment the ship's table (`ship.wave_moment`, per the ship's own roll inertia) gives at this
    heading; None without a table, and in long-crested head and following seas (|cos χ| = 1) without `yaw`, where
    the moment of a hull symmetric port and starboard vanishes and the paper's model runs unchanged (a short-crested
    sea has oblique directions at every heading)."""
    if ship.wave_moment is None or (
        spreading is None and yaw is None and abs(heading_cosine(heading)) == 1.0
    ):
        return None
    table = ship.wave_moment.per_inertia(roll_inertia(ship))
    return WaveMomentExcitation(sea, table, dt, speed=speed, heading=heading, spreading=spreading, yaw=yaw)


def _check_yawed_time_step(dt, ship, wave, moment) -> None:
    """`check_time_step` at every heading the yaw's moment nodes reach (the moment's bandwidth grows off head seas)."""
    for chi in moment.yaw.nodes:
        folded = abs(math.remainder(chi, 2 * math.pi))  # the same |F| at −χ and 2π − χ
        at = WaveMomentExcitation(moment.sea, _node_table(moment), dt, heading=min(folded, math.pi))
        check_time_step(dt, ship, wave, at)


def _node_table(moment: WaveMomentExcitation):
    """The moment's nodes as a `WaveMoment` over their folded headings (for the bandwidth check)."""
    from ..ship._wave_moment import WaveMoment

    chis = np.array([min(abs(math.remainder(c, 2 * math.pi)), math.pi) for c in moment.yaw.nodes])
    order = np.argsort(chis, kind="stable")
    chis, idx = np.unique(chis[order], return_index=True)
    values = moment.yaw.transfers[order[idx]]
    return WaveMoment(moment.omega, jnp.asarray(chis), values, jnp.asarray(1.0))


class RollProblem(eqx.Module):
    """Everything one realization needs: ship, excitation source(s), initial condition — and, when built from a
    sea state, the effective wave and the filter fit the theories must share with the Monte Carlo.

    Build it from a sea state with `RollProblem.from_sea(ship, sea, ...)`, or from parts with the constructor.
    """

    ship: Ship
    excitation: AbstractExcitation
    phi0: Float[Array, ""]
    dphi0: Float[Array, ""]
    capsize_angle: Float[Array, ""]
    moment_excitation: AbstractExcitation | None
    wave: EffectiveWave | None
    filter_fit: FilterFit | None

    def __init__(
        self,
        ship: Ship,
        excitation: AbstractExcitation,
        phi0=math.radians(5.0),
        dphi0=0.0,
        *,
        moment_excitation: AbstractExcitation | None = None,
        wave: EffectiveWave | None = None,
        filter_fit: FilterFit | None = None,
    ):
        """**Arguments:**

        - `ship`: the roll model's parameters.
        - `excitation`: source of Grim's effective wave ζ_G [m] (`FilterExcitation`, `SuperpositionExcitation`,
          `SampledExcitation`).
        - `phi0`: initial roll [rad] (5°, the paper's); `dphi0`: initial roll rate [rad/s].
        - `moment_excitation`: optional source of an external roll moment per unit inertia M_w(t) [rad/s²]
          (zero in long-crested head or following seas; used for beam-sea studies and exact test cases).
        - `wave`, `filter_fit`: the effective wave and the shaping-filter fit behind `excitation`, when known
          (`from_sea` sets them), so the theories use exactly what the Monte Carlo simulates.
        """
        require_float64("jaxroll.RollProblem")
        self.ship = ship
        self.excitation = excitation
        self.phi0 = jnp.asarray(phi0, dtype=float)
        self.dphi0 = jnp.asarray(dphi0, dtype=float)
        self.capsize_angle = vanishing_angle(ship)
        if moment_excitation is not None and moment_excitation.dt != excitation.dt:
            raise ValueError(
                f"`moment_excitation.dt` ({moment_excitation.dt}) must equal `excitation.dt` ({excitation.dt})."
            )
        if (
            isinstance(moment_excitation, WaveMomentExcitation)
            and isinstance(excitation, FilterExcitation | SuperpositionExcitation)
            and not getattr(excitation, "joint", False)
        ):
            raise ValueError(
                "a WaveMomentExcitation needs ζ_G from the same wave components, or the direct and parametric "
                "excitations are wrongly independent: use `SuperpositionExcitation(wave, dt, joint=True)`, or "
                "`RollProblem.from_sea` with a ship carrying the wave moment."
            )
        yaws = [getattr(s, "yaw", None) for s in (excitation, moment_excitation) if s is not None]
        if len({None if y is None else y.yaw for y in yaws}) > 1:
            raise ValueError(
                "`excitation` and `moment_excitation` must be built with the same `yaw` (the heading of one run), "
                "or both without: use `RollProblem.from_sea(..., yaw=)`."
            )
        if (
            moment_excitation is not None
            and isinstance(moment_excitation, FilterExcitation)
            and (moment_excitation.substeps != excitation.substeps)
        ):
            raise ValueError(
                f"`moment_excitation` steps its filter every {moment_excitation.substeps} time steps and "
                f"`excitation` every {excitation.substeps}: build both with the same `substeps`."
            )
        self.moment_excitation = moment_excitation
        self.wave = wave
        self.filter_fit = filter_fit

    @classmethod
    def from_sea(
        cls,
        ship: Ship,
        sea: AbstractWaveSpectrum,
        *,
        speed: float = 0.0,
        heading: str | float = "head",
        excitation: str = "auto",
        dt: float = 0.5,
        filter_order: int | str = "auto",
        phi0: float = math.radians(5.0),
        dphi0: float = 0.0,
        substeps: int | None = None,
        noise_rank: int | None = None,
        validate: bool = True,
        spreading: Spreading | None = None,
        yaw: Yaw | None = None,
    ) -> "RollProblem":
        """The roll problem of `ship` in the sea state `sea`: Grim's effective wave, its excitation, initial roll.

        **Arguments:**

        - `ship`: the roll model; `sea`: one-sided sea spectrum (`ITTC`, `JONSWAP`).
        - `speed` [m/s]; `heading`: "head" | "following" | χ [rad] in [0, π] (0 following, π/2 beam, π head;
          the mean direction of a short-crested sea). In long-crested beam seas the projected wave number is 0:
          ζ_G ≡ 0 and the roll only decays.
        - `spreading`: a `jaxroll.sea.Spreading` (cos-2s or cos^n) for a short-crested sea, or None (long-crested,
          the paper's; exactly today's numbers). Grim's effective wave (hence the filter fit and the theories'
          S_G) and a ship's direct wave moment are summed over the spreading's directions, each with its own
          encounter frequency (docs/spreading.md); a ship carrying a moment then has it at every heading.
        - `excitation`: "filter" (Method 2, the paper's for Monte Carlo: a shaping filter fitted once to S_G
          with extra weight at 2ω0, kept in `filter_fit` for the moment method), "superposition" (Method 1), or
          "auto" (default): "filter", but "superposition" when the ship carries a wave moment
          (`ship.wave_moment`) and the heading is oblique or beam (|cos χ| < 1) or the sea short-crested. Then the
          direct wave moment M_w(t) joins the roll equation, made with ζ_G of the same wave components
          (`SuperpositionExcitation(joint=True)`, `WaveMomentExcitation`); a shaping filter cannot make both
          (docs/wave_moment.md), so "filter" is refused for such a run.
        - `dt`: time step [s] (checked against the roll period and the excitation bandwidth).
        - `filter_order`: order of the shaping filter (Method 2), or `"auto"` (default): order 4 where it follows S_G
          within 5 % on `parametric_band(ship)`, the encounter frequencies the roll responds to, else 8 (`fit_filter_in_band`; the order and its band error in `filter_fit.summary()`). The
          paper's Method 2 is `filter_order=4`: 10–60 % low in P(roll > angle) in some seas (docs/numerics.md, "The
          filter's order").
        - `phi0` [rad], `dphi0` [rad/s]: initial condition (the paper's 5°, 0).
        - `substeps`: time steps per shaping-filter step (None: chosen from the bridge's interpolation error,
          `FilterExcitation`); give it when the construction is traced, to keep the nominal problem's random stream.
        - `noise_rank`: normals per shaping-filter step (None: the principal directions of the step's noise that
          keep every state variance within 1e-6, `choose_noise_rank`); give it with `substeps` when traced.
        - `yaw`: a [`Yaw`][jaxroll.Yaw], the heading an Ornstein–Uhlenbeck process about χ (zero speed only; the
          superposition, with the ship's wave moment at every heading, head seas included: docs/yaw.md); None (or
          σ_ψ = 0): none, the problem exactly as without the argument.
        - `validate`: check the inputs and gate the filter fit (default). `False` skips those concrete checks so
          that the construction can be traced (e.g. differentiated in the ship or sea parameters); validate the
          nominal problem first.

        **Raises:** `ValueError` for a bad method, time step, filter fit or initial roll (beyond the vanishing
        angle).
        """
        require_float64("jaxroll.RollProblem.from_sea")
        if excitation not in ("auto", "filter", "superposition"):
            raise ValueError(f"`excitation` must be 'auto', 'filter' or 'superposition'; got {excitation!r}.")
        wave = EffectiveWave(sea, ship.lpp, speed, heading, spreading=spreading, validate=validate)
        if yaw is not None and yaw.std == 0:
            yaw = None  # no yaw: today's problem, bit for bit
        if yaw is not None:
            check_yaw_speed(yaw, speed)
            if spreading is not None:
                raise ValueError(
                    "yaw in a short-crested sea is not modelled (the yawed synthesis is long-crested): drop the "
                    "yaw or the spreading (--yaw-std 0 or --spreading none)."
                )
            if excitation == "filter":
                raise ValueError(
                    "yaw changes the effective wave's weight with the heading along the run: a shaping filter cannot "
                    "make it; use excitation='superposition' or 'auto' (--method superposition/auto)."
                )
            excitation = "superposition"
        moment = _moment_excitation(ship, sea, speed, heading, dt, spreading, yaw)
        if excitation == "auto":
            excitation = "filter" if moment is None else "superposition"
        elif excitation == "filter" and moment is not None:
            raise ValueError(
                f"the ship carries a direct wave moment, which at heading χ = {math.degrees(wave.heading):.4g}° "
                "joins the roll equation: a shaping filter cannot make it with ζ_G from the same waves; use "
                "excitation='superposition' or 'auto' (--method superposition/auto)."
            )
        if validate:
            for name, value in (("phi0", phi0), ("dphi0", dphi0)):
                if not math.isfinite(value):
                    raise ValueError(f"`{name}` must be finite; got {value!r}.")
            if moment is not None and moment.yaw is not None:
                _check_yawed_time_step(dt, ship, wave, moment)
            else:
                check_time_step(dt, ship, wave, moment)
            warn_outside_validity(ship, wave, stacklevel=2)
            capsize = float(vanishing_angle(ship))
            if abs(phi0) >= capsize:
                raise ValueError(
                    f"the initial roll {math.degrees(phi0):.4g}° is beyond the angle of vanishing stability "
                    f"({math.degrees(capsize):.1f}°)."
                )
            surface = ship.restoring_surface
            if surface is not None and abs(phi0) > float(surface.heel_max):
                raise ValueError(
                    f"the initial roll {math.degrees(phi0):.4g}° is beyond the ship's GZ surface (|φ| <= "
                    f"{math.degrees(float(surface.heel_max)):.4g}°): start inside it, or widen the surface (jaxroll "
                    "hydrostatics --gz-surface --heel-max-deg)."
                )
        if excitation == "filter":
            if filter_order == "auto":
                if not is_concrete((ship, wave)):
                    raise ValueError(
                        "filter_order='auto' chooses the order from the concrete ship and sea; when the construction "
                        "is traced give the nominal problem's order (`problem.filter_fit.filter.order`)."
                    )
                fit = fit_filter_in_band(
                    wave, parametric_band(ship), match_frequency=2 * ship.omega0, warn=False
                )
            elif isinstance(filter_order, str):
                raise ValueError(f"`filter_order` must be an integer >= 3 or 'auto'; got {filter_order!r}.")
            else:
                fit = fit_filter(wave, order=filter_order, match_frequency=2 * ship.omega0)
            if validate:
                check_filter_fit(fit, dt)  # a filter that cannot be used is an error before any band warning
                _warn_if_off_the_band(fit, ship, wave)
            source = FilterExcitation(fit.filter, dt, substeps, noise_rank)
        else:
            fit = None
            source = SuperpositionExcitation(wave, dt, joint=moment is not None, yaw=yaw)
        return cls(ship, source, phi0, dphi0, moment_excitation=moment, wave=wave, filter_fit=fit)

    @property
    def dt(self) -> float:
        """Time step [s]."""
        return self.excitation.dt


class RealizationEnd(eqx.Module):
    """Capsize outcome of one realization: whether |φ| passed the vanishing angle (or diverged), and when [s];
    `left_range`: whether it ended instead by leaving its ship's GZ surface (`ship.restoring_surface`: |φ| beyond the
    surface's heel range or ζ_mid beyond its wave range), which counts as capsized too (never extrapolated)."""

    capsized: Array
    capsize_time: Array
    left_range: Array | bool = False


MOMENT_KEY = 0x7FFFFFFE  # the moment excitation of a realization keyed k draws from fold_in(k, MOMENT_KEY)


def as_dtype(tree, dtype):
    """`tree` with its floating array leaves cast to `dtype` (Grim's effective wave and a wave-moment excitation are
    left as they are: Method 1 and the moment synthesise in float64)."""

    def cast(x):
        if isinstance(x, jax.Array | np.ndarray) and jnp.issubdtype(x.dtype, jnp.floating):
            return jnp.asarray(x).astype(dtype)
        return x

    return jax.tree.map(cast, tree, is_leaf=lambda x: isinstance(x, EffectiveWave | WaveMomentExcitation))


def _drive(problem: RollProblem, key, num_steps: int, dtype, per_source_step, inner, done=None):
    """Run the problem's excitation sources for `num_steps` time steps in source steps of m = substeps, a block of
    `BLOCK` source steps at a time, calling `per_source_step(inner, xs) -> (inner, out)` with xs [sources, 2m + 1]:
    each source's value at the 2m + 1 half steps of the source step (its start included).

    `done(inner) -> bool`, if given, stops the run after the first block at whose end it holds (the blocks run in
    a while loop; `per_source_step` must then output nothing). Vmapped, the batch runs until every member is done,
    the done ones frozen.

    **Returns:** `(inner, outs)` with outs stacked over the ⌈num_steps/m⌉ source steps (None with `done`).
    """
    m = problem.excitation.substeps
    sources = [problem.excitation]
    if problem.moment_excitation is not None:
        sources.append(problem.moment_excitation)
    # a WaveMomentExcitation draws the realization's own wave components (those of a joint ζ_G): the same key
    keys = [
        key,
        key if isinstance(problem.moment_excitation, WaveMomentExcitation) else jr.fold_in(key, MOMENT_KEY),
    ]
    keys = keys[: len(sources)]
    if getattr(problem.excitation, "joint", False) and isinstance(
        problem.moment_excitation, WaveMomentExcitation
    ):
        inits = joint_init(
            problem.excitation, problem.moment_excitation, key, num_steps, m, dtype
        )  # one pass
    else:
        inits = [src.init(k, num_steps, m, dtype) for src, k in zip(sources, keys, strict=True)]

    def source_step(carry, inputs):
        states, x_start, inner = carry
        new, values = [], []
        for src, st, inp in zip(sources, states, inputs, strict=True):
            st, v = src.advance(st, inp, m)
            new.append(st)
            values.append(v)
        xs = [(x0, *v) for x0, v in zip(x_start, values, strict=True)]
        inner, out = per_source_step(inner, xs)
        return (tuple(new), tuple(v[-1] for v in values), inner), out

    def block(carry, index, length=BLOCK):
        inputs = tuple(
            jax.tree.map(lambda x: x[:length], src.block_inputs(k, st, index, m))
            for src, st, k in zip(sources, carry[0], keys, strict=True)
        )
        return jax.lax.scan(source_step, carry, inputs)

    # Whole blocks, then the first `rest` source steps of one more: no source step past num_steps is simulated
    # (and the time steps of the last one beyond num_steps are masked by the caller). The noise of the steps
    # simulated does not depend on how many follow.
    num_full, rest = divmod(-(-num_steps // m), BLOCK)
    carry = (tuple(i[0] for i in inits), tuple(i[1] for i in inits), inner)
    if done is not None:
        carry = jax.lax.while_loop(
            lambda c: (c[0] < num_full) & ~done(c[1][2]),
            lambda c: (c[0] + 1, block(c[1], c[0])[0]),
            (jnp.array(0), carry),
        )[1]
        if rest:
            carry = jax.lax.cond(
                done(carry[2]), lambda c: c, lambda c: block(c, jnp.array(num_full), rest)[0], carry
            )
        return carry[2], None
    pieces = []
    if num_full:
        carry, outs = jax.lax.scan(block, carry, jnp.arange(num_full))
        pieces.append(jax.tree.map(lambda o: o.reshape(num_full * BLOCK, *o.shape[2:]), outs))
    if rest:
        carry, outs = block(carry, jnp.array(num_full), rest)
        pieces.append(outs)
    return carry[2], jax.tree.map(lambda *o: jnp.concatenate(o), *pieces)


def simulate(
    problem: RollProblem,
    key: PRNGKeyArray,
    num_steps: int,
    observe,
    obs_state,
    *,
    dtype=jnp.float64,
    finished=None,
    record_every: int = 1,
):
    """Integrate one realization for `num_steps` steps of dt, feeding every new state to an observer.

    Classical RK4 at dt with P(t) (and M_w(t)) at each step's start, midpoint and end from the excitation sources,
    which advance m = `problem.excitation.substeps` time steps at a time (the shaping filter exactly on H = m·dt,
    bridged in between: `FilterExcitation`). `observe(obs_state, k, y, alive) -> (obs_state, output)` is called
    after step k (1-based) with y = (φ, φ̇); its outputs after the steps k = r, 2r, … (r = `record_every`, a
    divisor of m) are stacked (length `num_steps // r`), the others are not kept (nor computed). After a
    capsize (|φ| at or beyond the vanishing angle, or a non-finite state) the state is frozen and `alive` is
    False, so observers can ignore it (their floating state is kept in `dtype`). `dtype`: the floating type of the
    integration (float64; the Monte Carlo of amplitude statistics runs float32, docs/numerics.md). Written for one
    realization: vmap it over keys.

    `finished(obs_state) -> bool`, for observers without per-step outputs: the realization stops (at the end of a
    block of `BLOCK`·m steps) once it holds or the roll capsized; what follows is not simulated (outputs None).

    **Returns:** `(obs_state, outputs, RealizationEnd)`.

    **Raises:** `ValueError` when `record_every` does not divide m, or for 2³¹ or more time steps (the capsize step
    is kept as an int32).
    """
    require_float64("jaxroll.simulate")
    problem = as_dtype(problem, dtype)
    ship, h, m = problem.ship, problem.dt, problem.excitation.substeps
    if not (isinstance(record_every, int) and record_every >= 1 and m % record_every == 0):
        raise ValueError(
            f"`record_every` must be a divisor of the excitation's substeps m = {m}; got {record_every!r}."
        )
    if num_steps >= 2**31:  # the capsize step is kept as an int32
        raise ValueError(
            f"at most 2³¹ − 1 time steps per realization; got {num_steps} (shorten the duration or "
            f"lengthen dt)."
        )
    two_sources = problem.moment_excitation is not None
    surface = ship.restoring_surface  # its range ends a realization that leaves it, as a capsize does
    ragged = num_steps % m != 0  # the last source step runs past num_steps: mask its extra time steps

    def per_source_step(inner, xs):
        phi, dphi, alive, k_cap, obs, k, left = inner
        one = runtime_one(phi)  # φ is finite: P at the 2m + 1 half steps and the RK4 stages are computed once
        keep = lambda v: computed_once(v, one)  # noqa: E731
        # With a surface, ζ and its ζ-part d too: recomputed from the filter's states in each RK4 stage and range
        # check that used them, they made XLA:CPU take > 20 GB to compile `monte_carlo_max_roll`'s loop (now 0.74 GB
        # the whole process), and the Monte Carlo cost 1.40× the polynomial model's (now 1.19×: gz_surface.py)
        zeta = xs[0] if surface is None else [keep(x) for x in xs[0]]
        p = [wave_restoring_terms(ship, x) for x in zeta]
        p = [(keep(v[0]), keep(v[1])) if isinstance(v, tuple) else keep(v) for v in p]
        mw = xs[1] if two_sources else [0.0] * len(p)
        outs = []
        for s in range(m):
            phi1, dphi1 = rk4_step(ship, (phi, dphi), p[2 * s : 2 * s + 3], mw[2 * s : 2 * s + 3], h, one)
            ok = jnp.isfinite(phi1) & jnp.isfinite(dphi1) & (jnp.abs(phi1) < problem.capsize_angle)
            inside = k < num_steps
            if surface is not None:
                # ζ at the step's middle and end (its start is the last step's end; the source step's first start
                # is checked too, for the run's first step)
                zs = zeta[2 * s : 2 * s + 3] if s == 0 else zeta[2 * s + 1 : 2 * s + 3]
                on = functools.reduce(jnp.logical_and, (in_surface_range(surface, phi1, -z) for z in zs))
                left = left | ((alive & ok & ~on & inside) if ragged else (alive & ok & ~on))
                ok = ok & on
            newly = alive & ~ok & inside if ragged else alive & ~ok
            k_cap = jnp.where(newly, (k + 1).astype(k_cap.dtype), k_cap)
            alive = alive & ~newly
            phi, dphi = jnp.where(alive, phi1, phi), jnp.where(alive, dphi1, dphi)
            new_obs, out = observe(obs, k + 1, jnp.stack([phi, dphi]), alive)
            new_obs = jax.tree.map(
                lambda new, old: new.astype(old.dtype), new_obs, obs
            )  # the carry keeps its type
            if ragged:
                new_obs = jax.tree.map(lambda x, y: jnp.where(inside, x, y), new_obs, obs)
            obs = new_obs
            if (
                s + 1
            ) % record_every == 0:  # source steps start at multiples of m: step k + 1 is a multiple of r
                outs.append(out)
            k = k + 1
        return (phi, dphi, alive, k_cap, obs, k, left), jax.tree.map(lambda *o: jnp.stack(o), *outs)

    obs_state = as_dtype(obs_state, dtype)
    # The carry is per realization from the start (under vmap: batched), as it is after the first step; else vmap
    # batches the loop bodies again on finding it batched, and the nested loops multiply that (lowering the paper's
    # Monte Carlo chunk 0.80 → 0.65 s, the program the same bits). `where(True, x, x)`: the same value, no work.
    same = jr.key_data(key).reshape(-1)[0] == jr.key_data(key).reshape(-1)[0]
    per_realization = jax.tree.map(
        lambda x: jnp.where(same, x, x),
        (problem.phi0, problem.dphi0, jnp.array(True), jnp.array(-1, jnp.int32), obs_state),
    )
    inner = (*per_realization, jnp.array(0), jnp.where(same, False, False))
    done = None if finished is None else (lambda inner: ~inner[2] | finished(inner[4]))
    inner, outs = _drive(problem, key, num_steps, dtype, per_source_step, inner, done)
    _, _, alive, k_cap, obs_state, _, left = inner
    outs = jax.tree.map(lambda o: o.reshape(-1, *o.shape[2:])[: num_steps // record_every], outs)
    end = RealizationEnd(~alive, jnp.where(alive, jnp.inf, k_cap.astype(float) * h), left)
    return obs_state, outs, end


def forcing_series(problem: RollProblem, key: PRNGKeyArray, num_steps: int, *, dtype=jnp.float64):
    """P [1/s²] and M_w [rad/s²] at the (start, middle, end) of each of `num_steps` steps, [num_steps, 3] each,
    exactly as `simulate` forms them for the realization keyed `key` (M_w = 0 without a moment excitation)."""
    refuse_restoring_surface(problem.ship, "forcing_series (and the sensitivities built on it)")
    problem = as_dtype(problem, dtype)
    m = problem.excitation.substeps

    def per_source_step(inner, xs):
        p = parametric_excitation(problem.ship, jnp.stack(xs[0]))
        mw = jnp.stack(xs[1]) if problem.moment_excitation is not None else jnp.zeros_like(p)
        idx = np.arange(m)[:, None] * 2 + np.arange(3)  # [m, 3]: each time step's start, middle, end
        return inner, (p[idx], mw[idx])

    _, (p, mw) = _drive(problem, key, num_steps, dtype, per_source_step, None)
    return p.reshape(-1, 3)[:num_steps], mw.reshape(-1, 3)[:num_steps]


def roll_time_series(problem: RollProblem, key: PRNGKeyArray, duration: float, *, dtype=jnp.float64):
    """φ(t) and φ̇(t) [rad, rad/s] of one realization on t = 0, dt, …, duration [s], and its `RealizationEnd`.

    The realization keyed `fold_in(key, i)` is trial i of `monte_carlo(problem, key, ...)` (which integrates in
    float32: the two agree to ~1e-5 deg). One compiled program per problem structure, duration and dtype (a
    second call with another key or another sea of the same form runs at once)."""
    require_float64("jaxroll.roll_time_series")
    return _roll_time_series(problem, key, int(round(duration / problem.dt)), dtype)


@filter_jit
def _roll_time_series(problem: RollProblem, key: PRNGKeyArray, num_steps: int, dtype):
    def observe(obs, k, y, alive):
        return obs, y

    _, ys, end = simulate(problem, key, num_steps, observe, None, dtype=dtype)
    ys = jnp.concatenate([jnp.stack([problem.phi0, problem.dphi0]).astype(dtype)[None], ys])
    return ys[:, 0], ys[:, 1], end
