r"""The direct wave moment in the roll a user runs (issue 44, item 1): ζ_G and M_w from the same wave components,
the ship carrying the moment (ship file, `jaxroll hydrostatics --wave-moment`), the exact linear answer, and the
theories that refuse it. Every statistical check has fixed seeds and a tolerance from its standard error."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest

from jaxroll import ITTC, RollProblem, SuperpositionExcitation, WaveMomentExcitation
from jaxroll.roll._excitation import _padded_length
from jaxroll.sea import grim_transfer
from jaxroll.sea._grim import superposition_length
from jaxroll.sea._spectra import encounter_branches
from jaxroll.ship import c11_hull, c11_hull_loading, c11_hull_ship, wave_moment

G = 9.80665


@pytest.fixture(scope="module")
def moment_ship():
    """The C11-like hull's ship carrying its Froude–Krylov moment (every 15°, ω to 4 rad/s)."""
    ship = c11_hull_ship()
    table = wave_moment(c11_hull(), c11_hull_loading(), ship, omega=np.linspace(0.0, 4.0, 401))
    return eqx.tree_at(lambda s: s.wave_moment, ship, table, is_leaf=lambda x: x is None)


def _exact_cross_covariance(wave, moment, lags, dt, size):
    r"""E[ζ_G(t) M_w(t + τ)] = Σ_b ∫ S(ω_b)/|dω_e/dω| Re[G_b conj(F_b) e^{−iω_e τ}] dω_e, F_b = F(ω_b, χ)/I44 (conj on
    branch 3), G_b = Grim's F(k_b|cos χ|) (real): each component's ζ_G = Re[G a e^{iω_e t}] and
    M_w = Re[F a e^{iω_e t}] with E|a|² = 2 S Δω, so E[ζ_G(t) M_w(t+τ)] = Re[G conj(F) e^{−iω_e τ}] S Δω.
    On the synthesis's own encounter frequencies (its discretisation: the sum is then exact)."""
    domega = 2 * np.pi / (size * dt)
    omega_e = np.arange(size // 2 + 1) * domega
    interior = (omega_e > 0) & (omega_e < omega_e[-1])
    projection = abs(float(wave.cos_heading))
    omegas, weights = (
        np.asarray(x) for x in encounter_branches(omega_e, float(moment.speed), moment.following)
    )
    out = np.zeros(len(lags))
    for b in range(3 if moment.following else 1):
        f = np.asarray(moment.transfer_at(omegas[:, b]))
        f = np.conj(f) if b == 2 else f
        g = np.asarray(grim_transfer(omegas[:, b] ** 2 / G * projection, float(wave.length)))
        s = np.where(interior & (weights[:, b] > 0), np.asarray(wave.sea(omegas[:, b])) * weights[:, b], 0.0)
        for i, tau in enumerate(lags):
            out[i] += np.sum(s * domega * np.real(g * np.conj(f) * np.exp(-1j * omega_e * tau)))
    return out


@pytest.mark.parametrize(
    ("heading", "speed"), [(2 * math.pi / 3, 6.0), (math.pi / 3, 3.0), (math.pi / 4, 0.0)]
)
def test_effective_wave_and_moment_are_one_realization(moment_ship, heading, speed):
    """`RollProblem.from_sea` with a ship carrying a moment: ζ_G and M_w of a realization from the same components,
    so their cross-covariance E[ζ_G(t) M_w(t + τ)] at lags 0, 3, 8 s is the sea's (the exact sum above), within
    3 standard errors of 40 records of 4000 s; ζ_G's variance is still σ_G²."""
    sea, dt, n = ITTC(3.0, 10.0), 0.25, 16000
    problem = RollProblem.from_sea(moment_ship, sea, speed=speed, heading=heading, dt=dt, phi0=0.0)
    assert isinstance(problem.excitation, SuperpositionExcitation) and problem.excitation.joint
    assert isinstance(problem.moment_excitation, WaveMomentExcitation)
    zsrc, msrc = problem.excitation, problem.moment_excitation

    def records(key):  # as `simulate` forms them: both sources get the realization's key
        return zsrc.init(key, n, 1, jnp.float64)[0][0], msrc.init(key, n, 1, jnp.float64)[0][0]

    zeta, mw = (np.asarray(r) for r in jax.jit(jax.vmap(records))(jr.split(jr.key(5), 40)))
    lags = (0.0, 3.0, 8.0)
    size = superposition_length(_padded_length(n, 1))  # the synthesis's FFT length
    want = _exact_cross_covariance(problem.wave, msrc, lags, dt, size)
    sigma = math.sqrt(float(problem.wave.variance()) * float(jnp.mean(mw**2)))
    for tau, w in zip(lags, want, strict=True):
        j = int(round(tau / dt))
        per = (zeta[:, : n - j] * mw[:, j:n]).mean(axis=1)
        se = per.std(ddof=1) / math.sqrt(per.size)
        print(
            f"χ {math.degrees(heading):.0f}°, U {speed}: τ {tau} s  MC {per.mean():.4g} ± {se:.2g}, exact {w:.4g}"
            f" (correlation {w / sigma:.3f})"
        )
        assert abs(per.mean() - w) < 3 * se + 1e-3 * sigma
    var = (zeta[:, :n] ** 2).mean(axis=1)
    assert (
        abs(var.mean() / float(problem.wave.variance()) - 1)
        < 3 * var.std(ddof=1) / math.sqrt(40) / var.mean() + 0.01
    )
