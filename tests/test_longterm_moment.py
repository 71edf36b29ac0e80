"""Long-term risk of a ship carrying a direct wave moment (issue 44, item 6): beam seas no longer 0, the moment
cells simulated with the whole excitation (the superposition: ζ_G and M_w from the same waves), the parametric-only
probability beside the total per cell and over the long term, the theory refused where it cannot cover the moment,
and the outputs (JSON, netCDF, polar chart) carrying both. Tiny tables: one sea state, a few trials."""

import json
import math

import equinox as eqx
import jax
import numpy as np
import pytest

import jaxroll as jxr
from jaxroll._cli import main
from jaxroll.longterm import METHODS
from jaxroll.ship import c11_hull, c11_hull_loading, c11_hull_ship, wave_moment

#: A swell (T_z 17.5 s: T01 19 s) whose energy reaches the roll's resonance (24.4 s): beam seas roll ~1–2° rms.
SWELL = "hs_m,17.5\n2.5,1\n"
ANGLES_DEG = (3.0, 6.0)
RUN = dict(exposure=600.0, discard=300.0, dt=0.25, hours_per_year=100.0, seed=3)


@pytest.fixture(scope="module")
def moment_ship():
    """The C11-like hull's ship carrying its Froude–Krylov moment (every 15°, ω to 4 rad/s)."""
    ship = c11_hull_ship()
    table = wave_moment(c11_hull(), c11_hull_loading(), ship, omega=np.linspace(0.0, 4.0, 201))
    return eqx.tree_at(lambda s: s.wave_moment, ship, table, is_leaf=lambda x: x is None)


@pytest.fixture(scope="module")
def swell_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("scatter") / "swell.csv"
    path.write_text(SWELL)
    return path


@pytest.fixture(scope="module")
def mc_run(moment_ship, swell_csv):
    return jxr.longterm(
        swell_csv,
        [moment_ship],
        headings=np.radians([90.0, 120.0, 240.0]),
        angles=np.radians(ANGLES_DEG),
        method="monte-carlo",
        realizations=24,
        **RUN,
    )


def test_beam_seas_are_simulated_with_the_moment_and_reproduce_the_cell(mc_run, moment_ship):
    """The beam cell is a Monte Carlo of the whole excitation (not `no_excitation`, not 0) whose parametric-only
    share is 0 exactly; its counts are `monte_carlo_max_roll`'s of the cell's problem (superposition) trial for
    trial."""
    ds = mc_run
    beam = ds.isel(hs=0, tz=0, speed=0, ship=0).sel(heading_deg=90.0)
    assert int(beam.method) == METHODS.index("monte_carlo") and bool(beam.direct_moment)
    assert int(beam.realizations) == 24
    assert float(beam.probability[0]) > 0.2  # 1–2° rms in this swell: 3° is crossed in most exposures
    np.testing.assert_array_equal(beam.parametric_probability.values, 0.0)
    problem = jxr.RollProblem.from_sea(
        moment_ship,
        jxr.ITTC(2.5, float(beam.t01)),
        heading=math.pi / 2,
        excitation="superposition",
        dt=0.25,
    )
    assert problem.moment_excitation is not None
    stats = jxr.monte_carlo_max_roll(
        problem,
        jax.random.key(int(beam.seed)),
        angle_deg=3.0,
        num_realizations=24,
        duration=900.0,
        discard=300.0,
    )
    for a, angle in enumerate(ANGLES_DEG):
        assert int(beam.n_exceeded[a]) == stats.exceedances(angle)
    # the recorded `jaxroll risk` command runs the superposition (the moment from the same waves)
    summary = jxr.longterm_summary(ds)
    row = summary["longterm"]["3"]
    cmd = next(c["risk_command"] for c in row["dominating_cells"] if c["heading_deg"] == 90.0)
    assert "--method superposition" in cmd


