"""Moment method, stage 3: the amplitude law from the stationary moments (Roberts-family fit, per-cycle law),
and the user entry points `roll_moments`, `moment_pdf`, `moment_pdf_first_stable`."""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float

from .._compiled import filter_jit
from .._config import require_float64
from ..laws._abstract import AbstractAmplitudeLaw, check_estimator
from ..laws._checks import error_line
from ..laws._tabulated import TabulatedAmplitudeLaw
from ..sea._filters import FilterFit, ShapingFilter, fit_filter
from ..sea._grim import EffectiveWave
from ..ship._ship import Ship
from ._averaging import _harmonic_frequency2
from ._linear import refuse_wave_moment
from ._moment_equations import roll_sde
from ._moment_solver import RESULTS, StationaryMoments, raise_if_failed, stationary_moments, succeeded

# ============================================================================================================
# Amplitude family p(A) = C A^ν exp(−c2 A − c3 A²): quadrature, fit, statistics
# ============================================================================================================

# tanh-sinh nodes on (0, 1): w = logistic(π sinh t); the left tail decays double-exponentially even for ν →
# −1.
_TS_T = np.linspace(-12.0, 6.0, 1201)
_TS_H = float(_TS_T[1] - _TS_T[0])
_A_MAX_NORMALISED = 40.0  # upper limit of the normalised amplitude a = A/√E[A²] (the tail beyond is < e^-100)


def _ts_log_terms(x, log_g_of_a, power):
    """log of the tanh-sinh terms of ∫_0^x a^power g(a) da (trapezoid in t); broadcasts with x[..., None]."""
    t = jnp.asarray(_TS_T)
    ps = jnp.pi * jnp.sinh(t)
    log_w = -jax.nn.softplus(-ps)
    log_1mw = -jax.nn.softplus(ps)
    x = jnp.asarray(x)[..., None]
    power = jnp.asarray(power)[..., None]
    a = x * jnp.exp(log_w)
    log_jac = log_w + log_1mw + jnp.log(jnp.pi * jnp.cosh(t)) + jnp.log(x)
    return power * (jnp.log(x) + log_w) + log_g_of_a(a) + log_jac + math.log(_TS_H)


class AmplitudeFamily(eqx.Module):
    r"""The moment method's fitted family $p(A) = C A^\nu e^{-c_2 A - c_3 A^2}$, A [rad] ≥ 0 (Roberts' family):
    its parameters and the integrals the fit needs. Internal (not exported): the law users evaluate is
    `MomentSolution`, an `AbstractAmplitudeLaw` tabulated from it (with the per-cycle weighting for zero-crossing
    amplitudes and tails accurate in log space, which `sf = 1 − cdf` here is not).

    `nu` [-] > −1, `c2` [1/rad], `c3` [1/rad²] > 0; `log_norm` = log C. Integrals by tanh-sinh quadrature in
    JAX (relative accuracy ~1e-12, also for ν close to −1).
    """

    nu: Float[Array, ""]
    c2: Float[Array, ""]
    c3: Float[Array, ""]
    scale: Float[Array, ""]  # √E[A²] of the fit [rad]: the quadrature runs on a = A/scale

    def _log_g(self, a):
        # normalised exponent in a = A/scale
        return -self.c2 * self.scale * a - self.c3 * self.scale**2 * a**2

    def _log_integral(self, power, upper=_A_MAX_NORMALISED):
        return jax.nn.logsumexp(_ts_log_terms(upper, self._log_g, power), axis=-1)

    @property
    def log_norm(self) -> Float[Array, ""]:
        """log C (p in 1/rad)."""
        return -self._log_integral(self.nu) - (self.nu + 1) * jnp.log(self.scale)

    def moment(self, r) -> Float[Array, "..."]:
        """E[A^r] [rad^r]."""
        r = jnp.asarray(r, dtype=float)
        return jnp.exp(self._log_integral(self.nu + r) - self._log_integral(self.nu)) * self.scale**r

    def pdf(self, amplitude) -> Float[Array, "..."]:
        """p(A) [1/rad] at `amplitude` [rad] > 0."""
        amplitude = jnp.asarray(amplitude, dtype=float)
        safe = jnp.where(amplitude > 0, amplitude, 1.0)
        logp = self.log_norm + self.nu * jnp.log(safe) - self.c2 * safe - self.c3 * safe**2
        return jnp.where(amplitude > 0, jnp.exp(logp), 0.0)

    def cdf(self, amplitude) -> Float[Array, "..."]:
        """P(A ≤ amplitude), `amplitude` [rad] ≥ 0."""
        amplitude = jnp.asarray(amplitude, dtype=float)
        x = jnp.clip(amplitude / self.scale, 1e-300, _A_MAX_NORMALISED)
        out = jnp.exp(
            jax.nn.logsumexp(_ts_log_terms(x, self._log_g, self.nu), axis=-1) - self._log_integral(self.nu)
        )
        return jnp.where(amplitude > 0, jnp.minimum(out, 1.0), 0.0)

    def sf(self, amplitude) -> Float[Array, "..."]:
        """P(A > amplitude), `amplitude` [rad]."""
        return 1.0 - self.cdf(amplitude)

    def mean(self) -> Float[Array, ""]:
        """E[A] [rad]."""
        return self.moment(1.0)


