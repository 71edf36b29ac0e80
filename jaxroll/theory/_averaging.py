"""Stationary roll-amplitude PDFs by stochastic averaging: Roberts' SAM and the energy-based ESAM.

Both start from the roll equation with the parametric term split into its mean and a zero-mean fluctuation,

    φ̈ + b(φ̇) + g(φ) + (E[P] + P̃(t)) φ = 0,   b(v) = b1 v + b2 v|v| + b3 v³,   g(φ) = Σ a_{2n−1} φ^{2n−1},

and, by default (`mean_shift=True`), absorb the mean E[P] = r κ h_0 into the linear stiffness: ω_l² = ω0² + E[P].
The fluctuation P̃ enters through its one-sided spectrum S_P⁺ (`parametric_spectrum`).

- **Roberts (SAM)**, φ = A cos Φ: dA = [−m_d(A) + (3/2) K A] dt + √K A dW with K = (π/8) S_P⁺(2ω_l)/ω_l² and
  m_d = (b1/2)A + (4/3π) b2 ω_l A² + (3/8) b3 ω_l² A³, so p(A) = C A^ν exp(−c2 A − c3 A²),
  ν = 1 − b1/K, c2 = 8 b2 ω_l/(3πK), c3 = 3 b3 ω_l²/(8K). The `"nonlinear"` variant uses the harmonic-balance
  frequency Ω(A) in K(A) and in the damping averages, p(A) = C A exp(−∫ 2 m_d/(K a²) da).
- **ESAM**: H = φ̇²/2 + G(φ) on the exact undamped orbits; p_H ∝ T(H) exp(−∫ 2⟨φ̇ b⟩/σ_H² dH).

A is the envelope amplitude and both stationary laws are *time-sampled*: compare `estimator="envelope"` with the
Monte Carlo's envelope PDF (every sample). `estimator="zero_crossing"` weights each amplitude by the number of
half cycles per unit time, p ∝ p_A/T(A), to compare with per-half-cycle zero-crossing amplitudes. See
docs/theory.md for the derivations, the checks and the treatment of the top of the potential well.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._compiled import filter_jit
from .._config import require_float64
from ..laws._abstract import check_estimator
from ..sea._grim import EffectiveWave
from ..ship._ship import Ship
from ._averaged_law import (
    AveragedAmplitudeLaw,
    _build_pdf,
    _cumulative,
    _log_grid,
    _with_parameters,
)
from ._excitation import ParametricSpectrum, parametric_spectrum
from ._linear import refuse_wave_moment

_TAIL_EXPONENT = 80.0  # linear Roberts: the grid ends where c2 A + c3 A² = 80 (p below e^-80 of its scale)


# ------------------------------------------------------------------------------------------------------------
# Roberts' stochastic averaging
# ------------------------------------------------------------------------------------------------------------


class RobertsCoefficients(eqx.Module):
    r"""Roberts' averaged amplitude SDE for $\ddot\phi + b(\dot\phi) + \omega^2(1 + \xi(t))\phi = 0$ (Itô):

    $dA = [-\tfrac{b_1}{2}A - \tfrac{4 b_2\omega}{3\pi}A^2 - \tfrac{3 b_3\omega^2}{8}A^3 + \tfrac32 K A]\,dt
    + \sqrt{K}\,A\,dW$, with $K = \tfrac{\pi}{4}\omega^2 S_\xi(2\omega)$ (two-sided $S_\xi$) $=
    \tfrac{\pi}{8} S_P^+(2\omega)/\omega^2$.

    **Fields:** `omega`: ω [rad/s] (ω0, or ω_l with the mean stiffness shift); `k`: K [1/s];
    `damping`: (b1 [1/s], b2 [1/rad], b3 [s/rad²]).
    """

    omega: Float[Array, ""]
    k: Float[Array, ""]
    damping: Float[Array, " 3"]

    def __init__(self, omega, k, damping):
        self.omega = jnp.asarray(omega, dtype=float)
        self.k = jnp.asarray(k, dtype=float)
        self.damping = jnp.asarray(damping, dtype=float)

    @property
    def nu(self) -> Float[Array, ""]:
        """ν = 1 − b1/K [-]: p(A) ∝ A^ν near 0; a stationary PDF needs ν > −1."""
        return 1 - self.damping[0] / self.k

    @property
    def c2(self) -> Float[Array, ""]:
        """c2 = 8 b2 ω/(3πK) [1/rad]."""
        return 8 * self.damping[1] * self.omega / (3 * jnp.pi * self.k)

    @property
    def c3(self) -> Float[Array, ""]:
        """c3 = 3 b3 ω²/(8K) [1/rad²]."""
        return 3 * self.damping[2] * self.omega**2 / (8 * self.k)

    @property
    def lyapunov_exponent(self) -> Float[Array, ""]:
        """Almost-sure growth rate of ln A at small amplitude, K − b1/2 [1/s] (> 0 ⇔ ν > −1)."""
        return self.k - self.damping[0] / 2

    @property
    def mean_square_exponent(self) -> Float[Array, ""]:
        """Growth rate of E[A²] at small amplitude, 4K − b1 [1/s] (mean-square stable iff < 0)."""
        return 4 * self.k - self.damping[0]

    def drift(self, amplitude: ArrayLike) -> Float[Array, "..."]:
        """Itô drift of A [rad/s]."""
        a = jnp.asarray(amplitude, dtype=float)
        b1, b2, b3 = self.damping
        w = self.omega
        return (-b1 / 2 + 1.5 * self.k) * a - 4 * b2 * w / (3 * jnp.pi) * a**2 - 3 * b3 * w**2 / 8 * a**3

    def diffusion(self, amplitude: ArrayLike) -> Float[Array, "..."]:
        """Diffusion coefficient σ(A) = √K A [rad/√s] (dW has unit intensity)."""
        return jnp.sqrt(self.k) * jnp.asarray(amplitude, dtype=float)

    @property
    def exists(self) -> Bool[Array, ""]:
        """Whether the stationary PDF exists: ν > −1 (K > b1/2) and c2 > 0 or c3 > 0."""
        return _existence(self.nu, False, self.c2, self.c3)

    @filter_jit
    def stationary_pdf(self, *, num: int = 2049, estimator: str = "envelope") -> AveragedAmplitudeLaw:
        """The stationary PDF p(A) = C A^ν e^{−c2A − c3A²} on [0, ∞) as an `AveragedAmplitudeLaw` (NaN if none exists).

        The grid is log-spaced up to where c2A + c3A² = 80. Per half cycle the weight ∝ Ω is constant, so both
        estimators give the same PDF.
        """
        check_estimator(estimator)
        nu, c2, c3 = self.nu, self.c2, self.c3
        exists = self.exists
        nu_s, c2_s, c3_s = jnp.where(exists, nu, 0.0), jnp.where(exists, c2, 1.0), jnp.where(exists, c3, 0.0)
        s = _log_grid(_roberts_amax(c2_s, c3_s), num)
        a = jnp.exp(s)
        log_unnorm = nu_s * s - c2_s * a - c3_s * a**2
        parameters = {
            "nu": nu,
            "c2": c2,
            "c3": c3,
            "K": self.k,
            "b1": self.damping[0],
            "omega": self.omega,
            "lyapunov_exponent": self.lyapunov_exponent,
        }
        return _build_pdf(s, log_unnorm, nu_s, exists, parameters, "roberts", estimator)


@filter_jit
def roberts_log_normaliser(
    nu: ArrayLike, c2: ArrayLike, c3: ArrayLike, *, num: int = 2049
) -> Float[Array, ""]:
    r"""$\ln\int_0^\infty A^\nu e^{-c_2A - c_3A^2} dA$ (ν > −1; c2, c3 ≥ 0, not both 0), differentiably.

    Closed form $\Gamma(\nu+1)c_2^{-(\nu+1)}$ when c3 = 0; otherwise trapezoid quadrature in ln A on
    [A_max·1e-6, A_max] with the analytic piece below (the parabolic-cylinder closed form needs
    `scipy.special.pbdv`, which JAX lacks; the tests check against it to ~1e-12).
    """
    nu = jnp.asarray(nu, dtype=float)
    c2 = jnp.asarray(c2, dtype=float)
    c3 = jnp.asarray(c3, dtype=float)
    a_max = _roberts_amax(c2, c3)
    s = _log_grid(a_max, num)
    a = jnp.exp(s)
    f = (nu + 1) * s - c2 * a - c3 * a**2
    shift = jnp.max(f)
    quad = jnp.log(_cumulative(s, jnp.exp(f - shift), nu + 1)[0][-1]) + shift
    safe_c2 = jnp.where(c2 > 0, c2, 1.0)
    gamma_form = jax.scipy.special.gammaln(nu + 1) - (nu + 1) * jnp.log(safe_c2)
    return jnp.where(c3 == 0, gamma_form, quad)


def _roberts_amax(c2, c3):
    """Amplitude where c2 A + c3 A² = 80 (beyond it the Roberts PDF is below e^-80 of its scale; ν < 1)."""
    disc = jnp.sqrt(c2**2 + 4 * c3 * _TAIL_EXPONENT)
    return 2 * _TAIL_EXPONENT / jnp.maximum(c2 + disc, 1e-300)


def _as_spectrum(ship: Ship, wave) -> ParametricSpectrum:
    if isinstance(wave, ParametricSpectrum):
        return wave
    if isinstance(wave, EffectiveWave):
        return parametric_spectrum(ship, wave)
    raise TypeError(
        f"`wave` must be a `jaxroll.EffectiveWave` or a `ParametricSpectrum`; got {type(wave).__name__}."
    )


def _linear_stiffness(ship: Ship, spectrum: ParametricSpectrum, mean_shift: bool):
    """ω_l² = ω0² + E[P] (or ω0²) [1/s²]."""
    w2 = ship.omega0**2
    return w2 + spectrum.mean if mean_shift else w2


def roberts_coefficients(
    ship: Ship, wave: EffectiveWave | ParametricSpectrum, *, mean_shift: bool = True
) -> RobertsCoefficients:
    """Roberts' averaged-SDE coefficients for `ship` in `wave` (an effective wave or its S_P).

    K = (π/8) S_P⁺(2ω)/ω² with ω = ω_l = √(ω0² + E[P]) (`mean_shift=True`, the default) or ω0.
    """
    require_float64("jaxroll.theory.roberts_coefficients")
    spectrum = _as_spectrum(ship, wave)
    w = jnp.sqrt(_linear_stiffness(ship, spectrum, mean_shift))
    k = jnp.pi / 8 * spectrum(2 * w) / w**2
    return RobertsCoefficients(w, k, ship.damping)


def _restoring_poly(ship: Ship, stiffness_shift):
    """(a1 + shift, a3, a5, a7, a9)."""
    return ship.restoring_coefficients.at[0].add(stiffness_shift)


def _g(a, x):
    """g(x) = Σ a_{2n−1} x^{2n−1}."""
    x2 = x * x
    return x * (a[0] + x2 * (a[1] + x2 * (a[2] + x2 * (a[3] + x2 * a[4]))))


def _potential(a, x):
    """G(x) = Σ a_{2n−1} x^{2n}/(2n)."""
    x2 = x * x
    return x2 * (a[0] / 2 + x2 * (a[1] / 4 + x2 * (a[2] / 6 + x2 * (a[3] / 8 + x2 * a[4] / 10))))


def _first_zero(a):
    """First x in (0, π] with g(x) ≤ 0 (π if none), by a grid and bisection. **Returns:** `(x, found)`."""
    x = jnp.linspace(0.0, jnp.pi, 4097)[1:]
    neg = _g(a, x) <= 0
    idx = jnp.argmax(neg)
    found = neg[idx]
    lo = jnp.where(idx > 0, x[idx - 1], 0.0)
    up = x[idx]

    def bisect(_, bounds):
        lo, up = bounds
        mid = (lo + up) / 2
        n = _g(a, mid) <= 0
        return jnp.where(n, lo, mid), jnp.where(n, mid, up)

    lo, up = jax.lax.fori_loop(0, 45, bisect, (lo, up))
    return jnp.where(found, (lo + up) / 2, jnp.pi), found


def _well_top(ship: Ship, a_eff):
    """Top of the amplitude domain for the nonlinear theories: the calm-water vanishing angle (the Monte Carlo's
    capsize angle), or just below the vanishing angle of the shifted restoring if that is smaller.

    **Returns:** `(a_top [rad], bounded)`; `bounded` is False when the restoring never vanishes below π.
    """
    calm = _first_zero(ship.restoring_coefficients)[0]  # = jaxroll.vanishing_angle(ship)
    eff, found = _first_zero(a_eff)
    bounded = found | (calm < jnp.pi)
    top = jnp.minimum(calm, jnp.where(found, eff * (1 - 1e-3), jnp.pi))
    return top, bounded


def _existence(nu0, bounded, c2, c3):
    return (nu0 > -1) & (bounded | (c2 > 0) | (c3 > 0))


_NO_PDF = (
    "no stationary roll-amplitude PDF exists: either the roll dies out (the parametric excitation K = "
    "(π/8) S_P⁺(2ω)/ω² is below b1/2, i.e. ν = 1 − b1/K ≤ −1: increase H1/3 or reduce the linear damping b1), "
    "or the damping is purely linear (b2 = b3 = 0) on an unbounded restoring, so p(A) ∝ A^ν cannot be "
    "normalised. Call with throw=False and inspect `.parameters` for K and b1."
)


def _no_pdf_message(p: dict) -> str:
    k, b1, nu = float(p["K"]), float(p["b1"]), float(p["nu"])
    if not nu > -1:
        remedy = (
            "There is no parametric excitation at all: the waves do not modulate GM here (beam seas, a ΔGM(ζ) "
            "polynomial of zeros, or a GM correction r = 0)." if k == 0 else
            "Increase H1/3 or the GM correction r, or reduce the damping b1."
        )  # fmt: skip
        return (
            f"No stationary roll-amplitude PDF: the roll dies out. The parametric excitation K = {k:.4g} 1/s "
            f"is below b1/2 = {b1 / 2:.4g} 1/s (ν = 1 − b1/K = {nu:.4g} ≤ −1; Lyapunov exponent K − b1/2 = "
            f"{k - b1 / 2:.3g} 1/s < 0), so A → 0 almost surely. {remedy}"
        )
    return (
        f"No stationary roll-amplitude PDF: with purely linear damping (b2 = b3 = 0) and a restoring that never "
        f"vanishes, p(A) ∝ A^ν (ν = {nu:.4g}) cannot be normalised on [0, ∞): the amplitude grows without bound "
        "(K > b1/2). Give the ship quadratic or cubic damping, or a GZ curve with a vanishing angle."
    )


def _finish(out: AveragedAmplitudeLaw, throw: bool) -> AveragedAmplitudeLaw:
    if not throw:
        return out
    if not isinstance(out.exists, jax.core.Tracer):
        if not bool(out.exists):
            raise ValueError(_no_pdf_message(out.parameters))
        return out
    checked = eqx.error_if(out.log_density, ~out.exists, _NO_PDF)
    return eqx.tree_at(lambda o: o.log_density, out, checked)


@filter_jit
def _roberts_linear(ship, spectrum, estimator, mean_shift, num):
    rc = roberts_coefficients(ship, spectrum, mean_shift=mean_shift)
    out = rc.stationary_pdf(num=num, estimator=estimator)
    extra = {
        "mean_stiffness_shift": spectrum.mean if mean_shift else jnp.zeros(()),
        "S_P_at_2omega": spectrum(2 * rc.omega),
        # Roberts' law lives on [0, ∞): the mass it puts beyond the vanishing angle (the capsize range).
        "mass_beyond_vanishing_angle": out.sf(_first_zero(ship.restoring_coefficients)[0]),
    }
    return _with_parameters(out, **extra)


def _harmonic_frequency2(a_eff, amp):
    """Ω(A)² = a1 + (3/4)a3A² + (5/8)a5A⁴ + (35/64)a7A⁶ + (63/128)a9A⁸ (harmonic balance) [1/s²]."""
    x2 = amp * amp
    return a_eff[0] + x2 * (
        0.75 * a_eff[1] + x2 * (0.625 * a_eff[2] + x2 * (35 / 64 * a_eff[3] + x2 * 63 / 128 * a_eff[4]))
    )


def _nonlinear_domain(ship, a_eff, rc: RobertsCoefficients, max_amplitude):
    top, bounded = _well_top(ship, a_eff)
    rule = jnp.minimum(
        _roberts_amax(jnp.where(rc.c2 > 0, rc.c2, 0.0), jnp.where(rc.c3 > 0, rc.c3, 0.0)), jnp.pi
    )
    top = jnp.where(bounded, top, rule)
    if max_amplitude is not None:
        top = jnp.minimum(top, jnp.asarray(max_amplitude, dtype=float))
    return top, bounded


@filter_jit
def _roberts_nonlinear(ship, spectrum, estimator, mean_shift, num, max_amplitude):
    rc = roberts_coefficients(ship, spectrum, mean_shift=mean_shift)
    shift = spectrum.mean if mean_shift else jnp.zeros(())
    a_eff = _restoring_poly(ship, shift)
    top, bounded = _nonlinear_domain(ship, a_eff, rc, max_amplitude)
    exists = _existence(rc.nu, bounded, rc.c2, rc.c3)
    s = _log_grid(top, num)
    a = jnp.exp(s)
    w = jnp.sqrt(jnp.maximum(_harmonic_frequency2(a_eff, a), 1e-12 * a_eff[0]))
    k = jnp.pi / 8 * spectrum(2 * w) / w**2
    b1, b2, b3 = ship.damping
    m_d = b1 / 2 * a + 4 * b2 * w / (3 * jnp.pi) * a**2 + 3 * b3 * w**2 / 8 * a**3
    s0 = jnp.where(exists, b1 / rc.k, 0.0)
    # exponent integrand 2 m_d/(K a²) minus its singular part s0/a (exact at a → 0), integrated in s = ln a
    regular = (2 * m_d / (k * a**2) - s0 / a) * a
    psi = _cumulative(s, regular, 1.0)[0]
    nu0 = 1 - s0
    log_unnorm = nu0 * s - psi
    if estimator == "zero_crossing":
        log_unnorm = log_unnorm + jnp.log(w / w[0])  # half cycles per unit time ∝ Ω(A)
    parameters = {
        "nu": rc.nu,
        "c2": rc.c2,
        "c3": rc.c3,
        "K": rc.k,
        "b1": b1,
        "omega": rc.omega,
        "mean_stiffness_shift": shift,
        "S_P_at_2omega": spectrum(2 * rc.omega),
        "lyapunov_exponent": rc.lyapunov_exponent,
        "omega_at_top": w[-1],
        "K_at_top": k[-1],
    }
    out = _build_pdf(s, log_unnorm, nu0, exists, parameters, "roberts_nonlinear", estimator)
    return _with_parameters(out, density_at_top_per_degree=out.density[-1] * jnp.pi / 180)


def roberts_pdf(
    ship: Ship,
    wave: EffectiveWave | ParametricSpectrum,
    *,
    restoring: str = "linear",
    estimator: str = "envelope",
    mean_shift: bool = True,
    num: int = 2049,
    max_amplitude: float | None = None,
    throw: bool = True,
) -> AveragedAmplitudeLaw:
    r"""Roberts' stationary PDF of the roll amplitude (stochastic averaging, Itô amplitude SDE).

    **Arguments:**

    - `ship`: the roll model (damping b1, b2, b3; restoring a1…a9; ΔGM and GM0 through S_P).
    - `wave`: Grim's effective wave (`jaxroll.EffectiveWave`, e.g. `problem.wave`), or its precomputed
      `ParametricSpectrum`.
    - `restoring`: `"linear"` — Roberts' closed form $p = C A^\nu e^{-c_2A - c_3A^2}$ on [0, ∞), whatever the
      ship's GZ curve; `"nonlinear"` — the harmonic-balance frequency Ω(A) in K(A) = (π/8)S_P⁺(2Ω)/Ω² and in
      the damping averages, $p = C A \exp(-\int_0^A 2 m_d/(K a^2)\,da)$, on [0, vanishing angle].
    - `estimator`: `"envelope"` (time-sampled A: compare with the Monte Carlo envelope PDF) or
      `"zero_crossing"` (per half cycle, ∝ p·Ω(A); identical for linear restoring).
    - `mean_shift`: absorb E[P] = rκh_0 into the stiffness, ω_l² = ω0² + E[P] (default True; False uses ω0).
    - `num`: grid points (log-spaced in A). `max_amplitude`: optional cap of the nonlinear support [rad].
    - `throw`: raise when no stationary PDF exists (ν ≤ −1, or linear damping on an unbounded restoring);
      with `throw=False` the result has `exists=False` and NaN densities.

    **Returns:** `AveragedAmplitudeLaw` with `parameters` ν, c2, c3, K [1/s], ω [rad/s], … (radians throughout).

    **Raises:** `ValueError` (concrete inputs) or `EquinoxRuntimeError` (under `jit`/`grad`) when no PDF exists.

    jit-able and differentiable (e.g. `jax.grad` of `.sf(a)` with respect to ship fields or H1/3).
    """
    refuse_wave_moment(ship, wave, "roberts")
    require_float64("jaxroll.theory.roberts_pdf")
    check_estimator(estimator)
    spectrum = _as_spectrum(ship, wave)
    if restoring == "linear":
        out = _roberts_linear(ship, spectrum, estimator, mean_shift, num)
    elif restoring == "nonlinear":
        out = _roberts_nonlinear(ship, spectrum, estimator, mean_shift, num, max_amplitude)
    else:
        raise ValueError(f"`restoring` must be 'linear' or 'nonlinear'; got {restoring!r}.")
    return _finish(out, throw)


# ------------------------------------------------------------------------------------------------------------
# ESAM: energy-based stochastic averaging on the exact undamped orbits
# ------------------------------------------------------------------------------------------------------------


class Orbits(eqx.Module):
    """Undamped orbits φ̈ + g(φ) = 0 of amplitude A [rad] (energy H = G(A)), vectorised over A.

    `period` T [s], `frequency` Ω = 2π/T [rad/s], `fourier` d_m [rad²] of φ² = d_0 + Σ_m d_m cos(mΩt)
    (m = 2, 4, …, 2·num_harmonics; t from a maximum), `dissipation` ⟨φ̇ b(φ̇)⟩ [1/s³],
    `mean_rate_squared` ⟨φ̇²⟩ [1/s²], `energy` H [1/s²], `restoring` g(A) [1/s²].
    """

    amplitude: Float[Array, " n"]
    energy: Float[Array, " n"]
    restoring: Float[Array, " n"]
    period: Float[Array, " n"]
    frequency: Float[Array, " n"]
    fourier: Float[Array, "n m"]
    dissipation: Float[Array, " n"]
    mean_rate_squared: Float[Array, " n"]


def _difference_quotient(a, u, w):
    """(G(√u) − G(√w))/(u − w) = Σ_n a_{2n−1}/(2n) Σ_{k<n} u^k w^{n−1−k}, without 0/0."""
    q = jnp.ones_like(w)
    w_pow = jnp.ones_like(w)
    out = a[0] / 2 * q
    for n in range(2, 6):
        w_pow = w_pow * w
        q = u * q + w_pow
        out = out + a[n - 1] / (2 * n) * q
    return out


def undamped_orbits(
    a_coefficients: ArrayLike,
    damping: ArrayLike,
    amplitude: ArrayLike,
    *,
    num_theta: int = 256,
    num_harmonics: int = 6,
    num_gauss: int = 64,
) -> Orbits:
    r"""Period, Fourier coefficients of φ² and damping averages on the undamped orbits of amplitude A.

    The orbit is parametrised by φ = A sin θ: dt = dθ/√(2R(θ)) with R = (G(A) − G(φ))/(A² − φ²) > 0, a smooth
    π-periodic even function of θ, so T = 4∫₀^{π/2} dθ/√(2R) and the time t(θ) (through the Fourier series of
    1/√(2R)) are spectrally accurate on a uniform θ grid; d_m = (8/T)∫₀^{T/4} φ² cos(mΩt) dt uses the same grid.
    ⟨φ̇b⟩ = (4/T)∫₀^A b(v) dφ, v = √(2(H − G(φ))), by Gauss–Legendre in θ.

    **Arguments:** `a_coefficients`: (a1, a3, a5, a7, a9) [1/s² rad^(1−n)]; `damping`: (b1, b2, b3);
    `amplitude`: A [rad] (1-D, below the vanishing angle); `num_theta`, `num_harmonics`, `num_gauss`.
    """
    a = jnp.asarray(a_coefficients, dtype=float)
    b1, b2, b3 = jnp.asarray(damping, dtype=float)
    amp = jnp.asarray(amplitude, dtype=float)
    theta = jnp.arange(num_theta, dtype=float) * jnp.pi / num_theta
    x_gl, w_gl = np.polynomial.legendre.leggauss(num_gauss)
    theta_gl = jnp.asarray((x_gl + 1) * jnp.pi / 4)
    w_gl = jnp.asarray(w_gl * np.pi / 4)
    kk = jnp.fft.fftfreq(num_theta) * num_theta
    nyq = jnp.abs(kk) == num_theta // 2
    harmonics = 2 * jnp.arange(1, num_harmonics + 1, dtype=float)
    sign = jnp.where((harmonics // 2) % 2 == 0, 1.0, -1.0)

    def one(amp_i):
        u = amp_i**2
        sin2 = jnp.sin(theta) ** 2
        r = jnp.maximum(_difference_quotient(a, u, u * sin2), 1e-300)
        f = 1 / jnp.sqrt(2 * r)  # dt/dθ
        f0 = jnp.mean(f)
        period = 2 * jnp.pi * f0
        omega = 1 / f0
        coef = jnp.fft.fft(f - f0)
        denom = jnp.where(kk == 0, 1.0, kk).astype(coef.dtype) * jnp.asarray(2j, coef.dtype)
        integ = jnp.where((kk == 0) | nyq, 0.0, coef / denom)
        p = jnp.real(jnp.fft.ifft(integ))
        tau = f0 * theta + p - p[0]
        phase = harmonics[:, None] * omega * tau[None, :]
        d = 2 * u / (num_theta * f0) * sign * jnp.sum(sin2 * jnp.cos(phase) * f, axis=1)
        # damping averages (Gauss–Legendre on θ ∈ [0, π/2])
        cos_gl = jnp.cos(theta_gl)
        r_gl = jnp.maximum(_difference_quotient(a, u, u * jnp.sin(theta_gl) ** 2), 0.0)
        v = amp_i * cos_gl * jnp.sqrt(2 * r_gl)
        jac = amp_i * cos_gl * w_gl
        diss = 4 / period * jnp.sum((b1 * v + b2 * v**2 + b3 * v**3) * jac)
        rate2 = 4 / period * jnp.sum(v * jac)
        return period, omega, d, diss, rate2

    period, omega, d, diss, rate2 = jax.vmap(one)(amp)
    return Orbits(amp, _potential(a, amp), _g(a, amp), period, omega, d, diss, rate2)


def parametric_energy_diffusion(orbits: Orbits, spectrum: ParametricSpectrum) -> Float[Array, " n"]:
    """σ_H²(H) = (π/8) Σ_m m² Ω² d_m² S_P⁺(mΩ) [1/s⁵] for the energy rate −P̃ φ φ̇ (one-sided S_P⁺)."""
    m = 2 * jnp.arange(1, orbits.fourier.shape[1] + 1, dtype=float)
    w = orbits.frequency[:, None] * m[None, :]
    return jnp.pi / 8 * jnp.sum(w**2 * orbits.fourier**2 * spectrum(w), axis=1)


def additive_energy_diffusion(orbits: Orbits, intensity: ArrayLike) -> Float[Array, " n"]:
    """σ_H²(H) = D ⟨φ̇²⟩ [1/s⁵] for an additive white moment W, E[W(t)W(t+τ)] = D δ(τ) (D [1/s³])."""
    return jnp.asarray(intensity, dtype=float) * orbits.mean_rate_squared


def moment_energy_diffusion(orbits: Orbits, moment) -> Float[Array, " n"]:
    """σ_H²(H) = π S_M⁺(Ω) ⟨φ̇²⟩ [1/s⁵] for the energy rate φ̇ M_w of a direct wave moment M_w [rad/s²] (one-sided
    spectrum S_M⁺ = `moment.spectrum`, e.g. a `WaveMomentExcitation`): the moment's spectrum taken as white at the
    orbit's frequency Ω(H) (its fundamental; exact for a linear orbit, π S_M⁺ being the intensity of a white
    moment of that level: `additive_energy_diffusion`)."""
    return jnp.pi * moment.spectrum(orbits.frequency) * orbits.mean_rate_squared


def energy_averaged_pdf(
    orbits: Orbits,
    sigma_h2: Float[Array, " n"],
    singular: ArrayLike,
    *,
    estimator: str = "envelope",
    exists: ArrayLike = True,
    parameters: dict | None = None,
    method: str = "esam",
) -> AveragedAmplitudeLaw:
    r"""The ESAM core: stationary amplitude PDF from orbits and an energy diffusion σ_H²(H) on a log A grid.

    With the drift m_H = −⟨φ̇b⟩ + (1/2T) d(Tσ_H²)/dH, the stationary law is
    p_H ∝ T(H) exp(−∫₀^H 2⟨φ̇b⟩/σ_H² dH'), mapped to the amplitude by H = G(A):
    time-sampled (`"envelope"`) p_A = p_H(G(A)) g(A); per half cycle (`"zero_crossing"`) ∝ p_A/T(G(A)).

    `singular` = s0 is the limit of A·2⟨φ̇b⟩g/σ_H² as A → 0 (b1/K0 for parametric noise, 0 for additive noise):
    it is integrated analytically, so p_A ∝ A^(1 − s0) near 0. `orbits.amplitude` must be log-spaced.
    """
    check_estimator(estimator)
    amp = orbits.amplitude
    s = jnp.log(amp)
    s0 = jnp.asarray(singular, dtype=float)
    regular = (2 * orbits.dissipation * orbits.restoring / sigma_h2 - s0 / amp) * amp
    psi = _cumulative(s, regular, 1.0)[0]
    nu0 = 1 - s0
    log_unnorm = nu0 * s - psi + jnp.log(orbits.period * orbits.restoring / amp)
    if estimator == "zero_crossing":
        log_unnorm = log_unnorm - jnp.log(orbits.period)
    out = _build_pdf(s, log_unnorm, nu0, jnp.asarray(exists), dict(parameters or {}), method, estimator)
    return _with_parameters(
        out, density_at_top_per_degree=out.density[-1] * jnp.pi / 180, period_at_top=orbits.period[-1]
    )


@filter_jit
def _esam(ship, spectrum, estimator, mean_shift, num, max_amplitude, num_theta, num_harmonics, moment=None):
    rc = roberts_coefficients(ship, spectrum, mean_shift=mean_shift)
    shift = spectrum.mean if mean_shift else jnp.zeros(())
    a_eff = _restoring_poly(ship, shift)
    top, bounded = _nonlinear_domain(ship, a_eff, rc, max_amplitude)
    exists = _existence(rc.nu, bounded, rc.c2, rc.c3)
    orbits = undamped_orbits(
        a_eff, ship.damping, jnp.exp(_log_grid(top, num)), num_theta=num_theta, num_harmonics=num_harmonics
    )
    sigma_h2 = parametric_energy_diffusion(orbits, spectrum)
    s0 = jnp.where(exists, ship.damping[0] / rc.k, 0.0)
    extra = {}
    if moment is not None:  # the additive moment keeps the roll alive (never dies out) and p ∝ A near 0
        sigma_h2 = sigma_h2 + moment_energy_diffusion(orbits, moment)
        # p ∝ A^{1 − b1/K} at large A where the parametric diffusion dominates: normalisable for ν < −1 too
        exists = _existence(jnp.zeros(()), bounded, rc.c2, rc.c3) | (rc.nu < -1)
        s0 = jnp.zeros(())
        extra = {"S_M_at_omega": moment.spectrum(rc.omega)}
    parameters = {
        "nu": rc.nu,
        "c2": rc.c2,
        "c3": rc.c3,
        "K": rc.k,
        "b1": ship.damping[0],
        "omega": rc.omega,
        "mean_stiffness_shift": shift,
        "S_P_at_2omega": spectrum(2 * rc.omega),
        "lyapunov_exponent": rc.lyapunov_exponent,
        **extra,
    }
    return energy_averaged_pdf(
        orbits, sigma_h2, s0, estimator=estimator, exists=exists, parameters=parameters
    )


def esam_pdf(
    ship: Ship,
    wave: EffectiveWave | ParametricSpectrum,
    *,
    estimator: str = "envelope",
    mean_shift: bool = True,
    num: int = 2049,
    max_amplitude: float | None = None,
    num_theta: int = 256,
    num_harmonics: int = 6,
    throw: bool = True,
    moment=None,
) -> AveragedAmplitudeLaw:
    r"""Energy-based stochastic averaging (ESAM): stationary roll-amplitude PDF with the full nonlinear restoring.

    H = φ̇²/2 + G(φ), G' = g (the ship's GZ polynomial, plus E[P]φ with `mean_shift`); on each undamped orbit the
    period T(H), the Fourier coefficients d_m(H) of φ² and ⟨φ̇b⟩(H) are computed numerically (`undamped_orbits`);
    σ_H² = (π/8) Σ m²Ω²d_m² S_P⁺(mΩ); p_H ∝ T exp(−∫2⟨φ̇b⟩/σ_H²).

    The support ends at the top of the potential well (the calm-water vanishing angle, where the Monte Carlo
    declares capsize): the true process leaks over it, so the PDF is the quasi-stationary law conditioned on
    no capsize, like the Monte Carlo's statistics of surviving trials (docs/theory.md). A restoring that never
    vanishes is cut where Roberts' linear law is negligible (at most π), or at `max_amplitude` [rad].

    **Arguments:** as `roberts_pdf`; `num_theta`: θ points per orbit; `num_harmonics`: d_2 … d_{2·num}.
    `moment`: the direct wave moment M_w (`problem.moment_excitation`, a `WaveMomentExcitation`: its one-sided
    spectrum S_M⁺(ω_e) [rad²/s³]) acting with the parametric term: its energy diffusion π S_M⁺(Ω)⟨φ̇²⟩
    (`moment_energy_diffusion`) adds to the parametric one (the cross terms of M_w at Ω and P at 2Ω average out),
    so p ∝ A near 0 and the law exists whatever K. It holds where the roll is resonant — the moment's energy near
    ω0 makes the roll, not the quasi-static following of shorter waves, which averaging leaves out
    (docs/theory.md §8). A ship carrying a moment at an oblique or beam heading without `moment` is refused.

    **Returns:** `AveragedAmplitudeLaw` (`method="esam"`; with `moment`, `parameters["S_M_at_omega"]`).
    """
    if moment is None:
        refuse_wave_moment(ship, wave, "esam")
    require_float64("jaxroll.theory.esam_pdf")
    check_estimator(estimator)
    spectrum = _as_spectrum(ship, wave)
    out = _esam(ship, spectrum, estimator, mean_shift, num, max_amplitude, num_theta, num_harmonics, moment)
    return _finish(out, throw)


@filter_jit
def _esam_additive(ship, intensity, estimator, num, max_amplitude, num_theta):
    a = ship.restoring_coefficients
    top, bounded = _well_top(ship, a)
    top = jnp.where(bounded, top, jnp.pi)
    if max_amplitude is not None:
        top = jnp.minimum(top, jnp.asarray(max_amplitude, dtype=float))
    orbits = undamped_orbits(
        a, ship.damping, jnp.exp(_log_grid(top, num)), num_theta=num_theta, num_harmonics=1
    )
    sigma_h2 = additive_energy_diffusion(orbits, intensity)
    parameters = {
        "intensity": jnp.asarray(intensity, dtype=float),
        "b1": ship.damping[0],
        "nu": jnp.ones(()),
        "K": jnp.full((), jnp.inf),
    }
    return energy_averaged_pdf(
        orbits, sigma_h2, 0.0, estimator=estimator, exists=True, parameters=parameters, method="esam_additive"
    )


def esam_additive_pdf(
    ship: Ship,
    intensity: ArrayLike,
    *,
    estimator: str = "envelope",
    num: int = 2049,
    max_amplitude: float | None = None,
    num_theta: int = 256,
) -> AveragedAmplitudeLaw:
    r"""ESAM for an additive white roll moment: φ̈ + b(φ̇) + g(φ) = W(t), E[W(t)W(t+τ)] = D δ(τ).

    The same core as `esam_pdf` with σ_H² = D⟨φ̇²⟩. For linear damping it reproduces Caughey's exact law
    p(φ, φ̇) ∝ exp(−2b1 H/D) (conditioned on the potential well when the restoring softens). `intensity`: D
    [1/s³]. The ship's ΔGM is ignored.
    """
    require_float64("jaxroll.theory.esam_additive_pdf")
    check_estimator(estimator)
    return _esam_additive(ship, intensity, estimator, num, max_amplitude, num_theta)
