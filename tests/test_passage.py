"""Exposure risk from the first passage of the envelope FPK model (`jaxroll.theory.passage_risk`).

Checked against: the same discrete system marched in time (a second method for S(T)), the direct Monte Carlo
(benchmarks/data/exposure_mc_reference.json: trials of 1000 s + the exposure, their largest |φ| over the exposure;
`python benchmarks/exposure_mc_reference.py`), central differences, and the loop it vmaps.
"""

import json
import math
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll
from jaxroll import theory
from jaxroll.theory import _envelope_fpk as fpk, _envelope_fpk_passage as passage

DEG = np.pi / 180
SHIP = jaxroll.c11_representative()
SMALL = dict(num_rho=6, num_theta=10, num_s=30, num_s_coarse=6)  # a cheap grid for the numerical identities
REFERENCE = Path(__file__).parents[1] / "benchmarks" / "data" / "exposure_mc_reference.json"


def _wave(hs, t01=10.0):
    return jaxroll.EffectiveWave(jaxroll.ITTC(hs, t01), SHIP.lpp)


def test_survival_equals_the_system_marched_in_time():
    """S(T) from the inverse-iteration moments (slowest mode + one lumped fast mode) against the same operator
    with the same killing and start marched by backward Euler (dt 2 s and 1 s, Richardson-extrapolated)."""
    angle, durations = 30 * DEG, np.array([600.0, 1200.0, 1800.0])
    risk = theory.passage_risk(SHIP, _wave(6.0), [angle], durations, extrapolate=False, **SMALL)
    grid = fpk._grid(
        SMALL["num_s"],
        SMALL["num_s_coarse"],
        SMALL["num_rho"],
        SMALL["num_theta"],
        5.5,
        math.radians(0.5),
        math.radians(1e-4),
        0,
    )
    levels = passage._levels(passage._concrete_top(SHIP, "passage_risk"), grid, [angle])
    face = grid.num_s_coarse + levels[0][0]

    @eqx.filter_jit
    def marched(dt):
        md, _ = passage._model(SHIP, _wave(6.0), None, grid, levels)
        ns = md.sc.shape[0]
        capsize = fpk._factorise(md, 0.0, False)
        guess = jnp.ones((ns, md.m)) * md.ds[:, None]
        _, p = passage._survival_moments(md, capsize, guess / jnp.sum(guess), 8)  # the start law
        kill = jnp.where((jnp.arange(ns) >= face)[:, None], passage._peak_rate(md), 0.0)
        factors = fpk._factorise(md, 1.0 / dt, False, kill)

        def step(q, _):
            qn = fpk._solve(md, factors, -q / dt)
            return qn, jnp.sum(qn * md.ds[:, None])

        _, mass = jax.lax.scan(step, p / md.ds[:, None], None, length=int(round(1800 / dt)))
        return mass

    m2, m1 = np.asarray(marched(2.0)), np.asarray(marched(1.0))
    exact = np.array(
        [2 * m1[int(t) - 1] - m2[int(t) // 2 - 1] for t in durations]
    )  # first-order error removed
    theory_s = 1.0 - np.asarray(risk.probability[0])
    np.testing.assert_allclose(theory_s, exact, rtol=3e-3)
    assert np.all(np.diff(exact) < 0) and 0.5 < exact[-1] < 0.9  # a case where the survival really moves


def _reference_cases():
    data = json.loads(REFERENCE.read_text())
    return data["cases"]


@pytest.fixture(scope="module")
def default_grid_risks():
    """The default grid at H1/3 5–8 m, 25°/30°/40°, 1 h and 3 h (one compiled program per grid for the four
    seas)."""
    return {
        hs: theory.passage_risk(SHIP, _wave(hs), np.deg2rad([25.0, 30.0, 40.0]), [3600.0, 10800.0])
        for hs in (5.0, 6.0, 7.0, 8.0)
    }


def test_against_the_order_4_monte_carlo(default_grid_risks):
    """Issue 34's comparison (docs/theory.md §7's table): the order-4 filter's Monte Carlo, itself 10–20 % low at
    T01 10 s against the exact sea (docs/validation.md). Wherever its P lies in [1e-3, 0.95] the theory is within
    ×1.25 of it (measured ×0.90–1.22 since the resonant level over the locking band, ×0.85–1.00 before: the theory
    moved towards the exact sea, above this low reference); the independent-amplitude route of the same model
    misses it (×1.8 and more)."""
    checked, ratios, independent_worst = 0, [], 1.0
    for case in _reference_cases():
        risk = default_grid_risks[case["hs"]]
        j = [3600.0, 10800.0].index(3600.0 * case["hours"])
        for i, (p_mc, (lo, hi)) in enumerate(zip(case["probability"], case["probability_ci95"], strict=True)):
            if not 1e-3 <= p_mc <= 0.95:
                continue
            p = float(risk.probability[i, j])
            ratios.append(p / p_mc)
            assert 1 / 1.25 <= p / p_mc <= 1.25, (case["hs"], case["hours"], case["angles_deg"][i], p, p_mc)
            independent_worst = max(independent_worst, float(risk.independent_probability[i, j]) / p_mc)
            checked += 1
    assert checked >= 12
    assert independent_worst > 1.8  # what treating the amplitudes as independent gives (same model)
    assert max(max(ratios), 1 / min(ratios)) < 1.23  # measured 1.222 (5 m, 40°, 3 h)


EXACT = json.loads((REFERENCE.parent / "exact_reference.json").read_text())["cells"]


def test_against_the_exact_sea_at_t01_10s():
    """The exact-spectrum reference (benchmarks/exact_reference.py, 12 000 trials a cell) at H1/3 6 and 8 m, T01
    10 s, head seas, 0 m/s, 25–45°, 1 h and 3 h: within ×1.25 wherever 1e-3 ≤ P_exact ≤ 0.95 and at least 25
    exceedances (measured ×0.81–0.95; before the resonant level over the locking band ×0.75–0.94)."""
    angles = [25.0, 30.0, 35.0, 40.0, 45.0]
    checked = 0
    for hs in (6.0, 8.0):
        risk = theory.passage_risk(SHIP, _wave(hs), np.deg2rad(angles), [3600.0, 10800.0])
        cell = EXACT[f"hs{hs:g}_t10_chi180_u0"]
        for i, a in enumerate(angles):
            for j, hours in enumerate(("1", "3")):
                x = cell["exceedances"][hours][f"{a:g}"]
                p_exact = x / cell["trials"]
                if not (1e-3 <= p_exact <= 0.95 and x >= 25):
                    continue
                ratio = float(risk.probability[i, j]) / p_exact
                assert 1 / 1.25 <= ratio <= 1.25, (hs, hours, a, ratio)
                checked += 1
    assert checked >= 10


def test_clusters_and_rates_are_consistent(default_grid_risks):
    """Rare levels: P(T) ≈ start + λ₁T; 1/θ (amplitudes above the angle per cluster) > 1 and growing with lower
    levels; the capsize probability grows with the sea; continuous observation of the envelope is never lower."""
    risk = default_grid_risks[5.0]
    p = np.asarray(risk.probability)
    lam = np.asarray(risk.cluster_rate)
    np.testing.assert_allclose(
        p[2],
        1 - (1 - np.asarray(risk.start_exceedance)[2]) * np.exp(-lam[2] * np.array([3600.0, 10800.0])),
        rtol=3e-2,
    )
    theta = np.asarray(risk.extremal_index)
    assert np.all(theta < 1) and np.all(np.diff(theta) > 0)
    caps = [float(default_grid_risks[h].capsize_probability[1]) for h in (6.0, 7.0, 8.0)]
    assert np.all(np.diff(caps) > 0)
    cont = theory.passage_risk(SHIP, _wave(6.0), [30 * DEG], [3600.0], observe="continuous", **SMALL)
    peaks = theory.passage_risk(SHIP, _wave(6.0), [30 * DEG], [3600.0], **SMALL)
    assert float(cont.probability[0, 0]) > 1.2 * float(peaks.probability[0, 0])


def test_vmapped_over_sea_states_equals_the_loop():
    hs = jnp.array([5.5, 6.5])
    angles, durations = [30 * DEG], jnp.array([3600.0])

    def one(h):
        return theory.passage_risk(SHIP, _wave(h), angles, durations, **SMALL).probability

    batched = eqx.filter_vmap(one)(hs)
    looped = jnp.stack([one(h) for h in hs])
    np.testing.assert_allclose(np.asarray(batched), np.asarray(looped), rtol=1e-10)


def test_gradient_in_the_sea_matches_central_differences():
    def p(hs):
        return theory.passage_risk(SHIP, _wave(hs), [30 * DEG], jnp.array([3600.0]), **SMALL).probability[
            0, 0
        ]

    g = float(jax.grad(p)(6.0))
    h = 1e-3
    fd = (float(p(6.0 + h)) - float(p(6.0 - h))) / (2 * h)
    assert g > 0
    assert abs(g / fd - 1) < 1e-4


def test_order_of_the_angles_is_kept():
    a = theory.passage_risk(SHIP, _wave(6.0), np.deg2rad([40.0, 25.0, 30.0]), [3600.0], **SMALL)
    b = theory.passage_risk(SHIP, _wave(6.0), np.deg2rad([25.0, 30.0, 40.0]), [3600.0], **SMALL)
    np.testing.assert_allclose(np.asarray(a.probability), np.asarray(b.probability)[[2, 0, 1]], rtol=1e-12)
    np.testing.assert_allclose(np.asarray(a.angles_deg), [40.0, 25.0, 30.0])


def test_no_sustained_roll_gives_zero():
    risk = theory.passage_risk(SHIP, _wave(2.0), [20 * DEG], [3600.0], **SMALL)
    assert not bool(risk.exists) and float(risk.lyapunov_exponent) < 0
    assert float(risk.probability[0, 0]) == 0.0 and float(risk.capsize_probability[0]) == 0.0


@pytest.mark.parametrize(
    "angles, durations, kw, match",
    [
        ([80 * DEG], [3600.0], {}, "below the vanishing angle"),
        ([0.1 * DEG], [3600.0], {}, "above the fine"),
        ([30 * DEG, 30.5 * DEG], [3600.0], {}, "same amplitude cell"),
        ([30 * DEG], [0.0], {}, "durations` must be > 0"),
        ([30 * DEG], [3600.0], {"observe": "envelope"}, "`observe`"),
        ([[30 * DEG]], [3600.0], {}, "1-D"),
    ],
)
def test_bad_input_is_refused(angles, durations, kw, match):
    with pytest.raises(ValueError, match=match):
        theory.passage_risk(SHIP, _wave(6.0), angles, durations, **kw, **SMALL)


# ----------------------------------------------------------------------------------------------------------
# Speed: the inverted pivots, the batch, the thread limit (issue 34's long-term theory)
# ----------------------------------------------------------------------------------------------------------


def test_block_thomas_with_inverted_pivots_equals_a_dense_solve():
    """`_solve` with `_factorise`'s stored pivot inverses S_i⁻¹ against the same block-tridiagonal system assembled
    densely and solved by NumPy (capsize absorbing, killing above a face: a passage system)."""
    grid = fpk._grid(12, 4, 4, 6, 5.5, math.radians(0.5), math.radians(1e-4), 0)
    levels = passage._levels(passage._concrete_top(SHIP, "passage_risk"), grid, [30 * DEG])
    md, _ = passage._model(SHIP, _wave(6.0), None, grid, levels)
    ns, m = md.sc.shape[0], md.m
    face = grid.num_s_coarse + levels[0][0]
    kill = jnp.where((jnp.arange(ns) >= face)[:, None], passage._peak_rate(md), 0.0)
    rhs = jnp.asarray(np.random.default_rng(1).normal(size=(ns, m)))
    q = np.asarray(fpk._solve(md, fpk._factorise(md, 0.0, False, kill), rhs))
    dense = np.zeros((ns * m, ns * m))
    for i in range(ns):
        block = fpk._slice_operator(md, jnp.exp(md.sc[i]), md.level[i]) + jnp.diag(md.diag_s[i] - kill[i])
        dense[i * m : (i + 1) * m, i * m : (i + 1) * m] = np.asarray(block)
        if i > 0:
            dense[i * m : (i + 1) * m, (i - 1) * m : i * m] = np.diag(np.asarray(md.lower[i]))
        if i < ns - 1:
            dense[i * m : (i + 1) * m, (i + 1) * m : (i + 2) * m] = np.diag(np.asarray(md.upper[i]))
    expect = np.linalg.solve(dense, np.asarray(rhs).ravel()).reshape(ns, m)
    np.testing.assert_allclose(q, expect, rtol=1e-9, atol=1e-9 * np.abs(expect).max())


def test_batch_equals_the_call_per_sea_state():
    """`passage_risk_batch` (one program, the seas one after another; pass 1 then pass 2 reusing it as `coarse`)
    gives each sea's `passage_risk`, and refuses what `passage_risk` refuses."""
    waves = [_wave(5.5), _wave(6.5, 9.0), _wave(7.0, 11.0)]
    angles, durations = np.deg2rad([25.0, 40.0]), [3600.0, 10800.0]
    one_grid = theory.passage_risk_batch(SHIP, waves, angles, durations, extrapolate=False, **SMALL)
    batch = theory.passage_risk_batch(SHIP, waves, angles, durations, coarse=one_grid, **SMALL)
    assert batch.probability.shape == (3, 2, 2)
    for i, wave in enumerate(waves):
        single = theory.passage_risk(SHIP, wave, angles, durations, **SMALL)
        for name in ("probability", "cluster_rate", "exceedance_per_cycle", "capsize_probability"):
            np.testing.assert_allclose(
                np.asarray(getattr(batch, name)[i]),
                np.asarray(getattr(single, name)),
                rtol=1e-8
                if name == "capsize_probability"
                else 1e-10,  # capsize ~2e-6: a nearly singular system
                atol=1e-300,
            )
    with pytest.raises(ValueError, match="below the vanishing angle"):
        theory.passage_risk_batch(SHIP, waves, [80 * DEG], durations, **SMALL)
    with pytest.raises(ValueError, match="at least one wave"):
        theory.passage_risk_batch(SHIP, [], angles, durations, **SMALL)


def test_inverse_iterations_converge():
    """The default `num_iterations` (5) and `jaxroll longterm`'s 3 against 10 (the slowest mode converged): the
    probabilities on the default grid at 6 m, 25–40°, 1 h and 3 h (measured 6e-5 and 6e-4 relative)."""
    angles, durations = np.deg2rad([25.0, 30.0, 40.0]), [3600.0, 10800.0]

    def p(n):
        kw = {} if n is None else {"num_iterations": n}
        return np.asarray(
            theory.passage_risk(SHIP, _wave(6.0), angles, durations, extrapolate=False, **kw).probability
        )

    converged = p(10)
    np.testing.assert_allclose(p(None), converged, rtol=1e-4)
    np.testing.assert_allclose(p(3), converged, rtol=1e-3)


def test_a_traced_ship_is_refused_and_its_gradient_kept():
    """Under `jit`/`vmap` the ship's vanishing angle (the grid's top, which places the angles' faces) is unknown:
    refused, naming `passage_risk_batch`. `jax.grad` in a ship parameter still works (the top from the primal
    values) and matches central differences."""
    angles, durations = [30 * DEG], jnp.array([3600.0])
    with pytest.raises(ValueError, match="passage_risk_batch"):
        eqx.filter_jit(lambda s: theory.passage_risk(s, _wave(6.0), angles, durations, **SMALL))(SHIP)

    def p(scale):
        ship = eqx.tree_at(lambda s: s.damping, SHIP, SHIP.damping * scale)
        return theory.passage_risk(ship, _wave(6.0), angles, durations, **SMALL).probability[0, 0]

    g = float(jax.grad(p)(1.0))
    h = 1e-4
    fd = (float(p(1.0 + h)) - float(p(1.0 - h))) / (2 * h)
    assert g < 0  # more damping, fewer large rolls
    assert abs(g / fd - 1) < 1e-4


def test_single_threaded_blas_restores_the_thread_counts():
    from jaxroll._config import blas_threads

    before = blas_threads()
    assert before  # SciPy's OpenBLAS (jaxlib's LAPACK) is found
    with jaxroll.single_threaded_blas():
        assert set(blas_threads()) == {1}
        with jaxroll.single_threaded_blas():  # re-entrant
            assert set(blas_threads()) == {1}
        assert set(blas_threads()) == {1}
    assert blas_threads() == before