@filter_jit
def fit_amplitude_family(
    amplitude_moments: ArrayLike,
) -> tuple[AmplitudeFamily, Float[Array, ""], optx.RESULTS]:
    """Fit p(A) = C A^ν e^{−c2A−c3A²} to (E[A²], E[A⁴], E[A⁶]) [rad², rad⁴, rad⁶].

    Better conditioned than matching the raw moments: on the normalised amplitude a = A/√E[A²] the residuals
    are log E[a^{2k}]_fit − log E[a^{2k}]_target, k = 1, 2, 3, in the parameters (log(ν+1), c2, log c3) (so
    ν > −1, c3 > 0 always), solved with optimistix Levenberg–Marquardt from the Rayleigh law. Differentiable
    (implicit).

    **Returns:** `(family, max_abs_log_residual, optimistix result)`.
    """
    mom = jnp.asarray(amplitude_moments, dtype=float)
    scale = jnp.sqrt(mom[0])
    target = jnp.log(mom / scale ** jnp.array([2.0, 4.0, 6.0]))

    def family(q):
        return AmplitudeFamily(jnp.exp(q[0]) - 1.0, q[1] / scale, jnp.exp(q[2]) / scale**2, scale)

    def residuals(q, args):
        tgt = args
        f = AmplitudeFamily(jnp.exp(q[0]) - 1.0, q[1], jnp.exp(q[2]), jnp.ones(()))
        li = f._log_integral(f.nu + jnp.array([0.0, 2.0, 4.0, 6.0]))
        return li[1:] - li[0] - tgt

    sol = optx.least_squares(
        residuals,
        optx.LevenbergMarquardt(rtol=1e-12, atol=1e-14),
        jnp.array([math.log(2.0), 0.0, 0.0]),
        args=target,
        max_steps=400,
        throw=False,
    )
    res = jnp.max(jnp.abs(residuals(sol.value, target)))
    return family(sol.value), res, sol.result


# ============================================================================================================
# The roll: moments → envelope moments → amplitude PDF
# ============================================================================================================

ENVELOPES = ("phase_averaged", "omega0", "mean_square_frequency")


