"""Multilevel splitting (`jaxroll.monte_carlo_splitting`): exact against brute force in the one-stage case,
unbiased against brute force where brute force is feasible, the estimator and its variance on a Markov chain with
an exact answer, the pool's layout, bad input (docs/rare_events.md)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import default_problem

import jaxroll as jxr
from jaxroll.roll import _splitting as sp


@pytest.fixture(scope="module")
def sea5():
    return default_problem(5.0)


# ----------------------------------------------------------------------------------------------------------------
# The estimator on an exactly solvable chain (no JAX simulation): a ±1 random walk, horizon T, event max X ≥ b
# ----------------------------------------------------------------------------------------------------------------


class Walk:
    """X_{t+1} = X_t ± 1 (up with probability q), X_0 = 0, t ≤ T; the event X_t ≥ b; the score is X itself.
    Implements the stage interface `_split` drives (`initial`, `run`; no capsizes), with numpy noise from each
    stage's key; the score and the reach of a step are X."""

    def __init__(self, q: float, horizon: int, b: int):
        self.q, self.horizon, self.b = q, horizon, b

    def exact(self) -> float:
        """P(max_{t ≤ T} X_t ≥ b) by dynamic programming over the walk's law, absorbed at b."""
        off = self.horizon + 1
        law = np.zeros(2 * self.horizon + 3)
        law[off] = 1.0
        hit = 0.0
        for _ in range(self.horizon):
            new = np.zeros_like(law)
            new[1:] += self.q * law[:-1]
            new[:-1] += (1 - self.q) * law[1:]
            hit += new[off + self.b]
            new[off + self.b :] = 0
            law = new
        return hit

    def initial(self, key, num):
        zero = np.zeros(num)
        return {
            "phi": zero.copy(),
            "dphi": zero.copy(),
            "z": np.zeros((num, 1)),
            "x": zero.copy(),
            "k": np.zeros(num, np.int32),
            "alive": np.ones(num, bool),
            "score": np.full(num, -np.inf),
            "reach": np.zeros(num),
            "index": np.arange(num, dtype=np.int32),
        }

    def run(self, key, queue, level, final, angle=None):
        num = queue["k"].size
        rng = np.random.default_rng(np.asarray(jax.random.key_data(key)))
        x, k = queue["phi"].copy(), queue["k"].copy()
        score, reach = queue["score"].copy(), queue["reach"].copy()

        def target(score, reach):  # the event X >= b outranks every level
            top = np.where(reach >= self.b, np.inf, score)
            return top, (reach >= self.b) if final else top >= level

        top, success = target(score, reach)
        peak = top.copy()
        running = ~success & (k < self.horizon)
        while running.any():
            x = np.where(running, x + np.where(rng.random(num) < self.q, 1.0, -1.0), x)
            k = np.where(running, k + 1, k)
            score, reach = np.where(running, x, score), np.where(running, x, reach)
            top, done = target(score, reach)
            peak = np.where(running, np.maximum(peak, top), peak)
            success = np.where(running, done, success)
            running = running & ~done & (k < self.horizon)
        out = {
            "phi": x,
            "dphi": 0 * x,
            "z": np.zeros((num, 1)),
            "x": 0 * x,
            "k": k,
            "alive": np.ones(num, bool),
            "score": score,
            "reach": reach,
            "peak": peak,
            "success": success,
        }
        return out, 0


def _replicas(walk, levels, num, reps):
    est, var_hat, covered = [], [], {"t": [], "normal": []}
    exact = walk.exact()
    for r in range(reps):
        key = jax.random.key(r)
        run = sp._split(walk, key, num, [(lv, 0) for lv in levels] + [(None, 0)])
        p = [s.n_success / num for s in run["stages"]]
        z = float(np.prod(p)) if len(p) == run["num_stages"] else 0.0
        relvar = sp.genealogy_relative_variance(run["final_eves"], num, run["num_stages"])
        ancestors = sp.effective_ancestors(run["final_eves"])
        for rule, dof in (("t", ancestors), ("normal", math.inf)):
            lo, hi = sp._interval(z, relvar, math.nan, dof)
            covered[rule].append(lo <= exact <= hi)
        est.append(z)
        var_hat.append(z * z * relvar)
    return exact, np.array(est), np.array(var_hat), {k: np.mean(v) for k, v in covered.items()}


