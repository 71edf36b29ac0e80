"""Coloured-noise averaging of parametric roll: the envelope Fokker–Planck method ("envelope FPK").

Roberts and ESAM average the roll over its fast phase *and* replace the excitation by white noise. Here only the
first step is taken: the excitation's slowly varying complex envelope is kept as a Markov state, so its
correlation time (≈ 12 s, half a roll period, on the default ship) is not lost. With φ = Re[u e^{iωt}],
ω = ω_l = √(ω0² + E[P]), and ζ_mid = σ Re[X e^{2iωt}] (X the complex envelope of ζ_mid/σ about the carrier 2ω,
E|X|² = 2), first-order (Krylov–Bogoliubov) averaging of φ̈ + b(φ̇) + g(φ) + P(t)φ = 0 gives, with a = |u|,

    u̇ = −δ(a) u + i (Ω(a)² + P_s(|X|) − ω²)/(2ω) u + i W(X) ū/(4ω),
    δ(a) = b1/2 + 4 b2 ω a/(3π) + 3 b3 ω² a²/8,   Ω(a)² = a1 + ¾a3a² + ⅝a5a⁴ + 35/64 a7a⁶ + 63/128 a9a⁸,
    W = r κ · (first θ-harmonic of ΔGM(σ|X| cos θ)) e^{i arg X},   P_s = r κ ⟨ΔGM(σ|X| cos θ)⟩_θ,

ΔGM expanded in Hermite polynomials (`hermite_coefficients`). X is modelled as a complex Ornstein–Uhlenbeck
process whose Lorentzian matches the true envelope correlation in ∫R dτ and ∫τR dτ (`fit_envelope`; the resonant
level S(2ω) — the white-noise limit — is exact). In polar form (X = ρe^{iχ}, u = a e^{iψ}, θ = χ − 2ψ, s = ln a)
the reduced system is Markov in (s, ρ, θ) (Itô):

    ṡ  = −δ(a) − w(ρ) sin θ/(4ω),
    dρ = γ(1/ρ − ρ) dt + √(2γ) dB1,
    dθ = [Δ − 2ν(a, ρ) − w(ρ) cos θ/(2ω)] dt + (√(2γ)/ρ) dB2,   ν = (Ω(a)² + P_s(ρ) − ω²)/(2ω).

The Lorentzian misses the sea's level away from 2ω, where a roll of other amplitude or in another wave group locks
on: w is scaled by √(S̄/L̄), the sea's S_G and the Lorentzian averaged over the band the roll locks to,
2(ω + ν(a, ρ)) ± E|w|/(2ω) (`_resonant_level`; issue 42). Its stationary Fokker–Planck equation is solved by finite
volumes: the exact Rayleigh equilibrium flux in ρ, Scharfetter–Gummel (exponentially fitted) fluxes in θ, upwind
fluxes in s with defect corrections to second order, reflecting ends (the top is the vanishing angle), and a block-tridiagonal direct solve over the s slices
(block-Thomas in `lax.scan`: no iteration, no tolerance, differentiable). The envelope (time-sampled) law is the
s-marginal; the zero-crossing (per half cycle) law weights it by the half-cycle rate (ω + ψ̇)/π,
ψ̇ = ν + w cos θ/(4ω). The Lyapunov exponent of the linearised roll is Khasminskii's E_π[ṡ] on the a → 0 slice,
and in the averaged model E[A] = λ/c (c = 4 b2 ω/3π, b3 = 0) when the phase dynamics does not depend on a.

Derivation, validation against the Monte Carlo and limitations: docs/theory.md, section "Envelope Fokker–Planck".

Literature: J. B. Roberts (1982), stochastic averaging of parametric roll (the white-noise limit, γ → ∞);
R. L. Stratonovich, *Topics in the Theory of Random Noise* (complex envelope, averaging); R. Z. Khasminskii
(1967) (Lyapunov exponent from the projected invariant measure); D. L. Scharfetter & H. K. Gummel (1969), IEEE
Trans. Electron Devices 16 (exponentially fitted fluxes); Maki et al., arXiv 2309.07126 (stochastic stability of
parametric roll under white and coloured excitation); Mohamad & Sapsis, arXiv 1706.00109 (Mathieu equation
under correlated excitation: intermittent resonance missed by white-noise averaging); C. Floris (2012),
Math. Probl. Eng. 375913 (averaging for coloured parametric excitation); Katsumura et al., arXiv 2407.02728.
"""

from __future__ import annotations

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._compiled import filter_jit
from .._config import require_float64
from ..laws._abstract import check_estimator
from ..ship._restoring import vanishing_angle
from ..ship._ship import Ship
from ._envelope_fpk_law import EnvelopeExcitation, EnvelopeFPKLaw
from ._excitation import hermite_coefficients
from ._linear import refuse_wave_moment

_NUM_H = 7  # Hermite coefficients h_0 … h_6 of ΔGM