def envelope_moments(
    moments: StationaryMoments, omega0, envelope: str = "phase_averaged"
) -> Float[Array, " 3"]:
    """(E[A²], E[A⁴], E[A⁶]) of the roll envelope from the stationary moments of (φ, φ̇) [rad^2k].

    - `"omega0"`: A² = φ² + φ̇²/ω0² (docs/theory.md), exact moments of that energy-type envelope.
    - `"mean_square_frequency"`: the same with Ω² = E[φ̇²]/E[φ²] in place of ω0² (so E[A²] = 2E[φ²]).
    - `"phase_averaged"` (default): φ = A cos Θ with Θ uniform and independent of A, so
      E[A^{2k}] = E[φ^{2k}]·4ᵏ k!²/(2k)! (E[A²] = 2E[φ²], E[A⁴] = 8/3 E[φ⁴], E[A⁶] = 16/5 E[φ⁶]); the Hilbert
      envelope of a stationary process has E[A²] = 2E[φ²] exactly.
    """
    if envelope not in ENVELOPES:
        raise ValueError(f"`envelope` must be one of {ENVELOPES}; got {envelope!r}.")
    dim = moments.equations.tables.dim

    def e(i, j):
        return moments.moment((i, j) + (0,) * (dim - 2))

    if envelope == "phase_averaged":
        return jnp.stack([2.0 * e(2, 0), 8.0 / 3.0 * e(4, 0), 16.0 / 5.0 * e(6, 0)])
    w2 = omega0**2 if envelope == "omega0" else e(0, 2) / e(2, 0)
    a2 = e(2, 0) + e(0, 2) / w2
    a4 = e(4, 0) + 2 * e(2, 2) / w2 + e(0, 4) / w2**2
    a6 = e(6, 0) + 3 * e(4, 2) / w2 + 3 * e(2, 4) / w2**2 + e(0, 6) / w2**3
    return jnp.stack([a2, a4, a6])


class MomentSolution(AbstractAmplitudeLaw):
    """The moment method's amplitude law for one ship in one sea state, with the moments behind it.

    An amplitude law (`AbstractAmplitudeLaw`, radians): `pdf`, `cdf`, `sf`, `quantile`, `mean`, `summary`.
    `estimator="envelope"` is the method's own law (time-sampled, envelope-type: compare with Monte Carlo
    envelope amplitudes); `estimator="zero_crossing"` is the per-half-cycle law derived from it by weighting
    each amplitude with the rate of half cycles at that amplitude, Ω(A)/π (harmonic balance on the ship's
    restoring, as for Roberts' and ESAM's per-cycle laws): the law the maxima formulas need.

    - `moments`: the `StationaryMoments` (E[φ²] = `moments.moment((2, 0, 0, …))` etc.).
    - `amplitude_moments`: the (E[A²], E[A⁴], E[A⁶]) [rad^2k] the family was fitted to.
    - `family`: the fitted `AmplitudeFamily` (ν, c2 [1/rad], c3 [1/rad²]) of the envelope law.
    - `law`: the tabulated law of `estimator` that the methods evaluate.
    - `fit_residual`: max |log-moment mismatch| of the fit; `result`: a `RESULTS` item.
    """

    moments: StationaryMoments
    amplitude_moments: Float[Array, " 3"]
    family: AmplitudeFamily
    law: TabulatedAmplitudeLaw
    fit_residual: Float[Array, ""]
    result: RESULTS
    closure_order: int = eqx.field(static=True)
    filter_order: int = eqx.field(static=True)
    damping: str = eqx.field(static=True)
    envelope: str = eqx.field(static=True)
    estimator: str = eqx.field(static=True)
    requested_closure_order: int | None = eqx.field(static=True, default=None)
    fallback_reason: str = eqx.field(static=True, default="")  # why the requested order gave no law

    def _logpdf(self, a):
        return self.law._logpdf(a)

    def _logsf(self, a):
        return self.law._logsf(a)

    def _logcdf(self, a):
        return self.law._logcdf(a)

    def support(self):
        return self.law.support()

    def scale(self):
        return self.family.scale

    def _phi(self, i, j):
        dim = self.moments.equations.tables.dim
        return self.moments.moment((i, j) + (0,) * (dim - 2))

    @property
    def e_phi2(self) -> Float[Array, ""]:
        """E[φ²] [rad²]."""
        return self._phi(2, 0)

    @property
    def e_phi4(self) -> Float[Array, ""]:
        """E[φ⁴] [rad⁴]."""
        return self._phi(4, 0)

    @property
    def e_dphi2(self) -> Float[Array, ""]:
        """E[φ̇²] [rad²/s²]."""
        return self._phi(0, 2)

    @property
    def closure_fallback(self) -> bool:
        """True when `moment_pdf_first_stable` used a lower closure order than the first one asked for."""
        return self.requested_closure_order is not None and self.requested_closure_order != self.closure_order

    def details(self) -> dict:
        """The method's own numbers for JSON (closure, moments, fitted family; radians)."""
        # read on the host (NumPy): indexing the device arrays would compile one small program per number
        tables = self.moments.equations.tables
        full = np.asarray(self.moments.full)

        def phi(i, j):
            return float(full[tables.index[(i, j) + (0,) * (tables.dim - 2)]])

        amp = np.asarray(self.amplitude_moments)
        converged = succeeded(self.result)
        return {
            "method": "moment method (cumulant neglect)",
            "closure_order": self.closure_order,
            "requested_closure_order": self.requested_closure_order or self.closure_order,
            "closure_fallback": self.closure_fallback,
            "closure_fallback_reason": self.fallback_reason or None,
            # why, in a word: the closure has no stable fixed point, or its moments fit no law of the family
            "closure_fallback_cause": None
            if not self.closure_fallback
            else ("amplitude_family" if fit_failed(self.fallback_reason) else "no_stable_fixed_point"),
            "filter_order": self.filter_order,
            "damping_closure": self.damping,
            "envelope": self.envelope,
            "converged": converged,
            "message": "" if converged else RESULTS[self.result],
            "E_phi2_rad2": phi(2, 0),
            "E_phi4_rad4": phi(4, 0),
            "E_dphi2_rad2_s2": phi(0, 2),
            "E_A2_rad2": float(amp[0]),
            "E_A4_rad4": float(amp[1]),
            "E_A6_rad6": float(amp[2]),
            "nu": float(self.family.nu),
            "c2_per_rad": float(self.family.c2),
            "c3_per_rad2": float(self.family.c3),
            "fit_residual": float(self.fit_residual),
            "max_real_eigenvalue_per_s": float(self.moments.max_real_eigenvalue),
        }


