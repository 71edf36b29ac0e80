"""Stochastic averaging with the direct wave moment and the parametric term together (issue 44, item 5):
`esam_pdf(..., moment=)`. The white-moment limit is `esam_additive_pdf` exactly; the linear limit (beam seas: no
parametric term; linear restoring and damping) converges to the exact E[φ²] = ∫|H|²S_M as b1 → 0; against the Monte
Carlo of the C11-like hull at an oblique heading, the measured ratios of the envelope means (model error stated,
tolerance from the standard errors); the theories refuse a ship whose moment joins the roll without it."""

import math

import equinox as eqx
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest
from jaxtyping import Array, Float

import jaxroll as jxr
from jaxroll.ship import c11_hull, c11_hull_loading, c11_hull_ship, wave_moment
from jaxroll.theory import esam_additive_pdf, esam_pdf, linear_roll_variance, roberts_pdf


@pytest.fixture(scope="module")
def moment_ship():
    """The C11-like hull's ship carrying its Froude–Krylov moment (every 15°, ω to 4 rad/s)."""
    ship = c11_hull_ship()
    table = wave_moment(c11_hull(), c11_hull_loading(), ship, omega=np.linspace(0.0, 4.0, 201))
    return eqx.tree_at(lambda s: s.wave_moment, ship, table, is_leaf=lambda x: x is None)


class _WhiteMoment(eqx.Module):
    level: Float[Array, ""]

    def spectrum(self, omega):
        return jnp.full_like(jnp.asarray(omega, dtype=float), self.level)


def test_a_white_moment_is_esam_additive(moment_ship):
    """In beam seas (S_P = 0) a moment of flat one-sided spectrum S is the white moment of intensity D = π S."""
    ship = eqx.tree_at(lambda s: s.wave_moment, moment_ship, None, is_leaf=lambda x: x is None)
    wave = jxr.EffectiveWave(jxr.ITTC(3.0, 10.0), ship.lpp, 0.0, math.pi / 2)
    level = 2e-7
    law = esam_pdf(ship, wave, moment=_WhiteMoment(jnp.asarray(level)))
    white = esam_additive_pdf(ship, math.pi * level)
    a = np.asarray(white.amplitude[::97])
    np.testing.assert_allclose(np.asarray(law.pdf(a)), np.asarray(white.pdf(a)), rtol=1e-9)
    assert float(law.parameters["S_M_at_omega"]) == pytest.approx(level, rel=1e-15)


@pytest.mark.parametrize("t01", [20.0, 14.0])
def test_linear_limit_converges_to_the_spectral_integral(moment_ship, t01):
    """Beam seas, linear restoring, b2 = b3 = 0: E[φ²] = E[A²]/2 of the law against `linear_roll_variance`. The
    averaging takes S_M as white at ω0, so it is exact as b1 → 0: measured ratios at b1, b1/2, b1/4 (b1 = 0.0077
    1/s) 1.0438, 1.0218, 1.0109 (T01 20 s) and 0.846, 0.914, 0.954 (T01 14 s): the error halves with b1 and the
    Richardson limit (second order) is 1 to 1e-5 and 1.2e-3."""
    linear = eqx.tree_at(lambda s: s.restoring, moment_ship, jnp.zeros(4))
    b1 = float(moment_ship.damping[0])
    ratios = []
    for f in (1.0, 0.5, 0.25):
        ship = eqx.tree_at(lambda s: s.damping, linear, jnp.array([f * b1, 0.0, 0.0]))
        problem = jxr.RollProblem.from_sea(ship, jxr.ITTC(0.5, t01), heading=math.pi / 2, dt=0.25, phi0=0.0)
        law = esam_pdf(ship, problem.wave, moment=problem.moment_excitation)
        ratios.append(float(law.moment(2.0)) / 2 / float(linear_roll_variance(problem)))
    err = np.array(ratios) - 1
    assert abs(err[0]) > 0.03  # the default damping: off resonance matters
    assert np.all((err[:-1] / err[1:] > 1.6) & (err[:-1] / err[1:] < 2.2))  # first order in b1 (1.79–2.01)
    limit = (8 * ratios[2] - 6 * ratios[1] + ratios[0]) / 3  # Richardson, to second order
    assert abs(limit - 1) < 2e-3  # measured 1.00001 (20 s), 0.9988 (14 s)


# (heading [deg], T01 [s], H1/3 [m]) → ESAM envelope mean / Monte Carlo's, measured with 2000 trials (key 17) of
# 2400 s, 1200 s discarded, from rest, dt 0.25 s: 1.5921° / (1.3567 ± 0.0115)° and 0.9459° / (0.9961 ± 0.0054)°.
MEASURED = {(150.0, 12.0, 7.0): 1.174, (150.0, 13.0, 5.0): 0.950}


@pytest.mark.parametrize("case", list(MEASURED))
def test_against_the_monte_carlo_at_an_oblique_heading(moment_ship, case):
    """Both excitations matter at 150°, T01 12 s, H1/3 7 m (the parametric-only ESAM: 0.31°, the combined 1.59°,
    the Monte Carlo 1.36°); at 13 s, 5 m the roll dies out without the moment (K < b1/2). The averaged law is 17 %
    high where the parametric term is strong (as without the moment: docs/theory.md §4) and 5 % low where the
    moment drives it (the roll's quasi-static following of shorter waves is not in it)."""
    chi, t01, hs = case
    problem = jxr.RollProblem.from_sea(
        moment_ship, jxr.ITTC(hs, t01), heading=math.radians(chi), dt=0.25, phi0=0.0
    )
    law = esam_pdf(moment_ship, problem.wave, moment=problem.moment_excitation)
    stats = jxr.monte_carlo_amplitudes(
        problem, jr.key(5), num_realizations=300, duration=2400.0, discard=1200.0
    )
    pr = stats.per_realization
    ok = pr["n_env"] > 0
    per = np.rad2deg(pr["sum_env"][ok] / pr["n_env"][ok])
    mc, se = np.rad2deg(stats.mean("envelope")), per.std(ddof=1) / math.sqrt(ok.sum())
    ratio = math.degrees(float(law.mean())) / mc
    assert abs(ratio - MEASURED[case]) < MEASURED[case] * (4 * se / mc + 0.03)
    if case == (150.0, 12.0, 7.0):
        stripped = eqx.tree_at(lambda s: s.wave_moment, moment_ship, None, is_leaf=lambda x: x is None)
        assert math.degrees(float(esam_pdf(stripped, problem.wave).mean())) < 0.4 * mc


def test_without_the_moment_the_theories_refuse(moment_ship):
    wave = jxr.EffectiveWave(jxr.ITTC(7.0, 12.0), moment_ship.lpp, 0.0, math.radians(150.0))
    for fn, name in ((esam_pdf, "esam"), (roberts_pdf, "roberts")):
        with pytest.raises(ValueError, match=f"{name}: the ship carries a direct wave moment"):
            fn(moment_ship, wave)