def _hermite_harmonics(num_theta: int = 32):
    """Mean and first cosine harmonic over θ of He_n(ρ cos θ), as polynomial coefficients in ρ: `(mean, first)`,
    each [n, k] (n = 0 … 6, power k = 0 … 6). Exact for these degrees (the θ-quadrature is exact up to 31)."""
    th = 2 * np.pi * np.arange(num_theta) / num_theta
    mean = np.zeros((_NUM_H, _NUM_H))
    first = np.zeros((_NUM_H, _NUM_H))
    for n in range(_NUM_H):
        for k, c in enumerate(np.polynomial.hermite_e.herme2poly([0] * n + [1])):
            mean[n, k] += c * np.mean(np.cos(th) ** k)
            first[n, k] += c * 2 * np.mean(np.cos(th) ** (k + 1))
    return mean, first


_MEAN, _FIRST = _hermite_harmonics()


# ------------------------------------------------------------------------------------------------------------
# The excitation envelope
# ------------------------------------------------------------------------------------------------------------


def fit_envelope(
    wave, omega, *, w_max: float = 2.0, num_w: int = 801, tau_max: float = 250.0, num_tau: int = 801
) -> EnvelopeExcitation:
    """Complex-OU envelope matched to the sea about the carrier 2ω.

    **Arguments:** `wave`: anything with `.spectrum(ω)`, the one-sided spectrum of ζ_G [m² s/rad] in encounter
    frequency (a `jaxroll.EffectiveWave` or a fitted shaping filter); `omega` ω [rad/s] (half the carrier);
    quadrature: frequencies on [0, `w_max`] rad/s (`num_w` points), lags on [0, `tau_max`] s (`num_tau`).

    The envelope correlation R_X(τ) = 2∫S(ω') e^{i(ω'−2ω)τ} dω'/σ² and the OU's 2v e^{(−γ+iΔ)τ} are matched
    in I0 = ∫₀^∞R dτ and I1 = ∫₀^∞τR dτ: γ − iΔ = I0/I1; v from Re I0 = 2π S(2ω)/σ² (the white-noise level).

    **Returns:** `EnvelopeExcitation` (γ [1/s], Δ [rad/s], v, σ [m], ω [rad/s]).
    """
    w = jnp.linspace(0.0, w_max, num_w)
    s = wave.spectrum(w).at[0].set(0.0)
    dw = w[1] - w[0]
    var = jnp.sum(s) * dw - (s[0] + s[-1]) * dw / 2
    sn = s / var
    wc = 2 * omega
    tau = jnp.linspace(0.0, tau_max, num_tau)
    dt = tau[1] - tau[0]
    # R_X(τ) = e^{−i 2ω τ} · 2∫S(ω') e^{iω'τ}dω'/σ²: the (τ, ω') matrices do not depend on the sea or on ω (under
    # vmap over sea states they are computed once per batch; the screen of `jaxroll longterm`: 16 → <1 ms a sea)
    wt = w[None, :] * tau[:, None]
    c_sea, s_sea = 2 * (jnp.cos(wt) @ sn) * dw, 2 * (jnp.sin(wt) @ sn) * dw
    c_rot, s_rot = jnp.cos(wc * tau), jnp.sin(wc * tau)
    r_re = c_sea * c_rot + s_sea * s_rot  # R_X(τ) = r_re + i r_im (real arithmetic throughout)
    r_im = s_sea * c_rot - c_sea * s_rot
    trap = jnp.ones(num_tau).at[0].set(0.5).at[-1].set(0.5) * dt
    i0_re, i0_im = jnp.sum(trap * r_re), jnp.sum(trap * r_im)
    i1_re, i1_im = jnp.sum(trap * tau * r_re), jnp.sum(trap * tau * r_im)
    den = i1_re**2 + i1_im**2  # γ − iΔ = I0/I1
    gamma = (i0_re * i1_re + i0_im * i1_im) / den
    shift = -(i0_im * i1_re - i0_re * i1_im) / den
    s_c = jnp.interp(wc, w, sn)
    v = 2 * jnp.pi * s_c * (gamma**2 + shift**2) / (2 * gamma)
    return EnvelopeExcitation(gamma, shift, v, jnp.sqrt(var), jnp.asarray(omega, dtype=float))


# ------------------------------------------------------------------------------------------------------------
# The reduced (s, ρ, θ) Fokker–Planck operator
# ------------------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class _Grid:
    """Finite-volume grid (static): `num_s` fine log-amplitude cells on [a_fine, vanishing angle],
    `num_s_coarse` below down to `a_min` [rad]; `num_rho` × `num_theta` cells for ρ ∈ [0, rho_max] and θ."""

    num_s: int = 60
    num_s_coarse: int = 10
    num_rho: int = 12
    num_theta: int = 20
    rho_max: float = 5.5
    a_fine: float = math.radians(0.5)
    a_min: float = math.radians(1e-4)
    num_corrections: int = 4

    def record(self) -> tuple:
        return tuple((k, v) for k, v in dataclasses.asdict(self).items())