_LAW_POINTS = 1601
_LAW_TOP = 12.0  # the tabulated law reaches 12 √E[A²] (the family's tail there is < e^-100 of its scale)


def _harmonic_frequency(ship: Ship, amplitude):
    """Ω(A) [rad/s] of the undamped roll by harmonic balance on the GZ polynomial (floored at 1e-3 ω0)."""
    a = ship.restoring_coefficients
    return jnp.sqrt(jnp.maximum(_harmonic_frequency2(a, amplitude), 1e-6 * a[0]))


def _tabulated_law(family: AmplitudeFamily, ship: Ship, estimator: str) -> TabulatedAmplitudeLaw:
    grid = family.scale * jnp.linspace(0.0, _LAW_TOP, _LAW_POINTS)[1:]
    safe = jnp.maximum(grid, 1e-300)
    log_pdf = family.nu * jnp.log(safe) - family.c2 * safe - family.c3 * safe**2
    if estimator == "zero_crossing":
        log_pdf = log_pdf + jnp.log(_harmonic_frequency(ship, grid))
    log_pdf = log_pdf - jnp.max(log_pdf)
    # `TabulatedAmplitudeLaw.from_logpdf(grid, log_pdf)` without its input checks (the grid is increasing and
    # positive by construction): the same numbers, and no host callback when traced, so that a program holding
    # the law can be stored (`jaxroll._compiled`)
    log_mass = jnp.log(0.5 * jnp.diff(grid)) + jnp.logaddexp(log_pdf[:-1], log_pdf[1:])
    return TabulatedAmplitudeLaw(grid, log_pdf, log_mass, estimator=estimator)