def test_splitting_estimator_and_its_variance_are_unbiased_on_an_exact_chain():
    # 4 levels below b = 10 (P = 0.0128, exact): 600 independent splitting runs of N = 100. The mean estimate
    # is within 4 of its standard errors of the exact value, and the genealogy variance estimator's mean within 4
    # standard errors of the estimates' sample variance (Lee & Whiteley's estimator is unbiased).
    walk = Walk(0.4, 60, 10)
    exact, est, var_hat, covered = _replicas(walk, [2, 4, 6, 8], 100, 600)
    assert exact == pytest.approx(0.012756841906584637, rel=1e-12)
    se = est.std(ddof=1) / math.sqrt(est.size)
    assert abs(est.mean() - exact) < 4 * se, (est.mean(), exact, se)
    sample_var = est.var(ddof=1)
    # standard error of the difference of two means over the same runs: of (V̂ − (Z − mean)²)
    d = var_hat - (est - est.mean()) ** 2 * est.size / (est.size - 1)
    assert abs(d.mean()) < 4 * d.std(ddof=1) / math.sqrt(d.size), (var_hat.mean(), sample_var)
    # the 95 % interval's coverage (on the effective ancestors: 0.96 measured over 400 such runs; the normal
    # quantile on the relative variance 0.92: N = 100 is small); binomial standard error over 600 runs ≈ 0.009
    assert 0.93 <= covered["t"] <= 0.99, covered
    assert covered["normal"] < covered["t"], covered


def test_interval_covers_where_the_genealogy_is_thin():
    # A rarer event through 9 levels (P = 2.2e-4, exact), N = 100: the successes descend from ~5 effective stage-0
    # ancestors, the variance estimate is noisy and the normal-quantile interval covered 0.90 in 400 runs; the
    # interval on the effective ancestors 0.965. 300 runs: binomial standard error ≈ 0.012.
    walk = Walk(0.4, 120, 20)
    exact, est, _, covered = _replicas(walk, list(range(2, 20, 2)), 100, 300)
    assert exact == pytest.approx(2.2220576e-4, rel=1e-6)
    assert abs(est.mean() - exact) < 4 * est.std(ddof=1) / math.sqrt(est.size)
    assert covered["t"] >= 0.93, covered
    assert covered["normal"] < covered["t"], covered


class Stall(Walk):
    """The walk, except that runs that entered a level never rise above their entrance score (as clones that entered
    at the end of the exposure): a pilot's next level would be the last one again."""

    def run(self, key, queue, level, final, angle=None):
        out, lanes = super().run(key, queue, level, final, angle)
        if np.any(queue["k"] > 0):  # past stage 0: no run rises, none reaches the event
            out = {**out, "peak": queue["score"].copy(), "success": np.zeros(queue["k"].size, bool)}
        return out, lanes


def test_pilot_stops_at_a_level_that_does_not_rise():
    # Before: the levels repeated until `max_levels` (30) — stages with p̂ = 1 that cost a stage each (18 of 300
    # pilots at 46°, benchmarks/splitting.py --coverage). Now the event follows the first level that stalls.
    plan, found, _, capped = sp._pilot_plan(Stall(0.4, 60, 10), jax.random.key(0), 100, 0.2, 30, [None])
    assert [lv is None for lv, _ in plan] == [False, True], plan
    assert not capped and found == [0.0]


def test_genealogy_variance_is_binomial_for_one_stage():
    # One stage, S successes each its own ancestor: the unbiased binomial variance (1 − p̂)/((N − 1) p̂) relative.
    n, s = 200, 13
    relvar = sp.genealogy_relative_variance(np.arange(s), n, 1)
    assert relvar == pytest.approx((n - s) / ((n - 1) * s), rel=1e-12)
    # all successes from one ancestor: relative variance 1 whatever K (no information on the spread)
    assert sp.genealogy_relative_variance(np.zeros(7, int), 100, 4) == pytest.approx(1.0, rel=1e-12)
    assert sp.genealogy_relative_variance(np.zeros(0, int), 100, 4) == 0.0