class _Model(eqx.Module):
    """Coefficients and the discretised pieces of the reduced system (everything the solves need; the amplitude
    grid's fields, se … i_norm, are None in the (ρ, θ)-only model that λ needs)."""

    omega: jax.Array
    b1: jax.Array
    se: jax.Array  # s edges [ns+1]
    sc: jax.Array  # s centres [ns]
    ds: jax.Array  # s widths [ns]
    rho: jax.Array  # ρ centres [nρ]
    th: jax.Array  # θ centres [nθ]
    xi: jax.Array  # ṡ from the excitation at the (ρ, θ) centres [m]
    wr: jax.Array  # w(ρ) [1/s²]
    level: jax.Array  # √(S̄/L̄) at the slice centres [ns, nρ] (`_resonant_level`; None without amplitudes)
    level0: jax.Array  # the same at a → 0 [nρ]
    ps_dev: jax.Array  # P_s(ρ) − E[P] [1/s²]
    shift: jax.Array
    l_rho: jax.Array  # ρ operator ⊗ I_θ [m, m]
    theta_diffusion: jax.Array  # γ/ρ² [nρ]
    restoring: jax.Array  # a1 + E[P] = ω², a3 … a9
    lower: jax.Array  # s coupling to slice i−1 [ns, m]
    upper: jax.Array  # s coupling to slice i+1 [ns, m]
    diag_s: jax.Array  # s outflow [ns, m]
    vp: jax.Array  # positive part of the s velocity at the faces [ns+1, m]
    vm: jax.Array  # negative part
    i_norm: jax.Array  # slice of the normalisation row
    grid: _Grid = eqx.field(static=True)

    @property
    def k_norm(self) -> int:
        """(ρ ≈ 1.4, first θ) cell of the normalisation row."""
        return int(1.4 / self.grid.rho_max * self.grid.num_rho) * self.grid.num_theta

    @property
    def m(self) -> int:
        return self.grid.num_rho * self.grid.num_theta


def _delta(ship: Ship, omega, a):
    """Averaged damping rate δ(a) [1/s]."""
    b1, b2, b3 = ship.damping[0], ship.damping[1], ship.damping[2]
    return b1 / 2 + 4 * b2 * omega * a / (3 * jnp.pi) + 3 * b3 * omega**2 * a**2 / 8


def _detune(restoring, omega, a):
    """(Ω(a)² − ω²)/(2ω) [rad/s], Ω(a) the harmonic-balance frequency of the GZ curve."""
    a2 = a * a
    om2 = restoring[0] + a2 * (
        0.75 * restoring[1]
        + a2 * (0.625 * restoring[2] + a2 * (35 / 64 * restoring[3] + a2 * 63 / 128 * restoring[4]))
    )
    return (om2 - omega**2) / (2 * omega)


def _linear_frequency(ship: Ship, wave):
    """(r κ [1/s² per m], Hermite coefficients h [m], ω_l [rad/s]) from ζ_G's spectrum (σ² by a Riemann sum)."""
    scale = ship.gm_correction * ship.omega0**2 / ship.gm0
    w = jnp.linspace(0.0, 3.0, 3001)
    sg = wave.spectrum(w).at[0].set(0.0)
    sigma = jnp.sqrt(jnp.sum(sg) * (w[1] - w[0]))
    h = hermite_coefficients(ship.delta_gm, sigma)  # in powers of ζ_mid/σ (the sign of odd h is irrelevant)
    omega = jnp.sqrt(ship.omega0**2 + scale * h[0])
    return scale, h, omega


def _resonant_level(wave, exc: EnvelopeExcitation, restoring, omega, a, ps_dev, wr, rho):
    """Factor [-] on the coupling w(ρ) at amplitudes a [rad], shape [n_a, nρ]: √(S̄/L̄), with S̄ the sea's S_G and L̄
    the fitted Lorentzian, each averaged over the band the roll locks to — centred on the roll's own excitation
    frequency 2(ω + ν(a, ρ)), half-width b = E|w(ρ)|/(2ω) (the θ equation's locking range at the envelope's
    Rayleigh mean) — and each relative to its level at 2ω (where the fit makes the two equal). The Lorentzian keeps
    the envelope's correlation time; the factor puts the sea's own spectrum where the roll feeds on it
    (docs/theory.md §6, "The resonant level over the locking band")."""
    x = 2 * omega + 2 * _detune(restoring, omega, a)[:, None] + ps_dev[None, :] / omega
    rayleigh = rho * jnp.exp(-(rho**2) / 2)
    half = jnp.sum(rayleigh * jnp.abs(wr)) / jnp.sum(rayleigh) / (2 * omega)
    y = x[..., None] + half * jnp.linspace(-1.0, 1.0, _BAND_POINTS)
    carrier = 2 * omega
    s = wave.spectrum(jnp.concatenate([y.ravel(), carrier[None]]))
    sea = jnp.mean(s[:-1].reshape(y.shape), axis=-1) / jnp.where(s[-1] > 0, s[-1], 1.0)
    lorentz = jnp.mean(
        (exc.gamma**2 + exc.shift**2) / (exc.gamma**2 + (y - carrier - exc.shift) ** 2), axis=-1
    )
    return jnp.where(s[-1] > 0, jnp.sqrt(sea / lorentz), 1.0)


_BAND_POINTS = 17  # the band's mean by 17 equally spaced points