def _shaping_filter(ship: Ship, wave, shaping_filter, filter_order: int) -> ShapingFilter:
    """The filter the moment equations use: `shaping_filter` when given (the Monte Carlo's, e.g.
    `problem.filter_fit.filter`), else the fit of `wave` at 2ω0 that `RollProblem.from_sea` makes."""
    if shaping_filter is not None:
        if isinstance(shaping_filter, FilterFit):
            shaping_filter = shaping_filter.filter
        if not isinstance(shaping_filter, ShapingFilter):
            raise TypeError(
                f"`shaping_filter` must be a ShapingFilter or FilterFit; got {type(shaping_filter).__name__}."
            )
        return shaping_filter
    if not isinstance(wave, EffectiveWave):
        raise TypeError(
            f"`wave` must be Grim's effective wave (`jaxroll.EffectiveWave(sea, lpp, speed, heading)`, or "
            f"`problem.wave`); got {type(wave).__name__}. A bare sea spectrum has no speed or heading."
        )
    return fit_filter(wave, order=filter_order, match_frequency=2 * ship.omega0).filter


#: r.m.s. roll [deg] of the Gaussian start of the order-4 solve (σ_φ̇ = ω0 σ_φ). Newton converges from above the
#: solution and often not from below: on the default ship's map (H1/3 3–9 m × r 1/0.8/0.6, order 4) it finds the
#: fixed point from 15° in 19 of 21 points — all but the two without a stationary law — and from 10° in 18 (at
#: r = 1, 8 m, σ_φ = 13.8°, only the relaxation found it); over H1/3 6.5–8 m, r = 1, from 10° 30 of 50 sea states
#: needed the relaxation, from 15° none. From 20° and 30° Newton fails more often (an overshoot).
GAUSSIAN_START_DEG = 15.0


def roll_moments(
    ship: Ship,
    wave: EffectiveWave | None,
    *,
    shaping_filter: ShapingFilter | FilterFit | None = None,
    filter_order: int = 4,
    closure_order: int = 6,
    damping: str = "cubic",
    initial_roll_deg: float = GAUSSIAN_START_DEG,
    throw: bool = True,
) -> StationaryMoments:
    """Stationary moments of the roll + filter system of `ship` in `wave` (see `moment_pdf`).

    Order N > 4 is reached by continuation: order 4 from a Gaussian start (σ_φ = `initial_roll_deg`,
    σ_φ̇ = ω0 σ_φ), then each higher even order from the one below (docs/theory.md: order 6 from a deterministic
    small-roll start blew up).
    """
    require_float64("jaxroll.theory.roll_moments")
    return _roll_moments(
        ship,
        wave,
        shaping_filter,
        filter_order,
        closure_order,
        damping,
        initial_roll_deg,
        throw,
        lift_relax=True,
    )


def closure_sequence(closure_order: int) -> tuple[int, ...]:
    """The closure orders `roll_moments` solves in turn to reach `closure_order`: 4, then each higher even order
    (and `closure_order` itself last)."""
    if closure_order <= 4:
        return (closure_order,)
    orders = [4, *range(6, closure_order + 1, 2)]
    if orders[-1] != closure_order:
        orders.append(closure_order)
    return tuple(orders)