def test_block_normals_rows_are_the_blocks_rows():
    # A clone's noise for 16 source steps from row r of a block: the same numbers as rows r … r + 15 of the whole
    # block (even and odd filter orders; a traced first row), so a run's noise does not depend on where it starts.
    from jaxroll.roll._excitation import block_normals_by_column

    key = jax.random.key(11)
    for n in (3, 4):
        whole = np.stack(block_normals_by_column(key, 5, n), -1)
        part = jax.jit(lambda r, n=n: jnp.stack(block_normals_by_column(key, 5, n, r, 16), -1))(jnp.int32(48))
        np.testing.assert_array_equal(np.asarray(part), whole[48:64])


def test_restoring_potential_and_energy_amplitude():
    # V' = the restoring moment (central differences, float64), V(0) = 0; the energy amplitude inverts V (three
    # Newton steps: to 1e-7 rad, 6e-6°, up to 60°; clipped at the vanishing angle beyond V's maximum).
    ship = jxr.c11_representative()
    phi = jnp.linspace(0.05, 1.2, 24)
    h = 1e-6
    dv = (jxr.restoring_potential(ship, phi + h) - jxr.restoring_potential(ship, phi - h)) / (2 * h)
    np.testing.assert_allclose(dv, jxr.restoring_moment(ship, phi), rtol=1e-7, atol=1e-12)
    assert float(jxr.restoring_potential(ship, 0.0)) == 0.0
    vanishing = jxr.vanishing_angle(ship)
    angles = jnp.radians(jnp.linspace(1.0, 60.0, 60))
    back = sp.energy_amplitude(ship, jxr.restoring_potential(ship, angles), vanishing)
    np.testing.assert_allclose(back, angles, rtol=0, atol=1e-7)
    beyond = sp.energy_amplitude(ship, 2 * jxr.restoring_potential(ship, vanishing), vanishing)
    assert float(beyond) == float(vanishing)


# ----------------------------------------------------------------------------------------------------------------
# The roll problem
# ----------------------------------------------------------------------------------------------------------------


def test_one_stage_is_brute_force_trial_for_trial():
    # levels=[]: stage 0 alone is monte_carlo_max_roll's Monte Carlo, trial for trial (the same noise, the same
    # arithmetic, the same exceedances), the standard error the binomial one; and the runs that reached the angle,
    # continued from where they stopped with their own noise, capsize exactly where the brute force's trials did.
    problem = default_problem(8.0)
    key = jax.random.key(3)
    kw = dict(angle_deg=15.0, discard=100.0)
    bf = jxr.monte_carlo_max_roll(problem, key, num_realizations=64, duration=1000.0, **kw)
    r = jxr.monte_carlo_splitting(problem, key, num_trials=64, exposure=900.0, levels=[], **kw)
    assert 0 < bf.n_exceeded < 64 and bf.n_capsized > 0
    assert r.n_exceeded == bf.n_exceeded and r.n_capsized == bf.n_capsized
    assert r.probability == bf.exceedance_probability()
    assert r.capsize_probability == bf.n_capsized / 64
    p = r.probability
    np.testing.assert_allclose(r.standard_error, math.sqrt(p * (1 - p) / 63), rtol=1e-12, atol=0)
    assert r.levels_deg.tolist() == [15.0] and r.conditional_probabilities.tolist() == [p]
    # per trial: the stage program's successes are exactly the brute force's exceedances
    stages = sp._RollStages(problem, math.radians(15.0), 2000, 200, 16, None, jnp.float32)
    queue = stages.initial(key, 64)
    out, _ = stages.run(key, queue, math.inf, True)
    exceeded = bf.capsized | (bf.max_abs_phi_deg > 15.0)
    np.testing.assert_array_equal(out["success"], exceeded)
    # ... and their continuations capsize as the brute force's trials did, trial for trial
    following = stages.continuation(queue, out, exceeded)
    end, _ = stages.run(key, following, math.inf, True, stages.capsize_angle)
    np.testing.assert_array_equal(end["success"], bf.capsized[exceeded])
    stage = float(np.sum(out["k"])) * problem.dt
    assert r.stage_simulated_seconds.tolist() == [stage] and r.continuation_simulated_seconds > 0
    assert r.simulated_seconds == stage + r.continuation_simulated_seconds


