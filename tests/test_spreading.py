r"""Short-crested seas (issue 44, item 2): directional spreading D(θ) (cos-2s, cos^n), Grim's effective wave and the
direct wave moment summed over directions, the long-crested limit, and bad input. Statistical checks have fixed
seeds and tolerances from their standard errors."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import pytest
from scipy.integrate import quad

from jaxroll import ITTC, EffectiveWave, RollProblem, superpose
from jaxroll.sea import Spreading, grim_transfer, parse_spreading
from jaxroll.sea._spectra import encounter_branches

G = 9.80665
SPREADINGS = [("cos2s", 1.0), ("cos2s", 0.3), ("cos2s", 10.0), ("cos2s", 75.0), ("cosn", 2.0), ("cosn", 0.5)]


@pytest.mark.parametrize(("kind", "exponent"), SPREADINGS)
def test_spreading_is_normalised(kind, exponent):
    """∫ D dθ = 1 by adaptive quadrature (to 1e-10), the cumulative probability `cdf` (incomplete beta) against the
    same quadrature and `quantile` its inverse, and the directions' weights sum to 1 and give D's second moment."""
    sp = Spreading(kind, exponent)
    half = sp.half_width
    total = quad(lambda t: float(sp(t)), -half, half, points=[0.0], limit=400, epsabs=1e-13)[0]
    assert abs(total - 1) < 1e-10
    for theta in (-0.7 * half, -0.1, 0.05, 0.4 * half):
        want = quad(lambda t: float(sp(t)), -half, theta, points=[0.0] if theta > 0 else None, limit=400)[0]
        assert abs(float(sp.cdf(theta)) - want) < 1e-9
    u = np.array([1e-6, 0.1, 0.5, 0.77, 1 - 1e-6])
    assert np.allclose(sp.cdf(sp.quantile(u)), u, atol=1e-12, rtol=0)
    assert float(sp(1.01 * half)) == 0.0  # nothing outside the support
    theta, w = sp.directions()
    assert theta.size == 32 and abs(w.sum() - 1) < 1e-14 and np.allclose(theta, -theta[::-1])
    second = quad(lambda t: t * t * float(sp(t)), -half, half, points=[0.0], limit=400)[0]
    assert abs(np.sum(w * theta**2) / second - 1) < 2e-3


def test_closed_forms():
    """The normalisations against their values for integer exponents: cos-2s, s = 1: D = cos²(θ/2)/π; s = 2:
    D = (4/(3π)) cos⁴(θ/2); cos^n, n = 2: D = (2/π) cos²θ; n = 1: D = cos θ / 2. The cos-2s spread at large s:
    σ_θ² → 2/s (Gaussian limit), cos^n: 1/n."""
    assert math.isclose(Spreading("cos2s", 1).normalisation, 1 / math.pi, rel_tol=1e-14)
    assert math.isclose(Spreading("cos2s", 2).normalisation, 4 / (3 * math.pi), rel_tol=1e-14)
    assert math.isclose(Spreading("cosn", 2).normalisation, 2 / math.pi, rel_tol=1e-14)
    assert math.isclose(Spreading("cosn", 1).normalisation, 0.5, rel_tol=1e-14)
    assert math.isclose(float(Spreading("cos2s", 1)(0.3)), math.cos(0.15) ** 2 / math.pi, rel_tol=1e-14)
    for sp, var in ((Spreading("cos2s", 400.0), 2 / 400), (Spreading("cosn", 200.0), 1 / 200)):
        theta, w = sp.directions()
        assert abs(np.sum(w * theta**2) / var - 1) < 0.01


@pytest.mark.parametrize(
    "text", ["cos2s:0", "cos2s:-1", "cosn:0", "cosn:nan", "cos2s:inf", "cos2s", "cos3:2", "cos2s:abc", "x"]
)
def test_bad_spreading_is_refused(text):
    """Exponents ≤ 0 or not finite, an unknown kind or no exponent: a one-line error that names the fix."""
    with pytest.raises(ValueError, match=r"cos2s|exponent") as info:
        parse_spreading(text)
    assert "\n" not in str(info.value)
    assert parse_spreading("none") is None and parse_spreading("COS2S:10") == Spreading("cos2s", 10.0)
    with pytest.raises(ValueError, match="exponent s of cos-2s must be a finite number > 0"):
        Spreading("cos2s", 0.0)
    with pytest.raises(ValueError, match="exponent n of cos\\^n must be a finite number > 0"):
        Spreading("cosn", -2)
    with pytest.raises(ValueError, match="num_directions"):
        Spreading("cosn", 2, num_directions=0)


def _double_integral(sea, length, heading, sp):
    """σ_G² = ∫∫ S(ω) D(θ) F(k|cos(χ + θ)|)² dθ dω [m²] (trapezoid rules, 4001 × 4001 nodes; the encounter
    transform keeps the variance, so the speed does not enter), independent of jaxroll's directions."""
    om = np.linspace(1e-3, 4.0, 4001)
    theta = np.linspace(-sp.half_width, sp.half_width, 4001)
    x = om[:, None] ** 2 / G * np.abs(np.cos(heading + theta))[None, :] * length / 2
    # Grim's F = 2x sin x/(π² − x²), x = kL/2, with its removable singularity at x = π (F = 1)
    grim = 2 * x * np.sin(x) / (np.pi**2 - x**2 + (np.abs(np.pi - x) < 1e-9))
    grim = np.where(np.abs(np.pi - x) < 1e-9, 1.0, grim)
    inner = np.trapezoid(np.asarray(sea(om))[:, None] * grim**2, om, axis=0)
    return float(np.trapezoid(inner * np.asarray(sp(theta)), theta))


