"""The envelope Fokker–Planck method (coloured-noise averaging, `jaxroll.theory.envelope_fpk_pdf`).

CPU, one small grid shared by the numerical tests (one compilation of the solve; the default grid's dense
240 × 240 blocks are several times slower on a loaded 2-core machine), the default grid in the command-line test. Monte Carlo references: default ship,
ITTC T01 = 10 s, head seas, U = 0, Method-2 filter of order 4, dt 0.5 s, φ0 = 5°, 10 batches × 1000 realizations
× 3600 s with the first 500 s discarded (benchmarks/data/theory_map_mc_reference.json, made by
prototypes/theory/mc_reference.py on branch prototypes/session2; `python benchmarks/theory_map.py --recompute`
runs the same protocol with the current code).
"""

import json
import re
import warnings
from pathlib import Path

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
    """Stationarity of ṡ = −δ(a) + ξ gives E[A] = λ/c (c = 4 b2 ω/3π, b3 = 0) when neither the phase dynamics nor
    the coupling depends on a; the softening GZ moves both (through the detuning and the resonant level over the
    locking band), and the default ship stays within 2.5 % (7 m: 1.7 % since the resonant level, 1 % before)."""
    ship, _, env, _ = laws_7m
    c = 4 * float(ship.damping[1]) * float(env.excitation.omega) / (3 * np.pi)
    assert abs(float(env.lyapunov_exponent) / c / float(env.mean()) - 1) < 0.025


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


@pytest.mark.parametrize("hs, speed, measured", [(6.0, 0.0, 1.01), (8.0, 5.0, 0.96)])
def test_lyapunov_exponent_is_the_linearised_rolls_in_the_exact_sea(hs, speed, measured):
    """λ against the growth rate of the linearised roll φ̈ + b1φ̇ + (ω0² + P(t))φ = 0 simulated directly under
    the superposed (exactly Gaussian) effective wave: RK4 at 0.2 s, 16 × 10 000 s, 3 % standard error. T01 10 s,
    head seas. Before the resonant level over the locking band and the mean stiffness in the detuning (issue 42)
    the model's λ was ×0.73 of it at 8 m, 5 m/s (where S_G is asymmetric about 2ω); measured now ×1.01 and ×0.96
    (32 × 20 000 s)."""
    from jaxroll.sea._grim import superpose

    ship = SHIP
    sea = jaxroll.ITTC(hs, 10.0)
    wave = jaxroll.EffectiveWave(sea, ship.lpp, speed, "head")
    dt, n, runs = 0.2, 50_000, 16

    @jax.jit
    def growth(key):
        zeta, _ = superpose(wave, key, 2 * n + 1, dt / 2)
        p = jaxroll.parametric_excitation(ship, zeta)

        def f(y, q):
            return jnp.array([y[1], -ship.damping[0] * y[1] - (ship.omega0**2 + q) * y[0]])

        def step(carry, i):
            y, log_growth = carry
            k1 = f(y, p[2 * i])
            k2 = f(y + dt / 2 * k1, p[2 * i + 1])
            k3 = f(y + dt / 2 * k2, p[2 * i + 1])
            k4 = f(y + dt * k3, p[2 * i + 2])
            y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            norm = jnp.hypot(y[0], y[1] / ship.omega0)
            return (y / norm, log_growth + jnp.log(norm)), None

        (_, log_growth), _ = jax.lax.scan(step, (jnp.array([1.0, 0.0]), 0.0), jnp.arange(n))
        return log_growth / (n * dt)

    rates = np.asarray(jax.lax.map(growth, jax.random.split(jax.random.key(3), runs)))
    simulated, se = rates.mean(), rates.std(ddof=1) / np.sqrt(runs)
    lam = float(theory.envelope_lyapunov_exponent(ship, wave)[0])
    assert abs(lam / simulated - 1) < 0.05 + 3 * se / simulated, (lam, simulated, se, measured)