def test_results_do_not_depend_on_the_pool(sea5):
    # The lanes in flight and the order they take the clones in do not change any run (noise per clone and step).
    # 200 runs a stage over the devices: pools of 32 lanes (several waves a device) and of all of a device's runs.
    kw = dict(angle_deg=30.0, exposure=600.0, discard=200.0, num_trials=200, levels=[22.0, 27.0])
    a = jxr.monte_carlo_splitting(sea5, jax.random.key(5), lanes=32, **kw)
    b = jxr.monte_carlo_splitting(sea5, jax.random.key(5), lanes=200, **kw)
    assert a.n_successes.tolist() == b.n_successes.tolist()
    assert a.probability == b.probability and a.simulated_seconds == b.simulated_seconds
    assert a.n_successes[0] > 0


def test_splitting_agrees_with_brute_force(sea5):
    # H1/3 = 5 m, 900 s after 200 s, 30°: P ≈ 0.011 by brute force (20 000 trials) and by splitting (400 runs a
    # stage, levels from its pilot), independent keys: within 4 combined standard errors.
    kw = dict(angle_deg=30.0, discard=200.0)
    bf = jxr.monte_carlo_max_roll(sea5, jax.random.key(1), num_realizations=20_000, duration=1100.0, **kw)
    r = jxr.monte_carlo_splitting(sea5, jax.random.key(2), exposure=900.0, num_trials=400, **kw)
    p = bf.exceedance_probability()
    se = math.sqrt(p * (1 - p) / bf.n_realizations)
    assert 0.005 < p < 0.02
    assert len(r.levels_deg) >= 2  # it did split
    assert abs(r.probability - p) < 4 * math.hypot(se, r.standard_error), (
        r.probability,
        p,
        r.standard_error,
        se,
    )
    lo, hi = r.probability_ci95
    assert lo < r.probability < hi
    assert 0 < r.relative_error < 1
    assert np.all(np.diff(r.levels_deg[:-1]) > 0) and r.levels_deg[-1] == 30.0
    assert r.total_simulated_seconds == r.simulated_seconds + r.pilot_simulated_seconds > 0
    assert r.stage_simulated_seconds.size == r.levels_deg.size
    assert r.config["levels"] == "pilot" and r.config["num_trials"] == 400


def test_bad_input(sea5):
    kw = dict(angle_deg=30.0, exposure=600.0)
    with pytest.raises(ValueError, match="shaping-filter excitation"):
        jxr.monte_carlo_splitting(default_problem(5.0, excitation="superposition"), jax.random.key(0), **kw)
    with pytest.raises(ValueError, match="angle of vanishing stability"):
        jxr.monte_carlo_splitting(sea5, jax.random.key(0), angle_deg=75.0, exposure=600.0)
    with pytest.raises(ValueError, match="strictly increasing"):
        jxr.monte_carlo_splitting(sea5, jax.random.key(0), levels=[20.0, 20.0], **kw)
    with pytest.raises(ValueError, match="must be finite scores > 0"):
        jxr.monte_carlo_splitting(sea5, jax.random.key(0), levels=[-1.0, 20.0], **kw)
    with pytest.raises(ValueError, match="sequence of angles"):
        jxr.monte_carlo_splitting(sea5, jax.random.key(0), levels="20", **kw)
    with pytest.raises(ValueError, match="`num_trials` must be an integer >= 2"):
        jxr.monte_carlo_splitting(sea5, jax.random.key(0), num_trials=1, **kw)
    with pytest.raises(ValueError, match="`stage_probability` must be in"):
        jxr.monte_carlo_splitting(sea5, jax.random.key(0), stage_probability=0.7, **kw)
    with pytest.raises(ValueError, match="`exposure` must be"):
        jxr.monte_carlo_splitting(sea5, jax.random.key(0), angle_deg=30.0, exposure=0.0)
    with pytest.raises(ValueError, match="`wave_weight` must be"):
        jxr.monte_carlo_splitting(sea5, jax.random.key(0), wave_weight=-1.0, **kw)