@pytest.mark.parametrize(
    ("kind", "exponent", "heading", "speed"),
    [("cos2s", 1.0, math.pi, 0.0), ("cos2s", 10.0, math.pi, 5.0), ("cosn", 2.0, 0.75 * math.pi, 5.0),
     ("cos2s", 10.0, math.pi / 3, 3.0), ("cos2s", 75.0, math.pi / 2, 0.0)],
)  # fmt: skip
def test_effective_wave_variance_is_the_double_integral(kind, exponent, heading, speed):
    """σ_G² = ∫ S_G dω_e of the spread effective wave (32 directions, each with its own encounter branches) equals
    the double integral over ω and θ within 3e-4 (the directions' quadrature, 32 Gauss–Legendre nodes on the
    support: 1.5e-4 for the widest, cos2s:1, below 1e-5 from s = 10), at head, oblique, following-going and beam mean headings, with and without speed."""
    sea, length = ITTC(7.0, 10.0), 262.0
    sp = Spreading(kind, exponent)
    got = float(EffectiveWave(sea, length, speed, heading, spreading=sp).variance())
    want = _double_integral(sea, length, heading, sp)
    print(f"{sp.label()} χ {math.degrees(heading):.0f}° U {speed}: σ_G² {got:.6f} m², ∫∫ {want:.6f} m²")
    assert abs(got / want - 1) < 3e-4


def test_long_crested_limit():
    """`spreading=None` is today's sea (the same S_G, bit for bit); as the exponent grows the spread S_G tends to
    the long-crested one: within 1e-12 at s = n = 1e20, and in head seas ∝ 1/s (1e-8 at s = 1e8)."""
    sea, grid = ITTC(7.0, 10.0), np.linspace(0.0, 2.0, 2001)
    for heading, speed in (("head", 3.0), (math.radians(60), 4.0)):
        base = np.asarray(EffectiveWave(sea, 262.0, speed, heading).spectrum(grid))
        same = np.asarray(EffectiveWave(sea, 262.0, speed, heading, spreading=None).spectrum(grid))
        assert np.array_equal(base, same)
        for kind in ("cos2s", "cosn"):
            err = {}
            for s in (1e8, 1e10, 1e20):
                wave = EffectiveWave(sea, 262.0, speed, heading, spreading=Spreading(kind, s))
                err[s] = np.max(np.abs(np.asarray(wave.spectrum(grid)) - base)) / base.max()
            assert err[1e20] < 1e-12
            if heading == "head":  # (oblique, following-going: the encounter singularity moves with χ)
                assert 50 < err[1e8] / err[1e10] < 200


def test_superposition_of_a_spread_sea():
    """Method 1 in a short-crested sea draws from the spread S_G: the variance of ζ_G in 40 records of 4000 s
    within 3 standard errors of the double integral."""
    sea, sp = ITTC(5.0, 10.0), Spreading("cos2s", 2.0)
    wave = EffectiveWave(sea, 262.0, 4.0, math.radians(150), spreading=sp)
    zeta = jax.jit(jax.vmap(lambda k: superpose(wave, k, 16000, 0.25)[0]))(jr.split(jr.key(3), 40))
    var = np.asarray(jnp.mean(zeta**2, axis=1))
    want = _double_integral(sea, 262.0, math.radians(150), sp)
    se = var.std(ddof=1) / math.sqrt(var.size)
    print(f"superposition σ_G² {var.mean():.5f} ± {se:.2g}, ∫∫ {want:.5f} m²")
    assert abs(var.mean() - want) < 3 * se