def _roll_moments(
    ship, wave, shaping_filter, filter_order, closure_order, damping, initial_roll_deg, throw, *, lift_relax,
    sde=None,
) -> StationaryMoments:  # fmt: skip
    """`roll_moments`; with `lift_relax=False` every order is Newton only — order 4 from the Gaussian start, each
    higher order from the lifted lower one — with no relaxation where that fails: the result then says so, and
    the caller runs `lift_relax=True` (the relaxation first at order 4, as `roll_moments`). `sde`: the
    roll SDE when built already (on the host, where terms with zero coefficients are dropped)."""
    if sde is None:
        sde = roll_sde(ship, _shaping_filter(ship, wave, shaping_filter, filter_order), damping=damping)
    s0 = math.radians(initial_roll_deg)
    w0 = jax.lax.stop_gradient(ship.omega0)
    variances = jnp.zeros(sde.dim).at[0].set(s0**2).at[1].set((w0 * s0) ** 2)
    tau = 2 * jnp.pi / w0
    sol = None
    for k in closure_sequence(closure_order):
        if lift_relax:
            initial = sol
        else:
            initial = ("gaussian-newton", variances) if sol is None else ("lift-newton", sol)
        sol = stationary_moments(
            sde,
            closure_order=k,
            initial=initial,
            initial_variances=variances if sol is None else None,
            time_scale=tau,
            throw=throw and k == closure_order,
        )
    return sol


def moment_pdf(
    ship: Ship,
    wave: EffectiveWave | None,
    *,
    shaping_filter: ShapingFilter | FilterFit | None = None,
    estimator: str = "envelope",
    filter_order: int = 4,
    closure_order: int = 6,
    damping: str = "cubic",
    envelope: str = "phase_averaged",
    initial_roll_deg: float = GAUSSIAN_START_DEG,
    throw: bool = True,
) -> MomentSolution:
    """The moment method: stationary roll moments (cumulant neglect) → amplitude PDF C A^ν e^{−c2A−c3A²}.

    **Arguments:**

    - `ship`: the roll model (SI, radians); `wave`: Grim's effective wave (`problem.wave`).
    - `shaping_filter`: the Monte Carlo's filter (`problem.filter_fit`), so theory and simulation share one
      fit; when None, `wave` is fitted with `filter_order` at 2ω0 exactly as `RollProblem.from_sea` does.
    - `estimator`: "envelope" (the method's time-sampled law) or "zero_crossing" (per half cycle, weighted by
      Ω(A); for maxima).
    - `closure_order`: cumulant-neglect order N (4 or 6; ≥ 4).
    - `damping`: φ̇|φ̇| treatment, `"cubic"` (default) or `"linear"` (see `roll_sde`).
    - `envelope`: how amplitude moments follow from (φ, φ̇) moments (see `envelope_moments`).
    - `initial_roll_deg`: r.m.s. roll of the Gaussian start of the order-4 solve [deg] (`GAUSSIAN_START_DEG`).
    - `throw`: raise if the moment equations have no valid non-trivial fixed point or the fit fails.

    **Returns:** `MomentSolution`, an amplitude law of `estimator`. The envelope law is *time-sampled*: compare it
    with Monte Carlo envelope amplitudes (`stats.law("envelope")`), not with per-cycle
    zero-crossing amplitudes.

    !!! note
        Differentiable with respect to ship and sea parameters (`jax.grad` of e.g. `sf(jnp.deg2rad(20.0))`):
        the filter fit, the Newton root and the PDF fit are differentiated implicitly by optimistix.
    """
    refuse_wave_moment(ship, wave, "moment")
    require_float64("jaxroll.theory.moment_pdf")
    check_estimator(estimator)
    if envelope not in ENVELOPES:
        raise ValueError(f"`envelope` must be one of {ENVELOPES}; got {envelope!r}.")
    if not (isinstance(closure_order, int) and closure_order >= 4):
        raise ValueError(
            f"`closure_order` must be an integer >= 4 (E[φ⁴] is needed for the PDF); got {closure_order!r}."
        )
    return _moment_pdf(
        ship, wave, shaping_filter, estimator, filter_order, closure_order, damping, envelope, initial_roll_deg,
        throw, lift_relax=True,
    )  # fmt: skip