def _amplitude_edges(a_top, grid: _Grid, snap: tuple = ()):
    """s = ln a edges: coarse cells on [a_min, a_fine], fine ones on [a_fine, a_top]; `snap`: static pairs
    (index into the fine edges, s) that move those edges onto given levels (`_envelope_fpk_passage`)."""
    fine = jnp.linspace(jnp.log(grid.a_fine), jnp.log(a_top), grid.num_s + 1)
    for index, level in snap:
        fine = fine.at[index].set(level)
    coarse = jnp.linspace(math.log(grid.a_min), math.log(grid.a_fine), grid.num_s_coarse + 1)[:-1]
    return jnp.concatenate([coarse, fine])


def _build_model(
    ship: Ship,
    scale,
    h,
    omega,
    exc: EnvelopeExcitation,
    wave,
    grid: _Grid,
    amplitude: bool = True,
    absorbing_top: bool = False,
    snap: tuple = (),
) -> _Model:
    """The reduced system on `grid`; `amplitude=False`: the (ρ, θ) pieces only, which λ needs (`_lyapunov`), with
    the amplitude grid's fields None (no vanishing angle, no s operators: a smaller program to trace).
    `absorbing_top`: the top face (the vanishing angle) lets mass out (capsize) instead of reflecting it: the
    first-passage problems (`_envelope_fpk_passage.py`) use it; the stationary law needs the reflecting end.
    `snap`: fine-grid edges moved onto given levels (`_amplitude_edges`)."""
    nr, nt = grid.num_rho, grid.num_theta
    # excitation harmonics of the unit-variance envelope; the linear coupling scaled by √v (resonant level exact)
    hn = h.at[1].multiply(jnp.sqrt(exc.variance))
    drho = grid.rho_max / nr
    rho = (jnp.arange(nr, dtype=float) + 0.5) * drho
    powers = rho[:, None] ** jnp.arange(_NUM_H, dtype=float)
    wr = scale * jnp.sum(hn[:, None] * jnp.asarray(_FIRST) * powers[:, None, :], axis=(-1, -2))
    ps_dev = scale * jnp.sum(h[2:, None] * jnp.asarray(_MEAN)[2:] * powers[:, None, :], axis=(-1, -2))
    dth = 2 * jnp.pi / nt
    th = (jnp.arange(nt, dtype=float) + 0.5) * dth
    xi = (-(wr[:, None] * jnp.sin(th)[None, :]) / (4 * omega)).reshape(-1)

    # ρ: flux J = −γ M ∂ρ(q/M), M = ρ e^{−ρ²/2} (the discrete ρ-marginal is exactly Rayleigh)
    rho_f = jnp.arange(1, nr, dtype=float) * drho
    mc = rho * jnp.exp(-(rho**2) / 2)
    mf = rho_f * jnp.exp(-(rho_f**2) / 2)
    kr = exc.gamma * mf / drho
    j = jnp.arange(nr - 1)
    lrho = jnp.zeros((nr, nr))
    lrho = lrho.at[j, j + 1].add(kr / mc[j + 1] / drho).at[j, j].add(-kr / mc[j] / drho)
    lrho = lrho.at[j + 1, j + 1].add(-kr / mc[j + 1] / drho).at[j + 1, j].add(kr / mc[j] / drho)

    # the mean stiffness E[P] = ω² − a1 is part of the roll's own frequency: ν = 0 at a = 0, mean ρ
    restoring = ship.restoring_coefficients.at[0].set(omega**2)
    phase = dict(
        omega=omega,
        b1=ship.damping[0],
        rho=rho,
        th=th,
        xi=xi,
        wr=wr,
        ps_dev=ps_dev,
        shift=exc.shift,
        l_rho=jnp.kron(lrho, jnp.eye(nt)),
        theta_diffusion=exc.gamma / rho**2,
        level0=_resonant_level(wave, exc, restoring, omega, jnp.zeros(1), ps_dev, wr, rho)[0],
        restoring=restoring,
        grid=grid,
    )
    if not amplitude:
        return _Model(
            **phase,
            **dict.fromkeys(("se", "sc", "ds", "lower", "upper", "diag_s", "vp", "vm", "i_norm", "level")),
        )
    # s: F_{i+1/2} = v⁺ q_i + v⁻ q_{i+1}, v = −δ(e^s) + ξ at the interior faces; zero at both ends (reflecting)
    se = _amplitude_edges(vanishing_angle(ship), grid, snap)
    sc = (se[1:] + se[:-1]) / 2
    ds = jnp.diff(se)
    level_f = _resonant_level(wave, exc, phase["restoring"], omega, jnp.exp(se), ps_dev, wr, rho)
    vf = -_delta(ship, omega, jnp.exp(se))[:, None] + jnp.repeat(level_f, nt, axis=1) * xi[None, :]
    vf = vf.at[0].set(0.0)
    vf = vf.at[-1].set(jnp.maximum(vf[-1], 0.0) if absorbing_top else 0.0)  # outflow only: nothing comes back
    vp, vm = jnp.maximum(vf, 0.0), jnp.minimum(vf, 0.0)
    return _Model(
        **phase,
        se=se,
        sc=sc,
        ds=ds,
        lower=vp[:-1] / ds[:, None],
        upper=-vm[1:] / ds[:, None],
        diag_s=(-vp[1:] + vm[:-1]) / ds[:, None],
        vp=vp,
        vm=vm,
        i_norm=jnp.argmin(jnp.abs(sc - math.log(math.radians(3.0)))),
        level=_resonant_level(wave, exc, phase["restoring"], omega, jnp.exp(sc), ps_dev, wr, rho),
    )