def test_roll_dies_out_below_threshold():
    """3 m, r = 0.5: λ < 0, no sustained roll: an error, or with throw=False a law flagged exists=False whose
    mass sits at the bottom of the grid."""
    ship, wave = _case(3.0, 0.5)
    with pytest.raises(ValueError, match="no sustained parametric roll"):
        theory.envelope_fpk_pdf(ship, wave, **GRID)
    law = theory.envelope_fpk_pdf(ship, wave, throw=False, **GRID)
    assert not law.details()["exists"] and float(law.lyapunov_exponent) < 0
    assert float(law.cdf(0.01 * DEG)) > 0.9


def test_a_sea_the_envelope_model_does_not_fit_is_said_not_called_dying_out():
    """Following seas at 8 m/s: encounter puts the effective wave's energy far below the carrier 2ω, and the
    complex-OU envelope fitted to it has a negative decay rate (γ ≈ −0.009 1/s), so λ is undefined (NaN). The
    error says that — not "λ = nan <= 0, the roll dies out" — and so does the moment method's gate, which uses the
    same exponent; Roberts' K (the criterion the message points to) is far below b1/2 here."""
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), SHIP.lpp, 8.0, "following")
    lam, exc = theory.envelope_lyapunov_exponent(SHIP, wave)
    assert float(exc.gamma) < 0 and np.isnan(float(lam))
    with pytest.raises(
        ValueError, match=r"envelope FPK: no law: .*\(fitted decay rate γ = -0.00\d+ 1/s, not > 0"
    ):
        theory.envelope_fpk_pdf(SHIP, wave, **GRID)
    assert not theory.envelope_fpk_pdf(SHIP, wave, throw=False, **GRID).details()["exists"]
    from jaxroll.theory._moments import roll_not_sustained_error

    assert "cannot be told here" in str(roll_not_sustained_error(lam))
    assert "the roll dies out" in str(roll_not_sustained_error(-1e-3))
    k = theory.roberts_pdf(SHIP, wave, throw=False).parameters["K"]
    assert float(k) < 0.01 * float(SHIP.damping[0]) / 2


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
    assert t["mean_amplitude_deg"] == pytest.approx(9.76, abs=0.01)  # default grid (docs/theory.md §6)


# ------------------------------------------------------------------------------------------------------------
# The accuracy table of docs/theory.md §6 (issue 14): it regenerates, theory rows exactly as printed, the Monte
# Carlo reference within its standard errors. CI: one case (7 m, r = 1) and a 200-trial Monte Carlo (~5 s when
# the theories' programs are compiled already, as the command-line tests do); -m slow: all eight cases, 2000 trials.
# ------------------------------------------------------------------------------------------------------------

ROOT = Path(__file__).resolve().parents[1]
BINS = np.arange(0.0, 73.0, 1.0)  # the command line's bins for the default ship (vanishing angle 71.6°)


def _tolerance(text: str) -> float:
    """Half a unit of the last printed digit of `text` ("14.69", "0.254", "9.82e-05"), and a hair for rounding."""
    mantissa, _, exponent = text.partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 0.5 * 10.0 ** (int(exponent or 0) - decimals) * (1 + 1e-6)


def _number(cell: str) -> tuple[str, str | None]:
    """'14.69 (×1.49)' -> ('14.69', '1.49'); '9.82e-05 (×0.94†)' -> ('9.82e-05', '0.94'); '1.84 ± 0.01' -> (…)."""
    m = re.match(r"\s*([0-9.e+-]+)\s*(?:\(×([0-9.]+)†?\)|± ([0-9.e+-]+))?", cell)
    return m.group(1), m.group(2) or m.group(3)


def _docs_table() -> dict:
    """{(hs, r): {"Monte Carlo": row, "Roberts": row, "ESAM": row, "moment": row, "envelope FPK": row}}, each row
    a dict of (value, ratio or SE) text pairs and, for the moment method, the closure order printed."""
    lines = (ROOT / "docs" / "theory.md").read_text(encoding="utf-8").splitlines()
    start = lines.index(
        "| H1/3 | r | method | mean [deg] (ratio) | P(A>20°) (ratio) | 99 % [deg] (ratio) | targets |"
    )
    table, case = {}, None
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        hs, r, method, mean, p20, q99, _ = (c.strip() for c in line.strip("|").split("|"))
        if hs:
            case = (float(hs.removesuffix(" m")), float(r))
            table[case] = {}
        name = method.strip("*")
        if name.startswith("moment"):
            order = int(re.search(r"order (\d)", name).group(1))
            name = "moment"
        elif name not in ("Monte Carlo", "Roberts", "ESAM", "envelope FPK"):
            continue  # the protocol variant's row
        table[case][name] = {"mean": _number(mean), "p20": _number(p20), "q99": _number(q99)}
        if name == "moment":
            table[case][name]["order"] = order
    return table