def _moment_pdf(
    ship, wave, shaping_filter, estimator, filter_order, closure_order, damping, envelope, initial_roll_deg, throw,
    *, lift_relax, sde=None,
) -> MomentSolution:  # fmt: skip
    """`moment_pdf` (arguments checked there); `lift_relax` and `sde` as for `_roll_moments`."""
    mom = _roll_moments(
        ship, wave, shaping_filter, filter_order, closure_order, damping, initial_roll_deg, throw,
        lift_relax=lift_relax, sde=sde,
    )  # fmt: skip
    amp, family, res, fit_result = _amplitude_law(mom, ship.omega0, envelope)
    fit_ok = (fit_result == optx.RESULTS.successful) & (res < 1e-6)
    result = RESULTS.where(
        mom.result != RESULTS.successful,
        mom.result,
        RESULTS.where(fit_ok, RESULTS.successful, RESULTS.fit_failed),
    )
    if throw:
        family = raise_if_failed(result, family)
    law = _tabulated_law(family, ship, estimator)
    return MomentSolution(
        mom, amp, family, law, res, result, closure_order, filter_order, damping, envelope, estimator
    )


@filter_jit
def _amplitude_law(mom: StationaryMoments, omega0, envelope: str):
    amp = envelope_moments(mom, omega0, envelope)
    family, res, fit_result = fit_amplitude_family(amp)
    return amp, family, res, fit_result


def moment_pdf_first_stable(
    ship: Ship, wave, *, filter_order: int = 4, closure_orders=(6, 4), **kwargs
) -> MomentSolution:
    """`moment_pdf` at the first closure order in `closure_orders` that has a stable non-trivial fixed point.

    Order 6 is the more accurate on the default ship at H1/3 = 7 m, but its branch of fixed points ends near
    H1/3 ≈ 6.26 m (docs/theory.md; `moment_branch` locates the fold); order 4 exists there. The order used is
    `result.closure_order`, the one asked for `result.requested_closure_order`, `details()` records both
    (`closure_fallback`), and a `UserWarning` says when a fallback was taken. The result is discontinuous
    across the switch, so no derivative is offered across it: under `jax.grad`/`jit`/`vmap` only the first
    order is tried (differentiate `moment_pdf` at the order chosen at the nominal point).

    Concrete calls also check that the roll is sustained: below the parametric threshold (the Lyapunov exponent
    of the linearised roll under the same coloured excitation ≤ 0, `sustained_roll_exponent`) the roll dies out,
    yet the closed moment equations can keep a stable non-trivial fixed point — on the default ship at 3 m (r = 1),
    4 m (r = 0.8), 5 m (r = 0.6), 6 m (r = 0.5) order 4 gives means of 1.2–1.9° where the Monte Carlo's envelope
    is 0.01–0.09° at 15 000–20 000 s and still falling (docs/theory.md). There this raises (`throw=False`: the
    law is returned with `result` `RESULTS.roll_not_sustained`). `moment_pdf` itself, the paper's method, does
    not check.

    **Raises:** the last order's error when none of them has a stable solution (the first order's when traced);
    `ValueError` "the roll dies out" where the roll is not sustained (concrete calls).
    """
    require_float64("jaxroll.theory.moment_pdf_first_stable")
    from .._compiled import is_concrete

    error = None
    for i, order in enumerate(closure_orders):
        if i > 0 and not is_concrete((ship, wave, kwargs.get("shaping_filter"))):
            raise error  # traced: never switch closure inside a derivative (the law jumps there)
        try:
            out = moment_pdf(ship, wave, filter_order=filter_order, closure_order=order, **kwargs)
        except (ValueError, RuntimeError) as e:
            error = e
            continue
        out = with_requested_order(out, closure_orders[0], error)
        if is_concrete((ship, wave, kwargs.get("shaping_filter"))) and succeeded(out.result):
            lam = sustained_roll_exponent(ship, wave, kwargs.get("shaping_filter"))
            if not float(lam) > 0:  # below the threshold: the closure's fixed point is not the roll's
                if kwargs.get("throw", True):
                    raise roll_not_sustained_error(lam, out)
                return dataclasses.replace(out, result=RESULTS.roll_not_sustained)
        if i > 0:
            warn_closure_fallback(closure_orders[0], error, order)
        return out
    raise error