def _bernoulli(x):
    """B(x) = x/(eˣ − 1), stable at 0."""
    small = jnp.abs(x) < 1e-6
    xs = jnp.where(small, 1.0, x)
    return jnp.where(small, 1 - x / 2 + x * x / 12, xs / jnp.expm1(xs))


def _slice_operator(md: _Model, a, level=1.0):
    """m × m generator of the (ρ, θ) dynamics at amplitude a (θ drift depends on a through Ω(a)); `level`: the
    coupling's factor there (`_resonant_level`)."""
    nr, nt = md.grid.num_rho, md.grid.num_theta
    dth = 2 * jnp.pi / nt
    th_f = md.th + dth / 2
    mu = (
        md.shift
        - 2 * _detune(md.restoring, md.omega, a)
        - md.ps_dev[:, None] / md.omega
        - (level * md.wr)[:, None] * jnp.cos(th_f)[None, :] / (2 * md.omega)
    )
    dd = md.theta_diffusion[:, None]
    pe = mu * dth / dd
    # Scharfetter–Gummel: G_{k+1/2} = (D/Δθ)[B(−Pe) q_k − B(Pe) q_{k+1}];  dq_k/dt = −(G_{k+1/2} − G_{k−1/2})/Δθ
    c_from = (dd / dth**2 * _bernoulli(-pe)).ravel()
    c_to = (dd / dth**2 * _bernoulli(pe)).ravel()
    idx = jnp.arange(nr * nt).reshape(nr, nt)
    i0 = idx.ravel()
    i1 = idx[:, (jnp.arange(nt) + 1) % nt].ravel()
    op = md.l_rho.at[i0, i0].add(-c_from).at[i0, i1].add(c_to)
    return op.at[i1, i0].add(c_from).at[i1, i1].add(-c_to)


def _factorise(md: _Model, inv_dt, normalise: bool, killing=None):
    """Block-Thomas factors of (L₁ − I/Δt − diag(killing)) over the s slices (L₁: the first-order operator;
    `killing` [ns, m] a rate [1/s] at which mass is removed, or None); with `normalise` one row of the stationary
    (singular) system is replaced by the normalisation q[i_norm, k_norm] = 1."""
    _, factors = _factorise_slices(md, inv_dt, normalise, killing, 0, md.sc.shape[0], jnp.zeros((md.m, md.m)))
    return factors


def _factorise_slices(md: _Model, inv_dt, normalise: bool, killing, first: int, stop: int, g_first):
    """`_factorise` of the slices first … stop − 1 only (static), the elimination carried in from slice
    first − 1 as `g_first` (G_{first−1}; zeros at the bottom). Returns (G_{stop−1}, factors). Elimination runs
    from the bottom, so slice i's factors depend on the rows up to i only: systems that differ above a slice
    share the factors below it (`_envelope_fpk_passage`)."""
    m, k_norm = md.m, md.k_norm
    e_norm = jnp.zeros(m).at[k_norm].set(1.0)
    kill = jnp.zeros((md.sc.shape[0], m)) if killing is None else killing

    def factor(g_prev, i):
        b = _slice_operator(md, jnp.exp(md.sc[i]), md.level[i]) + jnp.diag(md.diag_s[i] - inv_dt - kill[i])
        lo, up = md.lower[i], md.upper[i]
        if normalise:
            is_norm = i == md.i_norm
            b = jnp.where(is_norm, b.at[k_norm].set(e_norm), b)
            lo = jnp.where(is_norm, lo.at[k_norm].set(0.0), lo)
            up = jnp.where(is_norm, up.at[k_norm].set(0.0), up)
        # S_i = B_i − diag(lo_i) G_{i−1},  G_i = S_i⁻¹ diag(up_i). S_i⁻¹ is stored, not its LU factors: each sweep
        # of a solve is then matrix-vector products (no triangular solves, no LAPACK call per slice and sweep;
        # the passage's inverse iteration sweeps each factorisation 2 × num_iterations times). −S_i is a
        # nonsingular M-matrix, diagonally dominant by columns (a generator's block less outflow), so its inverse
        # is as well conditioned as the block.
        s_inv = jnp.linalg.inv(b - lo[:, None] * g_prev)
        return s_inv * up[None, :], (s_inv, lo, up)

    return jax.lax.scan(factor, g_first, jnp.arange(first, stop))


def _solve(md: _Model, factors, rhs):
    """Solve the block-tridiagonal system with `factors` for the right-hand side rhs [ns, m]."""
    inverses, los, ups = factors  # S_i⁻¹, the couplings to slices i − 1 and i + 1

    def forward(y_prev, inp):
        s_inv, lo, r = inp
        y = s_inv @ (r - lo * y_prev)
        return y, y

    _, ys = jax.lax.scan(forward, jnp.zeros(md.m), (inverses, los, rhs))

    def backward(q_next, inp):
        s_inv, up, y = inp
        q = y - s_inv @ (up * q_next)  # q_i = y_i − G_i q_{i+1}
        return q, q

    _, qs = jax.lax.scan(backward, jnp.zeros(md.m), (inverses, ups, ys), reverse=True)
    return qs


