"""Yaw (issue 44, item 4; docs/yaw.md): the heading an Ornstein–Uhlenbeck process along the run."""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll
from jaxroll.roll._excitation import encounter_components, joint_init
from jaxroll.roll._yaw import YAW_KEY, yaw_path
from jaxroll.sea import grim_transfer
from jaxroll.sea._grim import superposition_length

DEG = math.pi / 180


@pytest.fixture(scope="module")
def moment_ship():
    """The default ship carrying the C11-like hull's Froude–Krylov moment (15° table, per its own inertia)."""
    ship = jaxroll.c11_representative()
    table = jaxroll.wave_moment(
        jaxroll.c11_hull(), jaxroll.ship.c11_hull_loading(), ship, omega=np.linspace(0.0, 4.0, 201)
    )
    return eqx.tree_at(lambda s: s.wave_moment, ship, table, is_leaf=lambda x: x is None)


def _brute_force(problem, key, num_steps):
    """ζ_G and M_w on the half steps by the direct sum over the realization's components, each weighted at the
    heading χ0 + ψ(t) of that instant: Grim's G(k|cos χ|) exactly, the moment by the table (`WaveMoment.transfer`,
    folded to [0, π] with F(−χ) = −F(χ))."""
    exc = problem.excitation
    dt = problem.dt
    n = -(-num_steps // 128) * 128 + 1
    size = superposition_length(n)
    omega_e, omegas, amps = encounter_components(exc.wave.sea, 0.0, exc.wave.following, key, size, dt)
    w, a = np.asarray(omegas[:, 0]), np.asarray(amps[:, 0]) * 2 / size  # one branch at zero speed
    t = np.arange(2 * n - 1) * dt / 2
    psi = np.asarray(yaw_path(exc.yaw.yaw, key, 2 * n - 1, dt / 2))
    chi = float(exc.wave.heading) + psi
    phase = np.exp(1j * np.outer(t, w))  # [time, component]
    g = np.asarray(grim_transfer(np.outer(np.abs(np.cos(chi)), w**2 / 9.80665), exc.wave.length))
    zeta = np.real(np.sum(g * a * phase, axis=1))
    folded = np.remainder(chi + math.pi, 2 * math.pi) - math.pi  # (−π, π]
    table = problem.ship.wave_moment.per_inertia(jaxroll.ship.roll_inertia(problem.ship))
    rows = np.stack([np.sign(c) * np.asarray(table.transfer(w, abs(c))) for c in folded])
    moment = np.real(np.sum(rows * a * phase, axis=1))
    return zeta, moment


def test_yawed_synthesis_is_the_direct_sum(moment_ship):
    """The node interpolation against the direct sum over a short record's components (≈ 130 of them, 100 s), head
    and oblique seas: M_w to round-off on the time steps (the table's own interpolation in χ), ζ_G within the
    nodes' stated error."""
    key = jax.random.key(3)
    for heading, std, dt in (("head", 5 * DEG, 0.4), (120 * DEG, 2 * DEG, 0.3)):
        yaw = jaxroll.Yaw(std, 20.0)
        problem = jaxroll.RollProblem.from_sea(
            moment_ship, jaxroll.ITTC(3.0, 10.0), heading=heading, dt=dt, phi0=0.0, yaw=yaw
        )
        num_steps = 250
        (zs, z0), (ms, m0) = joint_init(
            problem.excitation, problem.moment_excitation, key, num_steps, 1, jnp.float64
        )
        zeta, moment = _brute_force(problem, key, num_steps)
        zs, ms = np.asarray(zs[0]), np.asarray(ms[0])
        steps = slice(0, None, 2)  # on the time steps: no Hermite midpoint, only the heading's interpolation
        m_scale, z_scale = np.std(moment), np.std(zeta)
        assert m_scale > 0 and z_scale > 0
        assert np.max(np.abs(ms[steps] - moment[steps])) < 1e-9 * m_scale
        # ζ_G: the nodes' stated rms error (8e-4, 1.1e-3 σ_G here); measured max 1.3e-3, 2.5e-3 σ_G
        error = problem.excitation.yaw.error
        assert 0 < error < 2e-3
        assert np.max(np.abs(zs[steps] - zeta[steps])) < 4 * error * z_scale
        # midpoints too: the nodes' cubic Hermite interpolation, O(dt⁴) (M_w: measured 9e-5, 3e-5 of σ)
        assert np.max(np.abs(ms - moment)) < 5e-4 * m_scale
        assert np.max(np.abs(zs - zeta)) < 4 * error * z_scale
        assert float(z0) == zs[0] and float(m0) == ms[0]


def test_yaw_path_is_the_ornstein_uhlenbeck_process():
    """ψ over 400 keys: E[ψ²] = σ², E[ψ(t)ψ(t + s)] = σ² e^{−s/τ} at s = 10, 30 s, within 4 standard errors."""
    yaw = jaxroll.Yaw(3 * DEG, 20.0)
    keys = jax.random.split(jax.random.key(0), 400)
    psi = np.asarray(jax.vmap(lambda k: yaw_path(yaw, k, 801, 0.25))(keys))  # 200 s
    for lag_s in (0.0, 10.0, 30.0):
        lag = int(lag_s / 0.25)
        prod = psi[:, : psi.shape[1] - lag] * psi[:, lag:]
        per_key = prod.mean(axis=1)
        se = per_key.std(ddof=1) / math.sqrt(per_key.size)
        exact = yaw.std**2 * math.exp(-lag_s / yaw.correlation_time)
        assert abs(per_key.mean() - exact) < 4 * se, (lag_s, per_key.mean(), exact, se)
    assert np.all(np.abs(psi[:, 0]) < 6 * yaw.std)


def test_moment_variance_under_yaw(moment_ship):
    """E[M_w(t)²] at zero speed = E_ψ[Σ_ω |F(ω, χ0 + ψ)/I44|² S(ω) Δω] (ψ Gaussian, by Gauss–Hermite): head seas,
    where without yaw M_w ≡ 0; 60 records of 3000 s, within 3 standard errors."""
    yaw = jaxroll.Yaw(4 * DEG, 15.0)
    sea = jaxroll.ITTC(3.0, 10.0)
    problem = jaxroll.RollProblem.from_sea(moment_ship, sea, dt=0.3, phi0=0.0, yaw=yaw)
    keys = jax.random.split(jax.random.key(7), 60)
    init = jax.jit(
        jax.vmap(lambda k: joint_init(None, problem.moment_excitation, k, 10000, 1, jnp.float64)[0][0][0])
    )
    per_key = np.mean(np.asarray(init(keys)) ** 2, axis=1)
    table = moment_ship.wave_moment.per_inertia(jaxroll.ship.roll_inertia(moment_ship))
    w = np.linspace(0.0, 4.0, 4001)
    s = np.asarray(sea(jnp.asarray(w)))
    x, weights = np.polynomial.hermite_e.hermegauss(40)
    exact = 0.0
    for xi, wi in zip(x, weights, strict=True):
        chi = math.pi - abs(xi * yaw.std)  # |F| is the same at π + ψ and π − ψ
        f2 = np.abs(np.asarray(table.transfer(w, chi))) ** 2
        exact += wi / math.sqrt(2 * math.pi) * np.trapezoid(f2 * s, w)
    se = per_key.std(ddof=1) / math.sqrt(per_key.size)
    assert exact > 0
    assert abs(per_key.mean() - exact) < 3 * se, (per_key.mean(), exact, se)


def test_no_yaw_is_todays_problem(moment_ship):
    """yaw=None and a σ_ψ of 0 build today's problem exactly (the same pytree, the same realization)."""
    sea = jaxroll.ITTC(7.0, 10.0)
    for ship, heading in ((jaxroll.c11_representative(), "head"), (moment_ship, 120 * DEG)):
        base = jaxroll.RollProblem.from_sea(ship, sea, heading=heading, dt=0.25)
        for yaw in (None, jaxroll.Yaw(0.0, 30.0)):
            other = jaxroll.RollProblem.from_sea(ship, sea, heading=heading, dt=0.25, yaw=yaw)
            assert bool(eqx.tree_equal(base, other))
        assert getattr(base.excitation, "yaw", None) is None
    key = jax.random.key(1)
    a = jaxroll.roll_time_series(base, key, 200.0)[0]
    b = jaxroll.roll_time_series(other, key, 200.0)[0]
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_the_chunk_counts_the_yawed_synthesis(moment_ship):
    """The Monte Carlo's memory per realization adds the yawed synthesis' arrays (per node), nothing without yaw."""
    from jaxroll.roll._yaw import yaw_bytes_per_realization

    sea = jaxroll.ITTC(7.0, 10.0)
    plain = jaxroll.RollProblem.from_sea(moment_ship, sea, heading=120 * DEG, dt=0.25)
    assert yaw_bytes_per_realization(plain, 14400) == 0
    yawed = jaxroll.RollProblem.from_sea(moment_ship, sea, dt=0.25, yaw=jaxroll.Yaw(3 * DEG, 30.0))
    nodes = len(yawed.excitation.yaw.nodes) + len(yawed.moment_excitation.yaw.nodes)
    per = yaw_bytes_per_realization(yawed, 14400)
    assert nodes == 3 + 5 and 1.0e6 < per / nodes < 1.3e6  # ≈ 1.2 MB per node for 3600 s at dt 0.25 s


def test_yaw_draws_from_its_own_stream(moment_ship):
    """ψ keyed fold_in(key, YAW_KEY): the wave components of a realization are those without yaw."""
    assert YAW_KEY not in (0x7FFFFFFE, 0x7FFFFFFF)
    sea = jaxroll.ITTC(3.0, 10.0)
    p = jaxroll.RollProblem.from_sea(moment_ship, sea, heading=90 * DEG, dt=0.3, phi0=0.0)
    py = jaxroll.RollProblem.from_sea(
        moment_ship, sea, heading=90 * DEG, dt=0.3, phi0=0.0, yaw=jaxroll.Yaw(1e-9, 30.0)
    )
    key = jax.random.key(2)
    m0 = np.asarray(joint_init(p.excitation, p.moment_excitation, key, 300, 1, jnp.float64)[1][0][0])
    m1 = np.asarray(joint_init(py.excitation, py.moment_excitation, key, 300, 1, jnp.float64)[1][0][0])[::2]
    np.testing.assert_allclose(m1, m0, rtol=0, atol=1e-7 * np.abs(m0).max())


@pytest.mark.parametrize(
    ("std", "tau", "match"),
    [
        (-1 * DEG, 30.0, "between 0 and 45°"),
        (50 * DEG, 30.0, "between 0 and 45°"),
        (float("nan"), 30.0, "between 0 and 45°"),
        (2 * DEG, 0.0, "correlation time must be a finite number > 0"),
        (2 * DEG, -5.0, "correlation time must be a finite number > 0"),
        (2 * DEG, float("inf"), "correlation time must be a finite number > 0"),
    ],
)
def test_bad_yaw(std, tau, match):
    with pytest.raises(ValueError, match=match):
        jaxroll.Yaw(std, tau)


def test_yaw_refusals(moment_ship):
    sea = jaxroll.ITTC(7.0, 10.0)
    yaw = jaxroll.Yaw(2 * DEG, 30.0)
    with pytest.raises(ValueError, match="yaw at forward speed"):
        jaxroll.RollProblem.from_sea(moment_ship, sea, speed=3.0, dt=0.25, yaw=yaw)
    with pytest.raises(ValueError, match="a shaping filter cannot make it"):
        jaxroll.RollProblem.from_sea(moment_ship, sea, excitation="filter", dt=0.25, yaw=yaw)
    problem = jaxroll.RollProblem.from_sea(moment_ship, sea, dt=0.25, phi0=0.0, yaw=yaw)
    with pytest.raises(ValueError, match="linear_roll_variance: the heading yaws"):
        jaxroll.theory.linear_roll_variance(problem)
    plain = jaxroll.SuperpositionExcitation(problem.wave, 0.25, joint=True)
    with pytest.raises(ValueError, match="the same `yaw`"):
        jaxroll.RollProblem(problem.ship, plain, moment_excitation=problem.moment_excitation)


def _cli(*args) -> int:
    from jaxroll._cli import main

    return main(list(args))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["pdf", "--yaw-std", "-1"], "the yaw's standard deviation must be between 0 and 45°"),
        (["maxima", "--yaw-std", "60"], "the yaw's standard deviation must be between 0 and 45°"),
        (["risk", "--yaw-std", "2", "--yaw-time", "0"], "--yaw-time must be a finite number > 0"),
        (["pdf", "--yaw-std", "2", "--speed", "3"], "yaw at forward speed is not modelled"),
        (["pdf", "--yaw-std", "2", "--method", "filter"], "--yaw-std needs --method superposition or auto"),
        (
            ["risk", "--yaw-std", "2", "--estimator", "splitting"],
            "--estimator splitting needs the shaping filter",
        ),
        (["maxima", "--yaw-std", "2", "--theory", "roberts"], "roberts: the heading yaws"),
        (["risk", "--yaw-std", "2", "--theory", "first_passage"], "first_passage: the heading yaws"),
    ],
)
def test_cli_bad_yaw(args, message, tmp_path, capsys):
    assert _cli(*args, "--out", str(tmp_path / "o")) == 2
    err = capsys.readouterr().err
    assert message in err and err.startswith(f"jaxroll {args[0]}: ") and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_cli_pdf_with_yaw(tmp_path, capsys):
    """`jaxroll pdf --yaw-std`: the run's config records the yaw; the default overlay is left out with the reason,
    an asked-for theory is refused."""
    import json

    out = tmp_path / "pdf"
    common = [
        "pdf",
        "--yaw-std",
        "3",
        "--yaw-time",
        "20",
        "--realizations",
        "8",
        "--duration",
        "600",
        "--dt",
        "0.5",
    ]
    assert _cli(*common, "--out", str(out), "--quiet") == 0
    payload = json.loads((out / "pdf.json").read_text())
    assert payload["config"]["yaw"] == {
        "std_deg": 3.0,
        "correlation_time_s": 20.0,
        "model": "Ornstein-Uhlenbeck",
    }
    assert payload["config"]["method"] == "superposition"
    assert "the heading yaws" in payload["theory_left_out"]["roberts"]
    capsys.readouterr()
    assert _cli(*common, "--theory", "esam", "--out", str(tmp_path / "t"), "--quiet") == 2
    assert "esam: the heading yaws" in capsys.readouterr().err


def test_notebook_runs_in_smoke_mode(tmp_path, monkeypatch):
    """notebooks/08_yaw.ipynb top to bottom in smoke mode: the PDFs with and without yaw are densities, the steady
    moment's roll grows off head seas."""
    from helpers import run_notebook

    ns = run_notebook("08_yaw.ipynb", tmp_path, monkeypatch)
    assert set(ns["pdfs"]) == {0, 3}
    for pdf in ns["pdfs"].values():
        assert 0.5 < float(np.sum(pdf)) <= 1.0 + 1e-9  # per degree on 1° bins: the mass below 40°
    steady = ns["steady"]
    assert 0 < steady[5] < steady[15] < steady[30] < steady[90]