def test_oblique_cells_carry_the_parametric_only_probability_and_the_long_term_sums(mc_run):
    """120° and 240° are one class (port and starboard); P_param of a moment cell off beam seas is a Monte Carlo of
    the ship without its moment (here no parametric roll reaches 3°: 0); the long-term P_param = Σ w P_param and
    the share P_param,LT / P_LT are reported (dataset and JSON)."""
    ds = mc_run
    cells = ds.isel(hs=0, tz=0, speed=0, ship=0)
    np.testing.assert_array_equal(
        cells.probability.sel(heading_deg=120.0), cells.probability.sel(heading_deg=240.0)
    )
    assert bool(cells.direct_moment.sel(heading_deg=120.0))
    assert float(cells.probability.sel(heading_deg=120.0)[0]) > 0
    w = ds.weight.values[..., None]
    for lt_name, name in (("longterm_probability", "probability"), ("longterm_parametric_probability",
                          "parametric_probability")):  # fmt: skip
        np.testing.assert_allclose(
            ds[lt_name].values, (w * ds[name].values).sum(axis=(0, 1, 2, 3, 4)), rtol=1e-14
        )
    lt, lt_par = ds.longterm_probability.values, ds.longterm_parametric_probability.values
    assert lt[0] > 0 and lt_par[0] == 0.0 and float(ds.longterm_parametric_share[0]) == 0.0
    row = jxr.longterm_summary(ds)["longterm"]["3"]
    assert row["parametric_probability"] == 0.0 and row["parametric_share"] == 0.0
    assert ds.parametric_probability.attrs["units"] == "1"
    lo, hi = ds.longterm_parametric_probability_ci95.values[0]
    assert lo == 0.0 < hi < 0.1  # 0 of 24 trials at 120°/240° (their weight 2/3): sampling, Agresti–Coull


def test_theory_refuses_and_auto_simulates_the_moment_cells(moment_ship, swell_csv, tmp_path, capsys):
    """`method="theory"` cannot give a moment cell (API and CLI, exit 2, one line); head seas keep the theory."""
    with pytest.raises(ValueError, match=r"carries a direct wave moment.*heading\(s\) 90°.*method='auto'"):
        jxr.longterm(swell_csv, [moment_ship], headings=np.radians([180.0, 90.0]), method="theory")
    from jaxroll.io import ship_to_toml

    path = tmp_path / "ship.toml"
    path.write_text(ship_to_toml(moment_ship))
    argv = ["longterm", "--scatter", str(swell_csv), "--ship", str(path), "--heading", "180,90", "--out",
            str(tmp_path / "out")]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("jaxroll longterm: ") and "direct wave moment" in err[0]


def test_cli_writes_both_probabilities_and_the_polar_chart_draws_both(
    moment_ship, swell_csv, tmp_path, capsys
):
    """`jaxroll longterm --method auto` on a ship file carrying the moment: beam seas by the
    Monte Carlo (and head seas too: T01 19 s is outside the theory's validated map); longterm.json and longterm.nc
    carry P and P_param with units, the summary prints both, and the polar chart has a parametric-only panel per
    angle. A cell without the moment has P_param = P."""
    from jaxroll.io import read_dataset, ship_to_toml
    from jaxroll.plotting import longterm_polar_figure

    path = tmp_path / "ship.toml"
    path.write_text(ship_to_toml(moment_ship))
    out = tmp_path / "lt"
    argv = ["longterm", "--scatter", str(swell_csv), "--ship", str(path), "--heading", "180,90", "--angle", "3",
            "--method", "auto", "--realizations", "8", "--hours", "0.1667", "--discard", "300", "--dt", "0.25",
            "--out", str(out), "--quiet"]  # fmt: skip
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "parametric only (direct wave moment off)" in printed
    payload = json.loads((out / "longterm.json").read_text())
    row = payload["longterm"]["3"]
    assert row["probability"] > 0 and row["parametric_probability"] == 0.0
    ds = read_dataset(out / "longterm.nc")
    assert ds["longterm_parametric_probability"].attrs["units"] == "1"
    cells = ds.isel(hs=0, tz=0, speed=0, ship=0)
    head = cells.sel(heading_deg=180.0)  # no moment in head seas: the paper's model, P_param = P
    assert not bool(head.direct_moment)
    np.testing.assert_array_equal(head.parametric_probability.values, head.probability.values)
    assert int(cells.method.sel(heading_deg=90.0)) == METHODS.index("monte_carlo")
    assert int(cells.realizations.sel(heading_deg=90.0)) == 8
    fig = longterm_polar_figure(ds)
    titles = [ax.xaxis.get_label().get_text() for ax in fig.axes]
    assert any("parametric only" in t for t in titles) and any(
        "with the direct wave moment" in t for t in titles
    )