def _s_divergence(md: _Model, q, order: int):
    """−(F_{i+1/2} − F_{i−1/2})/Δs_i with first-order (upwind) or second-order (linear-upwind) face values."""
    se, c = md.se, md.sc
    if order == 1:
        qf_p = q
        qf_m = jnp.concatenate([q[1:], q[-1:]])
    else:
        qm1 = jnp.concatenate([q[:1], q[:-1]])
        cm1 = jnp.concatenate([c[:1] - 1.0, c[:-1]])
        slope_l = ((q - qm1) / (c - cm1)[:, None]).at[0].set(0.0)
        qf_p = q + slope_l * (se[1:, None] - c[:, None])
        qp1 = jnp.concatenate([q[1:], q[-1:]])
        qp2 = jnp.concatenate([q[2:], q[-1:], q[-1:]])
        cp1 = jnp.concatenate([c[1:], c[-1:] + 1.0])
        cp2 = jnp.concatenate([c[2:], c[-1:] + 2.0, c[-1:] + 3.0])
        slope_r = ((qp2 - qp1) / (cp2 - cp1)[:, None]).at[-2:].set(0.0)
        qf_m = qp1 + slope_r * (se[1:, None] - cp1[:, None])
    flux = md.vp[1:] * qf_p + md.vm[1:] * qf_m  # faces i+1/2 (the last is zero)
    flux_lo = jnp.concatenate([jnp.zeros((1, md.m)), flux[:-1]])
    return -(flux - flux_lo) / md.ds[:, None]


def _defect(md: _Model, q):
    return _s_divergence(md, q, 2) - _s_divergence(md, q, 1)


def _stationary(md: _Model):
    """Stationary density q [ns, m] (per unit s, ρ, θ; unnormalised)."""
    ns, m = md.sc.shape[0], md.m
    factors = _factorise(md, 0.0, True)
    rhs0 = jnp.zeros((ns, m)).at[md.i_norm, md.k_norm].set(1.0)
    norm_mask = jnp.ones((ns, m)).at[md.i_norm, md.k_norm].set(0.0)
    qs = _solve(md, factors, rhs0)
    for _ in range(md.grid.num_corrections):  # defect correction towards the second-order s fluxes
        qs = _solve(md, factors, rhs0 - _defect(md, qs) * norm_mask)
    return qs


def _protocol(md: _Model, a0, duration: float, discard: float, time_step: float):
    """Time average over (discard, duration] of the density started at a0 (φ̇ = 0: θ uniform, ρ Rayleigh),
    marched by backward Euler with one factorisation (the Monte Carlo protocol)."""
    ns, m = md.sc.shape[0], md.m
    nr, nt = md.grid.num_rho, md.grid.num_theta
    drho = md.grid.rho_max / nr
    factors = _factorise(md, 1.0 / time_step, False)
    i0 = jnp.argmin(jnp.abs(md.sc - jnp.log(a0)))
    m_rho = md.rho * jnp.exp(-(md.rho**2) / 2)
    m_rho = m_rho / (jnp.sum(m_rho) * drho)
    q0 = jnp.zeros((ns, m)).at[i0].set(jnp.repeat(m_rho, nt) / (2 * jnp.pi) / md.ds[i0])
    n_steps = int(round(duration / time_step))
    n_skip = int(round(discard / time_step))

    def step(carry, n):
        q, acc = carry
        qn = _solve(md, factors, -q / time_step)
        for _ in range(md.grid.num_corrections):
            qn = _solve(md, factors, -q / time_step - _defect(md, qn))
        acc = acc + jnp.where(n >= n_skip, 1.0, 0.0) * qn
        return (qn, acc), None

    (_, acc), _ = jax.lax.scan(step, (q0, jnp.zeros_like(q0)), jnp.arange(n_steps))
    return acc / (n_steps - n_skip)


def _lyapunov(md: _Model):
    """λ = E_π[ξ] − b1/2 [1/s], π the stationary law of (ρ, θ) at a → 0 (Khasminskii)."""
    e_norm = jnp.zeros(md.m).at[md.k_norm].set(1.0)
    l0 = _slice_operator(md, jnp.zeros(()), md.level0).at[md.k_norm].set(e_norm)
    pi = jnp.linalg.solve(l0, e_norm)
    xi = jnp.repeat(md.level0, md.grid.num_theta) * md.xi
    return jnp.sum(pi * xi) / jnp.sum(pi) - md.b1 / 2


def _cell_laws(md: _Model, qs):
    """Cell probabilities of the envelope law and of the zero-crossing law from the density q [ns, m]."""
    qs = jnp.maximum(qs, 0.0)  # round-off negatives far in the tails
    cells = qs * md.ds[:, None]
    cells = cells / jnp.sum(cells)
    mass_env = jnp.sum(cells, axis=1)
    # half-cycle rate ∝ ω + ψ̇,  ψ̇ = ν(a, ρ) + w cos θ/(4ω)
    psidot = _phase_velocity(md)
    zc = jnp.sum(cells * (md.omega + psidot), axis=1)
    return mass_env, zc / jnp.sum(zc)