def _reference(hs, r) -> dict:
    cases = json.loads((ROOT / "benchmarks" / "data" / "theory_map_mc_reference.json").read_text())["cases"]
    case = next(c for c in cases if (c["hs"], c["r"]) == (hs, r))
    e = case["envelope"]
    i20, i99 = e["tail_deg"].index(20.0), e["levels"].index(0.99)
    return {
        "mean": (e["mean_deg"], e["mean_se_deg"]),
        "p20": (e["tail"][i20], e["tail_se"][i20]),
        "q99": (e["quantiles_deg"][i99], e["quantiles_se_deg"][i99]),
        "E_A2": (e["E_A2"], e["E_A2_se"]),
        "n": case["n_realizations"],
    }


TABLE_CASES = [(7.0, 1.0)] + [
    pytest.param(c, marks=pytest.mark.slow) for c in [(5.0, 0.8), (6.0, 0.8), (7.0, 0.8), (8.0, 0.8), (5.0, 1.0),
                                                       (6.0, 1.0), (8.0, 1.0)]
]  # fmt: skip


@pytest.mark.parametrize("case", TABLE_CASES)
def test_accuracy_table_theory_rows_regenerate(case):
    """Every theory's row of the table (mean, P(A > 20°), 99 % point and their ratios to the Monte Carlo) comes out
    of the current code as printed, to the last printed digit; the Monte Carlo row is the stored reference."""
    row = _docs_table()[case]
    ref = _reference(*case)
    for key in ("mean", "p20", "q99"):  # the Monte Carlo row: the reference's value and standard error
        (value, se), (text, se_text) = ref[key], row["Monte Carlo"][key]
        assert abs(value - float(text)) <= _tolerance(text) and abs(se - float(se_text)) <= _tolerance(
            se_text
        )
    ship, wave = _case(*case)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the moment method's closure fallback (recorded below)
        results = dict(
            theory.iter_theory_summaries(("roberts", "esam", "moment", "envelope_fpk"), ship, wave, BINS)
        )
    names = {"Roberts": "roberts", "ESAM": "esam", "moment": "moment", "envelope FPK": "envelope_fpk"}
    for printed_name, name in names.items():
        law, summary = results[name]
        # P(A > 20°) from the summary's PDF: the CDF's increments above 20° and the mass beyond the last bin
        got = {
            "mean": summary["mean_amplitude_deg"],
            "p20": float(np.sum(summary["pdf_per_degree"][20:]) + summary["mass_beyond_grid"]),
            "q99": summary["quantiles_deg"]["99"],
        }
        for key, value in got.items():
            text, ratio = row[printed_name][key]
            assert abs(value - float(text)) <= _tolerance(text) * (1 + 1e-3), (case, name, key, value, text)
            assert abs(value / ref[key][0] - float(ratio)) <= _tolerance(ratio), (case, name, key, ratio)
        if name == "moment":
            assert law.closure_order == row["moment"]["order"]
        if name == "envelope_fpk" and case != (5.0, 0.8):  # the targets it meets (5 m, r = 0.8: not the mean)
            for key, (target, factor) in {
                "mean": (0.10, None),
                "q99": (0.10, None),
                "p20": (None, 1.5),
            }.items():
                value, se = ref[key]
                if factor is None:
                    assert abs(got[key] / value - 1) <= target + 3 * se / value
                elif value > 1e-3:
                    assert value / factor - 3 * se <= got[key] <= value * factor + 3 * se


