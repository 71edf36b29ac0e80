"""The envelope Fokker–Planck method (coloured-noise averaging, `jaxroll.theory.envelope_fpk_pdf`).

CPU, one small grid shared by the numerical tests (one compilation of the solve; the default grid's dense
240 × 240 blocks are several times slower on a loaded 2-core machine), the default grid in the command-line test. Monte Carlo references: default ship,
ITTC T01 = 10 s, head seas, U = 0, Method-2 filter of order 4, dt 0.5 s, φ0 = 5°, 10 batches × 1000 realizations
× 3600 s with the first 500 s discarded (benchmarks/data/theory_map_mc_reference.json, made by
prototypes/theory/mc_reference.py on branch prototypes/session2; `python benchmarks/theory_map.py --recompute`
runs the same protocol with the current code).
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll
from jaxroll import theory

DEG = np.pi / 180
GRID = dict(num_rho=10, num_theta=16, num_s=40, num_s_coarse=8)  # default: 12 ρ × 20 θ × (10 + 60) ln A cells
SHIP = jaxroll.c11_representative()

# Monte Carlo envelope statistics (mean ± SE [deg], P(A > 20°) ± SE, 99 % point ± SE [deg]) from the reference.
MC = {
    (7.0, 1.0): dict(mean=(9.8686, 0.0219), p20=(0.10857, 0.00057), q99=(35.383, 0.069)),
    (6.0, 0.8): dict(mean=(3.5297, 0.0141), p20=(0.0026248, 0.000078), q99=(15.877, 0.059)),
}


def _case(hs, r):
    ship = eqx.tree_at(lambda s: s.gm_correction, SHIP, SHIP.gm_correction * r)
    return ship, jaxroll.EffectiveWave(jaxroll.ITTC(hs, 10.0), ship.lpp)


@pytest.fixture(scope="module")
def laws_7m():
    ship, wave = _case(7.0, 1.0)
    env = theory.envelope_fpk_pdf(ship, wave, **GRID)
    zc = theory.envelope_fpk_pdf(ship, wave, estimator="zero_crossing", **GRID)
    return ship, wave, env, zc


def test_normalised_and_mean_is_integral(laws_7m):
    _, _, env, zc = laws_7m
    for law in (env, zc):
        assert abs(float(jnp.sum(law.mass)) - 1) < 1e-12
        a = np.linspace(float(law.edges[0]), float(law.edges[-1]), 400_001)
        p = np.asarray(law.pdf(a))
        assert np.all(p >= 0)
        assert abs(np.trapezoid(p, a) - 1) < 3e-5  # ∫ p dA = 1 (trapezoid error of the fine grid)
        mean = float(law.mean())
        assert abs(np.trapezoid(a * p, a) / mean - 1) < 3e-5  # E[A] = ∫ A p dA
        # ... = ∫ F̄ dA by the generic Gauss–Legendre rule of every amplitude law
        assert abs(float(jaxroll.AbstractAmplitudeLaw.mean(law)) / mean - 1) < 1e-6
        assert abs(float(law.cdf(law.quantile(0.9))) - 0.9) < 1e-9
        assert abs(float(law.sf(0.3) + law.cdf(0.3)) - 1) < 1e-12
    assert env.estimator == "envelope" and zc.estimator == "zero_crossing"
    d = env.details()
    assert d["method"] == "envelope_fpk" and d["grid"]["num_theta"] == 16 and d["exists"]
    # the excitation fit: γ ≈ 0.084 1/s (correlation time ≈ 12 s), Lorentzian variance ≈ 1.56 σ²
    assert 0.07 < d["parameters"]["envelope_gamma"] < 0.10
    assert 1.3 < d["parameters"]["envelope_variance"] < 1.8


def test_mean_equals_lyapunov_exponent_over_damping(laws_7m):
    """Stationarity of ṡ = −δ(a) + ξ gives E[A] = λ/c (c = 4 b2 ω/3π, b3 = 0) when the phase dynamics does not
    depend on a; the softening GZ keeps the default ship within 1 % (7 m: λ/c = 9.76°, mean 9.78°)."""
    ship, _, env, _ = laws_7m
    c = 4 * float(ship.damping[1]) * float(env.excitation.omega) / (3 * np.pi)
    assert abs(float(env.lyapunov_exponent) / c / float(env.mean()) - 1) < 0.01


def _linear_ship(c1):
    ship = eqx.tree_at(lambda s: s.restoring, SHIP, jnp.zeros(4))
    ship = eqx.tree_at(lambda s: s.delta_gm, ship, jnp.array([0.0, c1, 0, 0, 0, 0, 0]))
    return eqx.tree_at(lambda s: s.damping, ship, jnp.array([0.01, 0.5, 0.0]))


def test_small_excitation_limit_is_roberts():
    """As the parametric excitation → 0 its correlation time stops mattering (w/(2ωγ) → 0), so the coloured
    Lyapunov exponent tends to Roberts' white-noise one: λ + b1/2 → K (linear restoring, ΔGM = C1 ζ).
    Measured K_eff/K − 1 = −24.7 %, −3.3 %, −0.7 % at C1 = 0.55, 0.1375, 0.034 m/m."""
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), SHIP.lpp)
    errors = []
    for c1 in (0.55, 0.1375, 0.034375):
        ship = _linear_ship(c1)
        lam, _ = theory.envelope_lyapunov_exponent(ship, wave)
        k = float(theory.roberts_coefficients(ship, wave).k)
        errors.append(abs((float(lam) + 0.01 / 2) / k - 1))
    assert errors[2] < errors[1] < errors[0]
    assert errors[1] < 0.05 and errors[2] < 0.01


def test_roll_dies_out_below_threshold():
    """3 m, r = 0.5: λ < 0, no sustained roll: an error, or with throw=False a law flagged exists=False whose
    mass sits at the bottom of the grid."""
    ship, wave = _case(3.0, 0.5)
    with pytest.raises(ValueError, match="no sustained parametric roll"):
        theory.envelope_fpk_pdf(ship, wave, **GRID)
    law = theory.envelope_fpk_pdf(ship, wave, throw=False, **GRID)
    assert not law.details()["exists"] and float(law.lyapunov_exponent) < 0
    assert float(law.cdf(0.01 * DEG)) > 0.9


def test_zero_crossing_law_is_rate_weighted_envelope_law(laws_7m):
    """Per half cycle = envelope law × half-cycle rate (ω + ψ̇)/π. Up to 30° the rate's amplitude dependence is
    the harmonic-balance detuning (Ω(a)² − ω²)/(2ω), the excitation's share averaging out to within 2 %
    (measured 0.8 % on this grid, 1.3 % on the default one); above, phase-locked swings add to it (+2.4 % at 36°,
    +7.6 % at 52°)."""
    ship, _, env, zc = laws_7m
    omega = float(env.excitation.omega)
    a = np.asarray(env.amplitude)
    r = np.asarray(ship.restoring_coefficients)
    a2 = a * a
    om2 = r[0] + a2 * (0.75 * r[1] + a2 * (0.625 * r[2] + a2 * (35 / 64 * r[3] + a2 * 63 / 128 * r[4])))
    rate = omega + (om2 - omega**2) / (2 * omega)
    keep = (np.asarray(env.mass) > 1e-10) & (np.asarray(env.edges[1:]) <= 30 * DEG)
    ratio = np.asarray(zc.mass)[keep] / np.asarray(env.mass)[keep] / rate[keep]
    assert np.max(np.abs(ratio / np.median(ratio) - 1)) < 0.02
    # softening GZ: fewer half cycles at large amplitude, so the per-cycle law is the smaller one
    assert float(zc.mean()) < float(env.mean())
    assert float(zc.sf(30 * DEG)) < float(env.sf(30 * DEG))


def test_lyapunov_gradient_matches_central_differences():
    """jax.grad of λ (envelope fit + the a → 0 slice solve) with respect to H1/3 and b1 vs central differences."""

    def lyap(x):
        ship = eqx.tree_at(lambda s: s.damping, SHIP, SHIP.damping.at[0].set(x[1]))
        wave = jaxroll.EffectiveWave(jaxroll.ITTC(x[0], 10.0), ship.lpp)
        return theory.envelope_lyapunov_exponent(ship, wave)[0]

    x0 = jnp.array([7.0, float(SHIP.damping[0])])
    grad = np.asarray(jax.grad(lyap)(x0))
    fd = [float(lyap(x0.at[i].add(h)) - lyap(x0.at[i].add(-h))) / (2 * h) for i, h in enumerate((1e-3, 1e-5))]
    np.testing.assert_allclose(grad[1], -0.5, rtol=1e-12)  # λ = E_π[ξ] − b1/2, π independent of b1
    np.testing.assert_allclose(grad, fd, rtol=1e-6)


@pytest.mark.slow  # ~20 s on a quiet 2-core machine (compiling the reverse pass of the full solve)
def test_gradient_matches_central_differences():
    """jax.grad of P(A > 20°) with respect to H1/3 and b1 through the direct solve vs central differences."""

    def p20(x):
        ship = eqx.tree_at(lambda s: s.damping, SHIP, SHIP.damping.at[0].set(x[1]))
        wave = jaxroll.EffectiveWave(jaxroll.ITTC(x[0], 10.0), ship.lpp)
        return theory.envelope_fpk_pdf(ship, wave, **GRID).sf(20 * DEG)

    x0 = jnp.array([7.0, float(SHIP.damping[0])])
    grad = np.asarray(jax.grad(p20)(x0))
    steps = (1e-3, 1e-5)
    fd = [
        float(p20(x0.at[i].add(h)) - p20(x0.at[i].add(-h))) / (2 * h) for i, h in enumerate(steps)
    ]  # measured: 0.0751 per m and −11.58 (1/s)⁻¹
    assert grad[0] > 0 > grad[1]
    np.testing.assert_allclose(grad, fd, rtol=1e-5)


@pytest.mark.parametrize("case", list(MC))
def test_against_monte_carlo(case):
    """The issue-14 targets (mean and 99 % point within ±10 %, P(A > 20°) within ×1.5), each widened by 3 MC
    standard errors; and the accuracy this coarse grid has shown (7 m, r = 1: ×0.98, ×0.96, ×1.00; 6 m, r = 0.8:
    ×0.99, ×1.19, ×1.02; docs/theory.md §6 has the default grid): mean and 99 % point within 5 %, P20 ×1.3."""
    law = theory.envelope_fpk_pdf(*_case(*case), **GRID)
    ref = MC[case]
    got = {
        "mean": float(law.mean()) / DEG,
        "p20": float(law.sf(20 * DEG)),
        "q99": float(law.quantile(0.99)) / DEG,
    }
    for key, (target, tight) in {"mean": (0.10, 0.05), "q99": (0.10, 0.05)}.items():
        value, se = ref[key]
        err = abs(got[key] / value - 1)
        assert err <= target + 3 * se / value, (key, got[key], value)
        assert err <= tight + 3 * se / value, (key, got[key], value)
    value, se = ref["p20"]
    for factor in (1.5, 1.3):
        assert value / factor - 3 * se <= got["p20"] <= value * factor + 3 * se, (got["p20"], value)


def test_theory_command_runs_envelope_fpk(tmp_path):
    """`jaxroll theory --theory envelope_fpk`: the law, its summary and what produced it, in theory.json."""
    import json

    from jaxroll._cli import main

    assert main(["theory", "--theory", "envelope_fpk", "--hs", "7", "--out", str(tmp_path)]) == 0
    d = json.loads((tmp_path / "theory.json").read_text())
    t = d["theory"]["envelope_fpk"]
    edges = np.asarray(d["bins_deg"], float)
    assert np.sum(np.asarray(t["pdf"]) * np.diff(edges)) == pytest.approx(1 - t["mass_beyond_grid"], abs=1e-9)
    assert t["method"] == "envelope_fpk" and t["grid"]["num_theta"] == 20 and t["estimator"] == "envelope"
    assert t["mean_amplitude_deg"] == pytest.approx(9.77, abs=0.01)  # default grid (docs/theory.md §6)