def _phase_velocity(md: _Model):
    """ψ̇ = ν(a, ρ) + w cos θ/(4ω) [rad/s] in every cell [ns, m] (the averaged roll's phase velocity)."""
    psi = md.ps_dev[:, None, None] / (2 * md.omega) + md.level.T[:, :, None] * md.wr[:, None, None] * jnp.cos(
        md.th
    )[None, None, :] / (4 * md.omega)
    psi = jnp.moveaxis(psi, 1, 0).reshape(md.sc.shape[0], -1)  # [ns, nρ·nθ]
    return _detune(md.restoring, md.omega, jnp.exp(md.sc))[:, None] + psi


def _prepare(ship, wave, excitation, grid, amplitude=True):
    scale, h, omega = _linear_frequency(ship, wave)
    exc = fit_envelope(wave, omega) if excitation is None else excitation
    return _build_model(ship, scale, h, omega, exc, wave, grid, amplitude), exc


@filter_jit
def _envelope_fpk(ship, wave, excitation, grid: _Grid, protocol):
    md, exc = _prepare(ship, wave, excitation, grid)
    qs = _stationary(md) if protocol is None else _protocol(md, *protocol)
    mass_env, mass_zc = _cell_laws(md, qs)
    return jnp.exp(md.se), mass_env, mass_zc, _lyapunov(md), exc


@filter_jit
def _lyapunov_only(ship, wave, excitation, grid: _Grid):
    md, exc = _prepare(ship, wave, excitation, grid, amplitude=False)
    return _lyapunov(md), exc


# ------------------------------------------------------------------------------------------------------------
# Public entry points
# ------------------------------------------------------------------------------------------------------------

_DIES_OUT = (
    "envelope FPK: no sustained parametric roll: the Lyapunov exponent of the linearised roll under the "
    "coloured excitation is <= 0, so A → 0 almost surely (the stationary law is a point mass at 0), or undefined "
    "where the envelope model does not fit the sea (fitted decay rate γ <= 0). Increase H1/3 or r, or reduce "
    "b1; call with throw=False for the finite-grid law."
)


def _grid(num_s, num_s_coarse, num_rho, num_theta, rho_max, a_fine, a_min, num_corrections) -> _Grid:
    grid = _Grid(
        int(num_s),
        int(num_s_coarse),
        int(num_rho),
        int(num_theta),
        float(rho_max),
        float(a_fine),
        float(a_min),
        int(num_corrections),
    )
    if min(grid.num_s, grid.num_s_coarse) < 2 or grid.num_rho < 4 or grid.num_theta < 4:
        raise ValueError(
            f"envelope FPK grid too small: num_s = {grid.num_s}, num_s_coarse = {grid.num_s_coarse} (>= 2), "
            f"num_rho = {grid.num_rho}, num_theta = {grid.num_theta} (>= 4)."
        )
    if not (0 < grid.a_min < grid.a_fine and grid.rho_max > 0 and grid.num_corrections >= 0):
        raise ValueError(
            f"envelope FPK grid: need 0 < a_min < a_fine [rad], rho_max > 0 and num_corrections >= 0; got "
            f"a_min = {grid.a_min}, a_fine = {grid.a_fine}, rho_max = {grid.rho_max}, "
            f"num_corrections = {grid.num_corrections}."
        )
    return grid