def test_risk_cli_splitting_refuses_too_few_trials(tmp_path, capsys):
    from jaxroll._cli import main

    assert (
        main(["risk", "--estimator", "splitting", "--splitting-trials", "5", "--out", str(tmp_path / "bad")])
        == 2
    )
    assert "--splitting-trials must be >= 10; got 5." in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()


@pytest.mark.slow
def test_risk_cli_splitting(tmp_path, capsys):
    # `jaxroll risk --estimator splitting` adds the direct probability by splitting under "splitting"; the other keys
    # stay.
    import json

    from jaxroll._cli import main

    code = main(
        [
            "risk",
            "--hs",
            "5",
            "--angle",
            "25",
            "--hours",
            "0.25",
            "--realizations",
            "16",
            "--duration",
            "1400",
            "--estimator",
            "splitting",
            "--splitting-trials",
            "64",
            "--out",
            str(tmp_path / "r"),
            "--quiet",
        ]
    )
    assert code == 0
    d = json.loads((tmp_path / "r" / "risk.json").read_text())
    assert {"direct", "monte_carlo", "curve", "splitting"} <= set(d)
    s = d["splitting"]
    assert s["num_trials"] == 64 and s["angle_deg"] == d["monte_carlo"]["angle_deg"]
    assert 0 <= s["probability_ci95"][0] <= s["probability"] <= s["probability_ci95"][1] <= 1
    assert s["levels_deg"][-1] == s["angle_deg"] and d["config"]["estimator"] == "splitting"
    assert "Splitting (64 runs a stage" in capsys.readouterr().out


@pytest.mark.slow
def test_interval_coverage_on_the_roll_problem(sea5):
    # 100 independent splitting runs (each with its own pilot) at H1/3 = 5 m, 900 s, 30° (P ≈ 0.011), against a
    # 100 000-trial brute-force reference (±3 %): their mean within 4 standard errors of it, the log-normal 95 %
    # interval covering it in at least 85 of 100 (binomial standard error 2.2 % at 95 %).
    kw = dict(angle_deg=30.0, discard=200.0)
    bf = jxr.monte_carlo_max_roll(sea5, jax.random.key(100), num_realizations=100_000, duration=1100.0, **kw)
    p = bf.exceedance_probability()
    runs = [
        jxr.monte_carlo_splitting(sea5, jax.random.key(200 + i), exposure=900.0, num_trials=200, **kw)
        for i in range(100)
    ]
    est = np.array([r.probability for r in runs])
    covered = np.mean([r.probability_ci95[0] <= p <= r.probability_ci95[1] for r in runs])
    se = math.hypot(est.std(ddof=1) / math.sqrt(est.size), math.sqrt(p * (1 - p) / bf.n_realizations))
    assert abs(est.mean() - p) < 4 * se, (est.mean(), p, se)
    assert covered >= 0.85, covered


def test_the_interval_of_few_ancestors_stays_a_probability():
    """One or two effective ancestors give Student's t with ~1 degree of freedom (q = 12.7): the log-normal upper end
    exp(qσ)·P̂ went to 327 in a long-term part (CI); it is clipped at 1, the lower end untouched."""
    from jaxroll.roll._splitting_result import _interval

    lo, hi = _interval(0.00864, 3.0, 1.0, ancestors=1.3)
    assert hi == 1.0 and 0 < lo < 0.00864
    lo2, hi2 = _interval(0.01, 0.01, 1.0, ancestors=50.0)
    assert lo2 < 0.01 < hi2 < 0.02
