"""Rare cells of `jaxroll.longterm` by multilevel splitting (`estimator="splitting"`, `--estimator splitting`): the
rule that picks them, a splitting cell against brute force of the same cell, what the dataset and the summary
say about them, parts and checkpoints bit for bit, bad input (docs/longterm.md, "Rare cells").

Every Monte Carlo here has the same exposure, discard and runs a stage, so the stage programs compile once."""

import math

import jax
import numpy as np
import pytest
import xarray as xr
from helpers import SHIP

import jaxroll as jxr
from jaxroll._cli import main
from jaxroll.io import read_dataset, write_dataset
from jaxroll.longterm import METHODS, T01_OVER_TZ, _run as run
from jaxroll.longterm._monte_carlo import ESTIMATORS
from jaxroll.longterm._risk import rare_cells

ANGLES = (math.radians(25.0), math.radians(30.0))
TZ = 10.0 / T01_OVER_TZ  # T01 = 10 s
#: H1/3 5 m: P(30° within 900 s after 200 s) ≈ 0.011 (60 000 brute-force trials: 0.01098 ± 0.0004, 25°: 0.0430);
#: 7 m: far above 0.05.
TWO = f"hs_m,{TZ!r}\n5.0,1\n7.0,1\n"
KW = dict(angles=ANGLES, exposure=900.0, discard=200.0, method="monte-carlo", realizations=100)


def _flag(name):
    return ESTIMATORS.index(name)


@pytest.fixture(scope="module")
def two_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("scatter") / "two.csv"
    path.write_text(TWO)
    return path


@pytest.fixture(scope="module")
def split_run(two_csv):
    """Both cells by Monte Carlo, the rare one (pilot: P(30°) < 0.05) by splitting."""
    return jxr.longterm(two_csv, estimator="splitting", rare_below=0.05, seed=3, **KW)


def test_rare_cell_rule():
    # auto: a Monte Carlo cell is rare where the theory's P at its largest angle (the smallest P) < rare_below
    trials = np.array([100, 100, 0, 100])
    p = np.array([[0.2, 1e-4], [0.2, 2e-3], [1e-6, 1e-7], [np.nan, np.nan]])
    assert rare_cells(trials, p, 1e-3).tolist() == [True, False, False, False]
    assert rare_cells(trials, p, 1.0).tolist() == [True, True, False, False]


def test_splitting_cell_agrees_with_brute_force_and_is_marked(split_run):
    ds = split_run.isel(tz=0, heading_deg=0, speed=0, ship=0)
    rare, common = ds.isel(hs=0), ds.isel(hs=1)
    assert int(rare.estimator) == _flag("splitting") and int(common.estimator) == _flag("brute_force")
    assert split_run.estimator.attrs["flag_meanings"] == "none brute_force splitting"
    # no trial counts for splitting; the brute-force cell's are its trials'
    assert rare.n_exceeded.values.tolist() == [-1, -1] and int(rare.n_capsized) == -1
    assert (rare.n_exceeded_effort.values == -1).all()
    assert int(rare.realizations) == int(common.realizations) == 100
    # the cost in trials: the brute-force cell's 100 and the pilot that screened it; the splitting run's with its pilot
    assert float(common.cost_trials) > 100 and float(rare.cost_trials) > 0
    assert int(common.n_exceeded[0]) == round(100 * float(common.probability[0]))
    # the splitting cell against 10 000 brute-force trials of the same cell (another key): within 4 combined
    # standard errors at each angle (splitting's from its genealogy, the brute force's binomial)
    problem = jxr.RollProblem.from_sea(SHIP, jxr.ITTC(5.0, float(rare.t01)), heading="head")
    bf = jxr.monte_carlo_max_roll(  # in chunks of the cells' 100 trials: no new program
        problem,
        jax.random.key(99),
        angle_deg=25.0,
        num_realizations=10_000,
        duration=1100.0,
        discard=200.0,
        chunk_size=100,
    )
    for a, angle in enumerate((25.0, 30.0)):
        pb = bf.exceedances(angle) / bf.n_realizations
        ps, var = float(rare.probability[a]), float(rare.probability_variance[a])
        assert 0 < ps and 0 < var < ps**2  # a genealogy variance, relative error < 1
        assert float(rare.probability_lower[a]) < ps < float(rare.probability_upper[a])
        se = math.sqrt(var + pb * (1 - pb) / bf.n_realizations)
        assert abs(ps - pb) < 4 * se, (angle, ps, pb, se)
    assert float(rare.probability[1]) < float(rare.probability[0])
    # the cell is `monte_carlo_splitting_angles` with the cell's seed, bit for bit
    direct = jxr.monte_carlo_splitting_angles(
        problem, jax.random.key(int(rare.seed)), angles_deg=[25.0, 30.0], exposure=900.0, discard=200.0,
        num_trials=100,
    )  # fmt: skip
    assert [r.probability for r in direct] == rare.probability.values.tolist()
    assert [r.standard_error**2 for r in direct] == rare.probability_variance.values.tolist()
    # no capsize at 5 m: an estimate of 0 whose interval and variance still say how sure it is
    assert float(rare.capsize_probability) == 0.0 and float(rare.capsize_probability_upper) > 0
    assert float(rare.capsize_probability_variance) > 0