def with_requested_order(law: MomentSolution, requested: int, error: Exception | None) -> MomentSolution:
    """`law` labelled with the closure order asked for and, where that order gave no law (`error`), why."""
    return dataclasses.replace(
        law, requested_closure_order=requested, fallback_reason="" if error is None else error_line(error)
    )


def roll_not_sustained_error(lyapunov_exponent, law=None) -> ValueError:
    """The moment method's error where the linearised roll is stable under the coloured excitation (λ ≤ 0): the
    roll dies out, and a non-trivial fixed point of the closed moment equations is the closure's, not the roll's."""
    if not math.isfinite(float(lyapunov_exponent)):  # the envelope model behind λ does not fit this sea
        return ValueError(
            "moment method: no law: whether the roll is sustained cannot be told here: the Lyapunov exponent of "
            "the linearised roll under the coloured excitation is undefined (`envelope_lyapunov_exponent`: the "
            "wave's envelope about 2ω0 does not fit its Ornstein–Uhlenbeck model, e.g. following seas at speed), "
            "and where the roll dies out the closed moment equations keep non-trivial fixed points that are "
            "artefacts (docs/theory.md, 'Below the threshold'). Roberts' criterion (K against b1/2, `roberts_pdf`) "
            "tells whether the roll is sustained."
        )
    found = (
        f" (the closure's non-trivial fixed point here, mean {math.degrees(float(law.mean())):.2f}°, is an "
        "artefact of the closure: the Monte Carlo decays)"
        if law is not None
        else ""
    )
    return ValueError(
        "moment method: no stationary law: the roll dies out. The linearised roll under the coloured excitation "
        f"has Lyapunov exponent λ = {float(lyapunov_exponent):.3g} 1/s <= 0 (`envelope_lyapunov_exponent`), so "
        f"A → 0 almost surely{found}. Increase H1/3 or r, or reduce b1 (docs/theory.md, 'Below the threshold')."
    )


def sustained_roll_exponent(ship: Ship, wave, shaping_filter=None) -> Float[Array, ""]:
    """λ [1/s] of the linearised roll under the moment method's coloured excitation — the shaping filter's
    spectrum when one is given (the Monte Carlo's), else `wave`'s (`envelope_lyapunov_exponent`). λ ≤ 0: the roll
    dies out, whatever stationary point the closed moment equations have."""
    from ._envelope_fpk import envelope_lyapunov_exponent

    source = shaping_filter.filter if isinstance(shaping_filter, FilterFit) else shaping_filter
    return envelope_lyapunov_exponent(ship, wave if source is None else source)[0]


def fit_failed(reason: str) -> bool:
    """Whether a moment-method error line is the amplitude family's (the closure's moments exist, but no
    p = C A^ν e^(−c2A−c3A²) reproduces them) rather than the closure's (no stable fixed point)."""
    return RESULTS[RESULTS.fit_failed][:60] in reason  # the solver's own message, however it was wrapped


def warn_closure_fallback(requested: int, error: Exception, used: int, stacklevel: int = 2) -> None:
    """The `UserWarning` of a closure fallback (order `requested` failed with `error`; `used` is used instead),
    attributed to the caller of the function that calls this (`stacklevel=2`)."""
    import warnings

    reason = error_line(error)
    if fit_failed(reason):
        warnings.warn(
            f"moment method: closure order {requested} has a stable solution here, but no amplitude law of the "
            f"method's family fits its moments ({reason}); using order {used}.",
            stacklevel=stacklevel + 1,
        )
    else:
        warnings.warn(
            f"moment method: closure order {requested} has no stable solution here ({reason}); using order "
            f"{used}. This warning appears because the higher-order cumulant closure lost its stable "
            "non-trivial fixed point in this sea state.",
            stacklevel=stacklevel + 1,
        )