def test_spread_sea_lowers_the_head_sea_excitation():
    """The default ship in head seas: the spread S_G at 2ω0 (what the averaging theories and the filter's match
    take) falls with the spreading, and a theory takes it: Roberts' K ∝ S_P(2ω), the parametric term's spectrum,
    whose linear part (C1 ΔGM) is ∝ S_G(2ω); K(cos2s:2)/K(long-crested) is the ratio of the S_G(2ω) within 2 %
    (0.5 %: ΔGM's higher terms see σ_G, which the spreading lowers less)."""
    from jaxroll import c11_representative
    from jaxroll.theory import roberts_coefficients

    ship, sea = c11_representative(), ITTC(5.0, 10.0)
    w2 = 2 * float(ship.omega0)
    values = {}
    for sp in (None, Spreading("cos2s", 10.0), Spreading("cos2s", 2.0)):
        wave = EffectiveWave(sea, ship.lpp, 0.0, "head", spreading=sp)
        k = float(roberts_coefficients(ship, wave, mean_shift=False).k)
        values[sp] = (float(wave.spectrum(w2)), k)
    (s0, k0), (s10, _), (s2, k2) = values.values()
    assert s0 > s10 > s2 > 0.3 * s0
    assert abs((k2 / k0) / (s2 / s0) - 1) < 0.02


@pytest.fixture(scope="module")
def moment_ship():
    """The C11-like hull's ship carrying its Froude–Krylov moment (every 15°, ω to 4 rad/s)."""
    from jaxroll.ship import c11_hull, c11_hull_loading, c11_hull_ship, wave_moment

    ship = c11_hull_ship()
    table = wave_moment(c11_hull(), c11_hull_loading(), ship, omega=np.linspace(0.0, 4.0, 401))
    return eqx.tree_at(lambda s: s.wave_moment, ship, table, is_leaf=lambda x: x is None)