def envelope_fpk_pdf(
    ship: Ship,
    wave,
    *,
    estimator: str = "envelope",
    excitation: EnvelopeExcitation | None = None,
    num_s: int = 60,
    num_s_coarse: int = 10,
    num_rho: int = 12,
    num_theta: int = 20,
    rho_max: float = 5.5,
    a_fine: float = math.radians(0.5),
    a_min: float = math.radians(1e-4),
    num_corrections: int = 4,
    duration: float | None = None,
    discard: float = 500.0,
    a0: float = math.radians(5.0),
    time_step: float = 10.0,
    throw: bool = True,
) -> EnvelopeFPKLaw:
    """Roll-amplitude law by coloured-noise averaging: the stationary envelope Fokker–Planck equation (module
    docstring; docs/theory.md).

    **Arguments:**

    - `ship`: the roll model (damping b1…b3, restoring a1…a9, ΔGM, r = `gm_correction`).
    - `wave`: anything with `.spectrum(ω)`, the one-sided spectrum of ζ_G [m² s/rad] in encounter frequency (a
      `jaxroll.EffectiveWave`, e.g. `problem.wave`).
    - `estimator`: `"envelope"` (time-sampled; compare with the Monte Carlo envelope PDF) or `"zero_crossing"`
      (per half cycle, weighted by the averaged model's own half-cycle rate; what the maxima formulas need).
    - `excitation`: an `EnvelopeExcitation` to use instead of `fit_envelope(wave, ω_l)`.
    - grid: `num_s` fine log-amplitude cells on [`a_fine`, vanishing angle] and `num_s_coarse` on [`a_min`,
      `a_fine`] (amplitudes in rad), `num_rho` × `num_theta` cells for the envelope modulus ρ ∈ [0, `rho_max`]
      and the relative phase θ; `num_corrections` defect-correction sweeps to second order in s.
    - `duration` [s]: None (default) for the stationary law; otherwise the law the Monte Carlo protocol samples:
      the time-dependent equation from A = `a0` [rad] (φ̇ = 0), averaged over (`discard`, `duration`] s, by
      backward Euler with `time_step` [s] (about 100× slower; it differs from the stationary law only near the
      threshold, where the roll's relaxation time 1/λ exceeds the run).
    - `throw`: raise when λ ≤ 0 (the roll dies out); with `throw=False` the finite-grid law is returned with
      `exists=False` (its mass then piles up in the bottom cell: read it as "no sustained roll").

    **Returns:** `EnvelopeFPKLaw` (an `AbstractAmplitudeLaw`; `details()` records the method, the fitted
    envelope, λ, the top-cell mass and the grid). jit-able and differentiable in the ship's and the sea's
    parameters (direct solve, no iteration).

    **Raises:** `ValueError` for bad arguments or (with `throw`) λ ≤ 0; `EquinoxRuntimeError` for the latter
    under `jit`/`grad`.
    """
    refuse_wave_moment(ship, wave, "envelope_fpk")
    require_float64("jaxroll.theory.envelope_fpk_pdf")
    check_estimator(estimator)
    grid = _grid(num_s, num_s_coarse, num_rho, num_theta, rho_max, a_fine, a_min, num_corrections)
    protocol = None
    method = "envelope_fpk"
    record = grid.record()
    if duration is not None:
        duration, discard, time_step = float(duration), float(discard), float(time_step)
        if not (time_step > 0 and 0 <= discard < duration and duration >= 2 * time_step):
            raise ValueError(
                "envelope FPK protocol: need time_step > 0, 0 <= discard < duration and duration >= 2 time_step; "
                f"got duration = {duration}, discard = {discard}, time_step = {time_step}."
            )
        protocol = (jnp.asarray(a0, dtype=float), duration, discard, time_step)
        method = "envelope_fpk_protocol"
        record = record + (
            ("duration_s", duration),
            ("discard_s", discard),
            ("time_step_s", time_step),
            ("a0_deg", math.degrees(float(a0))),
        )
    edges, mass_env, mass_zc, lyap, exc = _envelope_fpk(ship, wave, excitation, grid, protocol)
    mass = mass_env if estimator == "envelope" else mass_zc
    exists = lyap > 0
    if throw:
        if isinstance(exists, jax.core.Tracer):
            mass = eqx.error_if(mass, ~exists, _DIES_OUT)
        elif not bool(exists):
            raise dies_out_error(lyap, exc)
    return EnvelopeFPKLaw(
        edges=edges,
        mass=mass,
        lyapunov_exponent=lyap,
        mass_top_cell=mass[-1],
        excitation=exc,
        exists=exists,
        method=method,
        grid=record,
        estimator=estimator,
    )


def dies_out_error(lyapunov_exponent, excitation: EnvelopeExcitation) -> ValueError:
    """The error `envelope_fpk_pdf` raises (concrete inputs, `throw=True`) when λ ≤ 0: the roll dies out — or,
    where the envelope model does not fit the sea (fitted decay rate γ ≤ 0, λ undefined), that it cannot tell."""
    gamma = float(excitation.gamma)
    if not (gamma > 0 and math.isfinite(float(lyapunov_exponent))):
        return ValueError(
            f"envelope FPK: no law: the wave's envelope about the carrier 2ω = {2 * float(excitation.omega):.3g} "
            f"rad/s does not fit the method's Ornstein–Uhlenbeck model here (fitted decay rate γ = {gamma:.3g} 1/s, "
            "not > 0), so the Lyapunov exponent of the linearised roll is undefined. This happens where the "
            "effective wave has little energy near 2ω (e.g. following seas at speed, where encounter compresses "
            "the spectrum); Roberts' criterion (K against b1/2, `roberts_pdf`) still tells whether the roll is "
            "sustained."
        )
    return ValueError(
        f"envelope FPK: no sustained parametric roll: the Lyapunov exponent of the linearised roll is "
        f"λ = {float(lyapunov_exponent):.3g} 1/s <= 0 (coloured excitation, envelope correlation time "
        f"{1 / float(excitation.gamma):.3g} s), so A → 0 almost surely. Increase H1/3 or r, or reduce b1; "
        "throw=False returns the finite-grid law."
    )


def envelope_lyapunov_exponent(
    ship: Ship,
    wave,
    *,
    excitation: EnvelopeExcitation | None = None,
    num_rho: int = 12,
    num_theta: int = 20,
    rho_max: float = 5.5,
):
    """Lyapunov exponent λ [1/s] of the linearised roll under the coloured excitation (one (ρ, θ) solve).

    λ > 0: parametric roll is sustained (the stationary amplitude law exists); in the averaged model
    E[A] = λ/c with c = 4 b2 ω/(3π) when b3 = 0 and the phase dynamics does not depend on A. As γ → ∞ at a fixed
    resonant level it tends to Roberts' K − b1/2. Arguments as `envelope_fpk_pdf`.

    **Returns:** `(λ [1/s], EnvelopeExcitation)`.
    """
    require_float64("jaxroll.theory.envelope_lyapunov_exponent")
    grid = _grid(2, 2, num_rho, num_theta, rho_max, _Grid.a_fine, _Grid.a_min, 0)
    return _lyapunov_only(ship, wave, excitation, grid)