def test_splitting_in_the_summary(split_run):
    s = jxr.longterm_summary(split_run)
    assert s["monte_carlo_estimators"] == {"brute_force": 1, "splitting": 1}
    rows = {row["hs_m"]: row for row in s["longterm"]["30"]["dominating_cells"]}
    assert rows[5.0]["estimator"] == "splitting" and "risk_command" not in rows[5.0]
    assert rows[7.0]["estimator"] == "brute_force" and "--seed" in rows[7.0]["risk_command"]
    effort = s["ci_against_effort"]
    assert effort["splitting_cells"] == 1
    # the splitting cell enters every point with its whole run: the half-width at full effort is the interval's
    z = 1.959963984540054
    np.testing.assert_allclose(
        effort["sampling_half_width"][-1], z * split_run.longterm_sampling_sd.values, rtol=1e-12, atol=0
    )
    w = float(split_run.weight.values.ravel()[0])
    var = split_run.probability_variance.values.reshape(2, 2)[0]
    np.testing.assert_allclose(effort["splitting_half_width"], z * w * np.sqrt(var), rtol=1e-12, atol=0)
    cost = float(split_run.cost_trials.values.ravel()[0])
    assert effort["trials"][-1] == 100 + round(cost) and effort["trials"][0] == 6 + round(cost)


def test_auto_sends_the_rare_dominant_cells_to_splitting(two_csv, split_run, monkeypatch):
    # The theory replaced by fixed values (no theory solve): both cells dominate (auto), the 5 m cell's P at 30°
    # is below rare_below, the 7 m cell's is not: one splitting cell, one brute-force cell, 100 trials each — the
    # cells `split_run` chose by its pilots, so the same runs, bit for bit.
    def fake_theory(ship, template, hs, t01, angles, exposure, tick, *, weight, refine_delta):
        n = len(hs)
        tick(n)
        p30 = np.where(np.asarray(hs) < 6, 1e-3, 0.2)
        return {
            "probability": np.stack([np.full(n, 0.3), p30], axis=-1),
            "capsize_probability": np.zeros(n),
            "lyapunov_exponent": np.full(n, 0.01),
            "envelope_gamma": np.full(n, 0.1),
            "pass1_probability": np.stack([np.full(n, 0.3), p30], axis=-1),
            "pass1_capsize_probability": np.zeros(n),
            "refined": np.ones(n, bool),
            "pass_ratio": np.ones(n),
            "pass_capsize_ratio": np.ones(n),
        }

    monkeypatch.setattr(run, "class_template", lambda *a: None)
    monkeypatch.setattr(run, "class_theory", fake_theory)
    kw = {**KW, "method": "auto"}
    ds = jxr.longterm(two_csv, estimator="splitting", rare_below=0.01, seed=3, **kw)
    est = ds.estimator.values.ravel().tolist()
    assert est == [_flag("splitting"), _flag("brute_force")]
    assert ds.realizations.values.ravel().tolist() == [100, 100]
    assert ds.method.values.ravel().tolist() == [METHODS.index("monte_carlo")] * 2
    assert ds.attrs["config_json"].count('"rare_below": 0.01') == 1
    for v in ("probability", "probability_variance", "probability_lower", "capsize_probability"):
        np.testing.assert_array_equal(ds[v].values, split_run[v].values, err_msg=v)


def _same(a, b):
    xr.testing.assert_identical(a, b)
    for v in a.variables:
        np.testing.assert_array_equal(a[v].values, b[v].values, err_msg=v)


def test_splitting_cells_parts_and_checkpoint_bit_for_bit(two_csv, split_run, tmp_path):
    kw = dict(estimator="splitting", rare_below=0.05, seed=3, **KW)

    def roundtrip(ds, path):
        write_dataset(path, ds)
        return read_dataset(path)

    parts = [roundtrip(jxr.longterm(two_csv, part=f"{i}/2", **kw), tmp_path / f"p{i}.nc") for i in (1, 2)]
    assert [int(p.computed.values.sum()) for p in parts] == [1, 1]
    _same(roundtrip(jxr.merge_longterm(parts), tmp_path / "m.nc"), roundtrip(split_run, tmp_path / "w.nc"))

    class Interrupt(Exception):
        pass

    def stop_in_the_second_cell(done, total, phase):
        if done > 100:
            raise Interrupt

    with pytest.raises(Interrupt):
        jxr.longterm(two_csv, checkpoint=tmp_path / "ck", progress=stop_in_the_second_cell, **kw)
    assert len(list((tmp_path / "ck").glob("mc_*.npz"))) == 1
    seen = []
    resumed = jxr.longterm(two_csv, checkpoint=tmp_path / "ck", progress=lambda d, t, p: seen.append(d), **kw)
    assert seen[0] == 100  # the first cell came from its checkpoint
    _same(resumed, split_run)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(estimator="splitting", rare_below=0.0), r"`rare_below` must be in \(0, 1\]"),
        (dict(estimator="splitting", rare_below=1.5), r"`rare_below` must be in \(0, 1\]"),
        (dict(estimator="splitting", excitation="superposition"), "`estimator='splitting'` needs excitation"),
    ],
)
def test_bad_input(kwargs, message, two_csv):
    with pytest.raises(ValueError, match=message):
        jxr.longterm(two_csv, **{**KW, **kwargs})


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--rare-below", "0"], "--rare-below must be a probability in (0, 1]"),
        (["--rare-below", "nan"], "--rare-below must be a probability in (0, 1]"),
        (["--excitation", "superposition"], "--estimator splitting needs --excitation filter"),
    ],
)
def test_bad_options_exit_2(extra, message, two_csv, tmp_path, capsys):
    argv = ["longterm", "--scatter", str(two_csv), "--heading", "180", "--method", "monte-carlo"]
    assert main([*argv, "--estimator", "splitting", *extra, "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "jaxroll longterm: error: " + message in err and not (tmp_path / "x").exists()