@pytest.mark.parametrize(
    "cases, n",
    [([(7.0, 1.0)], 200), pytest.param([(h, r) for r in (0.8, 1.0) for h in (5.0, 6.0, 7.0, 8.0)], 2000,
                                       marks=pytest.mark.slow)],
)  # fmt: skip
def test_accuracy_table_monte_carlo_reference_regenerates(cases, n):
    """The stored Monte Carlo reference (10⁴ × 3600 s per case) is what the current code computes: a fresh,
    independent run of the same protocol with `n` trials agrees with it within k combined standard errors — the
    mean envelope amplitude and E[A²] with the new run's own standard errors (ratio estimators over the trials, as
    the reference), P(A > 20°) with the reference's scaled to `n` trials. k = 3 for the one case in CI (3
    comparisons), 4 for all eight (24 comparisons: at 3 SE one in 25 runs would fail by chance; measured: the
    largest deviation 3.3 SE, 5 m, r = 1, mean 4.33° vs 4.20 ± 0.02°, where another key gives 4.22°). 7 m, r = 1,
    n = 200: measured mean 9.99° (reference 9.87 ± 0.02°)."""
    k = 3 if len(cases) == 1 else 4
    for hs, r in cases:
        ref = _reference(hs, r)
        ship, _ = _case(hs, r)
        with pytest.warns(
            UserWarning, match="shaping filter's spectrum is .* off the effective wave's"
        ):  # the paper's order, off the band
            problem = jaxroll.RollProblem.from_sea(
                ship, jaxroll.ITTC(hs, 10.0), dt=0.5, filter_order=4, phi0=5 * DEG
            )
        stats = jaxroll.monte_carlo_amplitudes(problem, jax.random.key(9_000 + int(10 * hs + r)),
                                               num_realizations=n, duration=3600.0, discard=500.0)  # fmt: skip
        per = stats.per_realization
        keep = per["n_env"] > 0
        count = per["n_env"][keep]
        for key, total, scale in (
            ("mean", per["sum_env"][keep], 1 / DEG),
            ("E_A2", per["sumsq_env"][keep], 1.0),
        ):
            est = total.sum() / count.sum()  # ratio estimator and its standard error, as the reference's
            se = np.sqrt(np.sum((total - est * count) ** 2) / (count.size * (count.size - 1))) / count.mean()
            value, ref_se = ref[key]
            assert abs(est * scale - value) <= k * np.hypot(se * scale, ref_se), (
                hs,
                r,
                key,
                est * scale,
                value,
            )
        counts = np.asarray(stats.counts_envelope)
        p20 = counts[int(round(20 / 0.05)) :].sum() / counts.sum()
        value, ref_se = ref["p20"]
        se = ref_se * np.sqrt(ref["n"] / n)  # the reference's batch standard error, for n trials
        assert abs(p20 - value) <= k * np.hypot(se, ref_se), (hs, r, "p20", p20, value)


def test_theory_summary_is_the_public_law_and_summary():
    """`theory_summary("envelope_fpk", …)` (one program: the FPK solve, the law's mean, quantiles and CDF on the
    bins) gives `envelope_fpk_pdf`'s law, `summary` and `details` to 1e-12 (default grid, 7 m, r = 1)."""
    ship, wave = _case(7.0, 1.0)
    law, summary = theory.theory_summary("envelope_fpk", ship, wave, BINS)
    ref = theory.envelope_fpk_pdf(ship, wave)
    want = ref.summary(BINS)
    assert summary.keys() == want.keys()
    for key, value in want.items():
        if isinstance(value, dict):
            np.testing.assert_allclose(list(summary[key].values()), list(value.values()), rtol=1e-12)
        elif isinstance(value, str):
            assert summary[key] == value
        else:
            np.testing.assert_allclose(summary[key], value, rtol=1e-12, atol=1e-15)
    got, ref_details = law.details(), ref.details()
    assert got["grid"] == ref_details["grid"] and got["method"] == "envelope_fpk"
    np.testing.assert_allclose(
        list(got["parameters"].values()), list(ref_details["parameters"].values()), rtol=1e-12
    )
    assert summary["mean_amplitude_deg"] == pytest.approx(9.764, abs=0.005)