def _exact_joint(problem, dt, size):
    """(E[ζ_G²], E[M_w²], E[ζ_G M_w]) of the joint synthesis in a short-crested sea, exactly on its own encounter
    frequencies: Σ_q w_q Σ_b S(ω_b)/|dω_e/dω| [G², |F|², G Re F] Δω_e, each direction q with its own branches,
    projected wave number and F(ω, χ_q) (F(−χ) = −F(χ) for waves from starboard)."""
    wave = problem.wave
    from jaxroll.ship import roll_inertia

    table = problem.ship.wave_moment.per_inertia(roll_inertia(problem.ship))
    theta, weights = wave.spreading.directions()
    domega = 2 * np.pi / (size * dt)
    omega_e = np.arange(size // 2 + 1) * domega
    interior = (omega_e > 0) & (omega_e < omega_e[-1])
    out = np.zeros(3)
    for t, w in zip(theta, weights, strict=True):
        chi = math.remainder(float(wave.heading) + t, 2 * math.pi)
        c = math.cos(chi)
        omegas, jac = (np.asarray(x) for x in encounter_branches(omega_e, float(wave.speed) * abs(c), c > 0))
        for b in range(3):
            ob = omegas[:, b]
            f = (-1 if chi < 0 else 1) * np.asarray(table.transfer(ob, abs(chi)))
            f = np.conj(f) if b == 2 else f
            g = np.asarray(grim_transfer(ob**2 / G * abs(c), float(wave.length)))
            s = np.where(interior & (jac[:, b] > 0), np.asarray(wave.sea(ob)) * jac[:, b], 0.0) * domega * w
            out += [np.sum(s * g * g), np.sum(s * np.abs(f) ** 2), np.sum(s * g * np.real(f))]
    return out


@pytest.mark.parametrize(("heading", "speed"), [(math.pi / 3, 3.0), (math.pi, 0.0)])
def test_moment_and_effective_wave_in_a_spread_sea(moment_ship, heading, speed):
    """A ship carrying its wave moment in a short-crested sea (cos2s:3, 8 directions): ζ_G and M_w of a realization
    are made of the same components of every direction, so E[ζ_G²], E[M_w²] and E[ζ_G M_w] of 40 records of
    4000 s are the exact sums over directions and branches within 3 standard errors. In head seas the moment is
    not zero (the oblique directions) but uncorrelated with ζ_G (the directions ±θ cancel); the spectrum of
    `WaveMomentExcitation` integrates to the same E[M_w²]."""
    from jaxroll import SuperpositionExcitation, WaveMomentExcitation
    from jaxroll.roll._excitation import _padded_length
    from jaxroll.sea._grim import superposition_length
    from jaxroll.sea._spectra import spectral_moment

    sea, dt, n = ITTC(3.0, 10.0), 0.25, 16000
    sp = Spreading("cos2s", 3.0, num_directions=8)
    problem = RollProblem.from_sea(
        moment_ship, sea, speed=speed, heading=heading, dt=dt, phi0=0.0, spreading=sp
    )
    assert isinstance(problem.excitation, SuperpositionExcitation) and problem.excitation.joint
    assert isinstance(problem.moment_excitation, WaveMomentExcitation)
    zsrc, msrc = problem.excitation, problem.moment_excitation

    def records(key):
        return zsrc.init(key, n, 1, jnp.float64)[0][0], msrc.init(key, n, 1, jnp.float64)[0][0]

    zeta, mw = (np.asarray(r)[:, :n] for r in jax.jit(jax.vmap(records))(jr.split(jr.key(7), 40)))
    size = superposition_length(_padded_length(n, 1))
    want = _exact_joint(problem, dt, size)
    assert (
        abs(float(spectral_moment(msrc.spectrum, 0)) / want[1] - 1) < 0.01
    )  # the table's ω grid vs FFT bins
    for name, per, w in zip(
        ("E[ζ_G²]", "E[M_w²]", "E[ζ_G M_w]"),
        ((zeta**2).mean(1), (mw**2).mean(1), (zeta * mw).mean(1)),
        want,
        strict=True,
    ):
        se = per.std(ddof=1) / math.sqrt(per.size)
        print(
            f"χ {math.degrees(heading):.0f}° U {speed}: {name} MC {per.mean():.4g} ± {se:.2g}, exact {w:.4g}"
        )
        assert abs(per.mean() - w) < 3 * se + 1e-9 * abs(want[1])
    scale = math.sqrt(want[0] * want[1])
    if heading == math.pi:
        assert want[1] > 0 and abs(want[2]) < 1e-12 * scale
    else:
        assert abs(want[2]) > 0.1 * scale


def test_theories_refuse_a_moment_ship_in_a_spread_head_sea(moment_ship):
    """A short-crested head sea brings the moment into the roll of a ship that carries one: the parametric-only
    theories refuse it with the reason, as at oblique headings."""
    from jaxroll.theory import roberts_pdf

    wave = EffectiveWave(ITTC(3.0, 10.0), moment_ship.lpp, 0.0, "head", spreading=Spreading("cosn", 2.0))
    with pytest.raises(ValueError, match="direct wave moment"):
        roberts_pdf(moment_ship, wave)


@pytest.mark.parametrize("command", ["pdf", "theory", "maxima", "risk", "sweep"])
@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("cos2s:0", r"--spreading: the spreading exponent must be a finite number > 0"),
        ("cosn:-2", r"--spreading: the spreading exponent must be a finite number > 0"),
        ("cos4:2", r"--spreading: spreading must be cos2s:S, cosn:N"),
    ],
)
def test_cli_refuses_a_bad_spreading_before_any_computation(
    command, value, message, tmp_path, monkeypatch, capsys
):
    """`--spreading` with an exponent ≤ 0 or an unknown kind: `jaxroll CMD: error: --spreading: …`, exit 2, nothing
    written, no problem built."""
    import re

    import jaxroll
    from jaxroll._cli import main

    def boom(*args, **kwargs):
        raise AssertionError("computation started before the options were checked")

    monkeypatch.setattr(jaxroll.RollProblem, "from_sea", boom)
    monkeypatch.setattr(jaxroll, "EffectiveWave", boom)
    out = tmp_path / "out"
    assert main([command, "--spreading", value, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert re.search(message, err) and err.count("\n") == 1, err
    assert not out.exists()


def test_cli_theory_in_a_spread_sea(tmp_path, capsys):
    """`jaxroll theory --spreading cos2s:2`: the theories take the spread S_G (Roberts' median amplitude below the
    long-crested sea's, as S_G(2ω0) is lower), the JSON records the spreading, the output says so."""
    import json

    from jaxroll._cli import main

    medians = {}
    for value in ("none", "cos2s:2"):
        out = tmp_path / value.replace(":", "_")
        assert (
            main(["theory", "--theory", "roberts", "--hs", "5", "--spreading", value, "--out", str(out)]) == 0
        )
        d = json.loads((out / "theory.json").read_text())
        assert d["config"]["spreading"] == value
        medians[value] = d["theory"]["roberts"]["quantiles_deg"]["50"]
    assert "Short-crested sea: spreading cos2s:2" in capsys.readouterr().out
    assert 0 < medians["cos2s:2"] < medians["none"]


def test_cli_pdf_in_a_spread_sea(tmp_path, capsys):
    """`jaxroll pdf --spreading cosn:2`: the Monte Carlo runs (the filter, fitted to the spread S_G), the JSON
    records the spreading and the sea line names it."""
    import json

    from jaxroll._cli import main

    out = tmp_path / "run"
    argv = ["pdf", "--realizations", "6", "--duration", "600", "--theory", "none", "--spreading", "cosn:2"]
    assert main([*argv, "--out", str(out), "--quiet"]) == 0
    d = json.loads((out / "pdf.json").read_text())
    assert d["config"]["spreading"] == "cosn:2" and d["config"]["method"] == "filter"
    printed = capsys.readouterr().out
    assert "head seas, short-crested cosn:2" in printed


def test_longterm_in_a_spread_sea(tmp_path):
    """`jaxroll.longterm(spreading=)` by theory on a small scatter (the passage risk takes the spread S_G): head-sea
    cells below the long-crested ones' (S_G(2ω0) lower), beam seas computed by theory (no longer `no_excitation`:
    the other directions excite the roll parametrically), the spreading in the configuration and in the recorded
    `jaxroll risk` command of a cell."""
    import jaxroll as jxr
    from jaxroll.longterm import METHODS
    from jaxroll.longterm._dataset import config_of, risk_command

    csv = tmp_path / "small.csv"
    csv.write_text("hs_m,8.5,9.5\n5.5,10,20\n7.5,5,0\n")
    kwargs = dict(headings=[math.pi, math.pi / 2], angles=(math.radians(25.0),), exposure=1800.0)
    long_crested = jxr.longterm(csv, **kwargs)
    spread = jxr.longterm(csv, spreading=Spreading("cos2s", 2.0), **kwargs)
    assert config_of(spread)["spreading"] == "cos2s:2" and config_of(long_crested)["spreading"] == "none"
    head = dict(hs=5.5, heading_deg=180.0)
    p0, p1 = (ds.probability.sel(**head).values for ds in (long_crested, spread))
    print("head seas P(25°):", p0.ravel(), "long-crested;", p1.ravel(), "cos2s:2")
    assert np.all(p1 < p0)
    beam = spread.sel(hs=5.5, heading_deg=90.0)
    assert np.all(beam.method.values == METHODS.index("theory"))
    assert np.all(long_crested.sel(hs=5.5, heading_deg=90.0).method.values == METHODS.index("no_excitation"))
    index = {"hs": 0, "tz": 0, "heading_deg": 0, "speed": 0, "ship": 0}
    assert risk_command(spread, index).endswith("--spreading cos2s:2")


def test_a_joint_pair_of_two_seas_is_refused(moment_ship):
    """ζ_G of a short-crested sea with the moment of a long-crested one would be two different seas in one run:
    refused with the reason."""
    from jaxroll import SuperpositionExcitation, WaveMomentExcitation
    from jaxroll.roll._excitation import joint_init
    from jaxroll.ship import roll_inertia

    sea, heading = ITTC(3.0, 10.0), math.radians(120)
    wave = EffectiveWave(
        sea, moment_ship.lpp, 0.0, heading, spreading=Spreading("cos2s", 4, num_directions=4)
    )
    table = moment_ship.wave_moment.per_inertia(roll_inertia(moment_ship))
    moment = WaveMomentExcitation(sea, table, 0.25, heading=heading)
    with pytest.raises(ValueError, match="must have the same spreading"):
        joint_init(SuperpositionExcitation(wave, 0.25, joint=True), moment, jr.key(0), 400, 1, jnp.float64)
