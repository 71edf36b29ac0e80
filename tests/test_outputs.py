"""Labelled results (issue 35): `.to_xarray()` of every result type, each command's netCDF twin of its JSON, and
datasets combined across runs as a user would. The commands' own tests check their .nc files
(`helpers.assert_labelled_output`); here: the result objects, the rule, and the checker itself."""

from __future__ import annotations

import json
import math

import jax
import numpy as np
import pytest
import xarray as xr
from helpers import assert_cf_variables, assert_labelled_output, default_problem

import jaxroll as jxr
from jaxroll._cli._common import write_json, write_netcdf
from jaxroll._labels import Layout, tree_to_dataset
from jaxroll.io import output_dataset, read_dataset, write_dataset


def _has_labels(ds: xr.Dataset) -> None:
    """Every variable and coordinate has a long name, and a UDUNITS unit that pint parses unless it holds text
    labels (or mixes units along a label, and says so)."""
    assert_cf_variables(ds)


@pytest.fixture(scope="module")
def amplitude_stats():
    # the run of test_cli's `jaxroll pdf` (its compiled programs serve both): 6 trials × 600 s of the 7 m sea
    return jxr.monte_carlo_amplitudes(
        default_problem(), jax.random.key(3), num_realizations=6, duration=600.0
    )


def test_amplitude_statistics_to_xarray(amplitude_stats, tmp_path):
    stats = amplitude_stats
    ds = stats.to_xarray()
    _has_labels(ds)
    summary = stats.summary(ds.bins_deg.values)
    # the pdf.json fields, on 1° bins over the fine grid, and the fine histograms themselves
    np.testing.assert_array_equal(ds.bins_deg, np.arange(91.0))
    np.testing.assert_array_equal(ds.pdf_envelope, summary["pdf_envelope"])
    assert ds.n_amplitudes.sel(estimator="zero_crossing") == stats.n_amplitudes("zero_crossing") > 100
    assert int(ds.counts_zero_crossing.sum()) == stats.n_amplitudes("zero_crossing")
    assert int(ds.counts_envelope.sum()) == stats.n_amplitudes("envelope")
    assert (
        ds.quantiles_deg.sel(estimator="envelope", percentile=99)
        == summary["quantiles_deg"]["envelope"]["99"]
    )
    np.testing.assert_allclose(
        ds.mean_amplitude_deg.sel(estimator="envelope"),
        np.rad2deg(stats.mean("envelope")),
        rtol=1e-15,
        atol=0,
    )
    # the per-trial arrays: capsizes, capsize time (inf: none), the largest roll, the exact sums behind the means
    assert ds.capsized.dims == ("realization",) and ds.capsized.dtype == bool and ds.sizes["realization"] == 6
    np.testing.assert_array_equal(ds.capsize_time_s, stats.capsize_time)
    assert np.all(np.isinf(ds.capsize_time_s.values[~stats.capsized]))
    n, s = ds.n_zero_crossing.sum(), ds.sum_zero_crossing_rad.sum()
    np.testing.assert_allclose(
        np.rad2deg(s / n), ds.mean_amplitude_deg.sel(estimator="zero_crossing"), rtol=1e-12
    )
    # the largest envelope amplitude per trial is at least the trial's own quantiles and below the vanishing angle
    largest = ds.max_envelope_deg.values
    assert np.all(largest > ds.quantiles_deg.sel(estimator="envelope", percentile=50).item() * 0.5)
    assert np.all(largest < 71.6) and largest.max() >= ds.quantiles_deg.sel(
        estimator="envelope", percentile=99
    )
    # written and read back: the same numbers, the booleans restored
    write_dataset(tmp_path / "a.nc", ds)
    back = read_dataset(tmp_path / "a.nc")
    assert back.capsized.dtype == bool
    xr.testing.assert_equal(back, ds)


def test_maxima_and_max_roll_to_xarray():
    problem = default_problem()
    # the sizes of test_cli's `jaxroll maxima` and test_scaling's sweep (their compiled programs serve here too)
    maxima = jxr.monte_carlo_maxima(problem, jax.random.key(0), n0=(10, 30), num_realizations=6, chunk_size=6)
    ds = maxima.to_xarray()
    _has_labels(ds)
    assert ds.maxima_deg.dims == ("n0", "realization")
    np.testing.assert_array_equal(ds.maxima_deg.sel(n0=30), maxima.maxima_deg[:, 1])
    # the maximum of the first 30 amplitudes is at least that of the first 10, trial by trial
    assert np.all(ds.maxima_deg.sel(n0=30) >= ds.maxima_deg.sel(n0=10))
    assert ds.n_trials.sel(n0=10) == 6 and list(ds.percentile.values) == [50, 90, 99]
    roll = jxr.monte_carlo_max_roll(
        problem, jax.random.key(1), angle_deg=15.0, num_realizations=5, duration=300.0, chunk_size=4
    )
    dr = roll.to_xarray()
    _has_labels(dr)
    np.testing.assert_array_equal(dr.max_abs_phi_deg, roll.max_abs_phi_deg)
    assert dr.n_exceeded == roll.n_exceeded == int(np.sum((dr.max_abs_phi_deg > 15.0) | dr.capsized))
    lo, hi = roll.exceedance_interval()
    np.testing.assert_array_equal(dr.probability_ci95.sel(bound=["lower", "upper"]), [lo, hi])
    # a second run with other N0 joins the first along `n0`, NaN where one has no trial (as maxima.nc does)
    more = jxr.MaximaStatistics(
        n0=(60,),
        maxima_deg=np.array([[20.0], [np.nan], [25.0], [30.0]]),
        capsized=np.array([False, True, False, False]),
        capsize_time=np.array([np.inf, 900.0, np.inf, np.inf]),
        count=np.array([60, 41, 60, 60]),
    )
    both = xr.concat(
        [ds, more.to_xarray()],
        dim="n0",
        data_vars="minimal",
        coords="minimal",
        compat="override",
        join="outer",
        combine_attrs="drop_conflicts",
    )
    assert list(both.n0.values) == [10, 30, 60] and both.sizes["realization"] == 6
    assert np.isnan(both.maxima_deg.sel(n0=60, realization=5)) and both.n_trials.sel(n0=60) == 4
    assert both.n_capsized.sel(n0=60) == 1 and both.capsize_time_s.sel(n0=60, realization=1) == 900.0


def test_law_to_xarray_rayleigh_closed_form():
    sigma = math.radians(5.0)
    law = jxr.RayleighLaw(sigma)
    ds = law.to_xarray()
    _has_labels(ds)
    a = ds.amplitude_rad.values
    exact_pdf = a / sigma**2 * np.exp(-(a**2) / (2 * sigma**2)) * np.pi / 180
    np.testing.assert_allclose(ds.pdf_per_degree, exact_pdf, rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(ds.sf, np.exp(-(a**2) / (2 * sigma**2)), rtol=1e-12, atol=1e-300)
    # the default grid runs to F̄ = 1e-12: a = σ √(24 ln 10), in 0.1° steps
    top = math.degrees(sigma * math.sqrt(24 * math.log(10)))
    assert top <= ds.amplitude_deg[-1] < top + 0.1 + 1e-9
    np.testing.assert_allclose(ds.mean_amplitude_deg, math.degrees(sigma * math.sqrt(math.pi / 2)), rtol=1e-9)
    np.testing.assert_allclose(
        ds.quantiles_deg.sel(percentile=50), math.degrees(sigma * math.sqrt(2 * math.log(2))), rtol=1e-9
    )
    assert ds.attrs["law"] == "RayleighLaw" and ds.attrs["estimator"] == "zero_crossing"
    own = law.to_xarray(np.array([0.0, 5.0, 10.0]))
    np.testing.assert_allclose(own.sf, np.exp(-np.array([0.0, 0.5, 2.0])), rtol=1e-12)


def test_exposure_risk_to_xarray():
    law = jxr.RayleighLaw(math.radians(5.0))
    r = jxr.exposure_risk(law, math.radians(20.0), rate=0.1, duration=3 * 3600.0, n_amplitudes=5000)
    ds = r.to_xarray()
    _has_labels(ds)
    assert ds.angle_deg == pytest.approx(20.0, rel=1e-14) and ds.n_cycles == pytest.approx(1080.0, rel=1e-14)
    # F̄(20°) = exp(-8) for σ = 5°; at least one of n independent amplitudes exceeds it
    np.testing.assert_allclose(ds.exceedance_per_cycle, math.exp(-8.0), rtol=1e-12)
    np.testing.assert_allclose(ds.probability, 1 - (1 - math.exp(-8.0)) ** 1080, rtol=1e-10)
    assert (
        float(ds.probability_ci95.sel(bound="lower"))
        < float(ds.probability)
        < float(ds.probability_ci95.sel(bound="upper"))
    )
    np.testing.assert_allclose(ds.characteristic_largest_deg, float(r.characteristic_largest_deg), rtol=1e-15)
    assert ds.characteristic_largest_ci95_deg.attrs["units"] == "degree"


def _sweep_result(hs, n_capsized, n_exceeded):
    grid = {"heading": ["head", "135deg"], "speed_m_s": [0.0], "hs_m": list(hs), "t01_s": [10.0]}
    shape = (2, 1, len(hs), 1)
    return jxr.SweepResult(grid, 20, 30.0, 0.95, np.reshape(n_capsized, shape), np.reshape(n_exceeded, shape))


def test_sweep_datasets_combine_across_runs():
    a = _sweep_result([5.0, 7.0], [0, 1, 0, 2], [3, 9, 4, 12]).to_xarray()
    b = _sweep_result([5.0, 7.0], [1, 2, 0, 3], [5, 10, 2, 11]).to_xarray()  # the same grid, another seed
    _has_labels(a)
    np.testing.assert_array_equal(a.heading_deg, [180.0, 135.0])
    assert a.exceedance_probability.sel(heading="135deg", hs_m=7.0).item() == 12 / 20
    # two seeds along a new dimension: pooled counts are the sums, the pooled probability their ratio
    seeds = xr.concat([a, b], dim="seed", data_vars="all", coords="different", compat="equals", join="exact")
    pooled = seeds.n_exceeded.sum("seed") / seeds.n_realizations.sum("seed")
    assert pooled.sel(heading="head", hs_m=7.0, speed_m_s=0.0, t01_s=10.0).item() == (9 + 10) / 40
    # another grid of heights joins along hs_m
    c = _sweep_result([9.0], [5, 6], [15, 16]).to_xarray()
    wide = xr.merge([a, c], join="outer", compat="no_conflicts", combine_attrs="drop_conflicts")
    assert (
        list(wide.hs_m.values) == [5.0, 7.0, 9.0]
        and wide.n_capsized.sel(heading="head", hs_m=9.0).item() == 5
    )


def test_sensitivity_result_to_xarray():
    kept = np.array([True, True, False, True])
    res = jxr.SensitivityResult(
        statistics=("E_phi2", "mean_envelope"), parameters=("b1", "gm_correction"),
        params={"b1": 0.0077, "gm_correction": 1.0}, value={"E_phi2": 0.02, "mean_envelope": 0.15},
        value_std_error={"E_phi2": 0.002, "mean_envelope": 0.01}, unsmoothed={"E_phi2": 0.02, "mean_envelope": 0.15},
        gradient={"E_phi2": {"b1": -2.0, "gm_correction": 0.1}, "mean_envelope": {"b1": -8.0, "gm_correction": 0.3}},
        std_error={"E_phi2": {"b1": 0.2, "gm_correction": 0.01}, "mean_envelope": {"b1": 0.5, "gm_correction": 0.02}},
        influence={s: {p: np.array([1.0, 2.0, 3.0]) * k for p, k in (("b1", -1.0), ("gm_correction", 0.1))}
                   for s in ("E_phi2", "mean_envelope")},
        unsmoothed_gradient={}, unsmoothed_std_error={}, by_burn_in={}, kept=kept, n_realizations=4, n_capsized=1,
        config={"method": "windowed"},
    )  # fmt: skip
    ds = res.to_xarray()
    _has_labels(ds)
    assert ds.gradient.sel(statistic="mean_envelope", parameter="b1") == -8.0
    # the influence of the realization left out is NaN; the others' mean is the gradient
    infl = ds.influence.sel(statistic="E_phi2", parameter="b1")
    assert np.isnan(infl.sel(realization=2)) and infl.mean().item() == pytest.approx(-2.0, rel=1e-15)
    assert list(ds.statistic_unit.values) == ["rad2", "rad"] and list(ds.parameter_unit.values) == [
        "s-1",
        "1",
    ]


def test_hydrostatics_to_xarray():
    hull = jxr.box_hull(100.0, 20.0, 12.0)
    loading = jxr.loading_condition(hull, kg=6.0, draught=5.0)
    sol = jxr.hull_hydrostatics(
        hull, loading, zeta_mid=np.linspace(-2.0, 2.0, 7), heels=np.radians([0.0, 5, 10, 15, 20])
    )
    ds = sol.to_xarray()
    _has_labels(ds)
    assert ds.tables_gz_m.dims == ("zeta_mid_m", "heel_deg")
    np.testing.assert_allclose(ds.heel_deg, [0.0, 5, 10, 15, 20], rtol=0, atol=1e-12)
    # the box barge: KB = d/2, BM = B²/(12 d), so GM0 = 2.5 + 6.6667 − 6
    np.testing.assert_allclose(ds.calm_water_gm_m, 2.5 + 400 / 60 - 6.0, rtol=1e-10)
    np.testing.assert_array_equal(ds.tables_converged, np.asarray(sol.converged))
    p = sol.particulars.to_xarray()
    assert p.displacement_kg.attrs["units"] == "kg" and p.displacement_kg == ds.calm_water_displacement_kg


def test_decay_fit_to_xarray():
    from importlib.resources import files

    records = jxr.load_records(str(files("jaxroll") / "data" / "records" / "decay"))
    fit = jxr.fit_extinction(records, jxr.c11_representative())
    ds = fit.to_xarray()
    _has_labels(ds)
    assert list(ds.parameter.values) == ["b1", "b2", "b3"]
    assert list(ds.unit.values) == [
        "s-1",
        "rad-1",
        "s rad-2",
    ]  # UDUNITS, as every `units` (the JSON: "1/s", …)
    for name, e in fit.damping.items():
        assert ds.estimate.sel(parameter=name) == e.value and ds.std_error.sel(parameter=name) == e.std_error
    cov = ds.covariance.values
    np.testing.assert_array_equal(cov, fit.damping_covariance)
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), ds.std_error, rtol=1e-12)
    assert ds.attrs["method"] == "extinction" and ds.diagnostics_converged


def test_tree_rule_refuses_what_its_layout_does_not_describe():
    with pytest.raises(ValueError, match="has no dimension names in the layout"):
        tree_to_dataset({"curve": [1.0, 2.0, 3.0]}, Layout())
    with pytest.raises(ValueError, match="no unit for mystery"):
        tree_to_dataset({"mystery": 1.0}, Layout())
    with pytest.raises(ValueError, match="two fields map to the variable 'a_b'"):
        tree_to_dataset({"a_b": 1.0, "a": {"b": 2.0}}, Layout(units={"a_b": "m"}))
    # the rule: nested names joined, labelled levels as dimensions (numeric keys as numbers), text as attributes
    ds = tree_to_dataset(
        {"q_deg": {"zc": {"50": 1.0, "90": 2.0}, "env": {"50": 3.0}}, "note": "x"},
        Layout(labels={"q_deg": "estimator", "q_deg/*": "percentile"}),
    )
    assert ds.q_deg.dims == ("estimator", "percentile") and list(ds.percentile.values) == [50, 90]
    assert np.isnan(ds.q_deg.sel(estimator="env", percentile=90)) and ds.attrs["note"] == "x"
    assert (
        ds.q_deg.attrs["json_path"] == "q_deg/{estimator}/{percentile}"
        and ds.q_deg.attrs["units"] == "degree"
    )


def test_the_round_trip_check_catches_a_wrong_or_missing_number(tmp_path):
    """`assert_labelled_output` (used by every command's test) fails on a changed number or a missing field."""
    result = _sweep_result([5.0, 7.0], [0, 1, 0, 2], [3, 9, 4, 12])
    payload = {
        "config": {"angle_deg": 30.0},
        "grid": {"axes": list(result.grid), **result.grid},
        "heading_deg": [180.0, 135.0],
        "n_realizations": 20,
        "n_capsized": result.n_capsized,
        "n_exceeded": result.n_exceeded,
        "capsize_probability": result.capsize_probability,
        "capsize_ci": result.capsize_interval(),
        "exceedance_probability": result.exceedance_probability,
        "exceedance_ci": result.exceedance_interval(),
        "points": [{"hs_m": 5.0}],
        "run_time_s": 1.5,
    }
    write_json(tmp_path / "sweep.json", payload)
    write_netcdf(tmp_path / "sweep.nc", "sweep", payload, result.to_xarray())
    assert_labelled_output(tmp_path, "sweep")
    ds = read_dataset(tmp_path / "sweep.nc")
    assert list(json.loads(ds.attrs["json_fields_not_stored"])) == ["points"]  # the grid arrays hold them
    bad = ds.copy(deep=True)
    bad["n_exceeded"][1, 0, 1, 0] += 1
    write_dataset(tmp_path / "sweep.nc", bad)
    with pytest.raises(AssertionError, match="n_exceeded"):
        assert_labelled_output(tmp_path, "sweep")
    write_dataset(tmp_path / "sweep.nc", ds.drop_vars("run_time_s"))
    with pytest.raises(AssertionError, match="run_time_s"):
        assert_labelled_output(tmp_path, "sweep")
    write_dataset(tmp_path / "sweep.nc", output_dataset("sweep", {**payload, "config": {"angle_deg": 20.0}}))
    with pytest.raises(AssertionError):
        assert_labelled_output(tmp_path, "sweep")


def test_every_unit_is_udunits_text_that_pint_parses():
    """One unit style (issue 45): every unit a layout declares and every unit a name states is UDUNITS text that
    pint parses through cf-xarray's UDUNITS registry (or says `mixed: …`, which becomes a `comment`); the units
    results write for people (`1/s`, `m/s`, `s/rad^2`, `-`, `deg`) are translated, never stored beside `s-1`."""
    import cf_xarray.units

    from jaxroll._labels import _layouts as layouts, cf_dataset, labelled_values, udunits
    from jaxroll._labels._units import SUFFIX_UNITS

    ureg = cf_xarray.units.units
    declared = [u for _, u in SUFFIX_UNITS]
    for lay in vars(layouts).values():
        if isinstance(lay, Layout):
            declared += [*lay.units.values(), *(c[0] for c in lay.coords.values() if c[0])]
    assert len(declared) > 100
    for unit in declared:
        if not unit.startswith("mixed"):
            assert udunits(unit) == unit, unit  # the layouts write UDUNITS already
            ureg.Unit(unit)
    expect = {"1/s": "s-1", "m/s": "m s-1", "rad/s": "rad s-1", "s/rad^2": "s rad-2", "1/rad^2": "rad-2",
              "-": "1", "deg": "degree", "1/year": "year-1", "m^2 s/rad": "m2 s rad-1", "rad2": "rad2"}  # fmt: skip
    for text, unit in expect.items():
        assert udunits(text) == unit
        assert ureg.Unit(unit) == ureg.Unit(
            text.replace("^", "**").replace("-", "1") if text == "-" else unit
        )
    ds = labelled_values(
        {
            "b1": ((), 0.1, "1/s", "damping"),
            "v": (("parameter",), [1.0, 2.0], "mixed: the parameter's", "values"),
        },
        coords={"unit": (("parameter",), ["1/s", "-"], None, "unit of each parameter")},
    )
    assert ds.b1.attrs["units"] == "s-1" and "units" not in ds.v.attrs
    assert ds.v.attrs["comment"] == "units: mixed: the parameter's" and list(ds.unit.values) == ["s-1", "1"]
    assert cf_dataset(ds) is ds


def test_runs_combine_by_their_inputs(tmp_path):
    """Two `jaxroll pdf` runs in other seas: the inputs are length-1 dimension coordinates (with CF standard
    names), so `xr.combine_by_coords` lays them side by side on `hs_m`, and each run's configuration is a variable
    (`run_config`) that `xr.concat` keeps per run — the attribute `config_json` keeps only the first's."""
    from jaxroll._cli import main

    folders = [tmp_path / f"hs{hs}" for hs in (5, 7)]
    for hs, out in zip((5, 7), folders, strict=True):
        args = ["--realizations", "4", "--duration", "300", "--theory", "none", "--seed", "3", "--quiet"]
        assert main(["pdf", "--hs", str(hs), *args, "--out", str(out)]) == 0
        assert_labelled_output(out, "pdf")  # CF attributes, units pint parses, the inputs as coordinates
    runs = [xr.open_dataset(out / "pdf.nc").load() for out in folders]
    assert runs[0].attrs["history"].endswith(f"jaxroll pdf --hs 5 {' '.join(args)} --out {folders[0]} (jaxroll "
                                             f"{jxr.__version__})")  # fmt: skip
    assert runs[0].cf["sea_surface_wave_significant_height"].values.tolist() == [5.0]
    both = xr.combine_by_coords(runs, combine_attrs="drop_conflicts")
    assert both.hs_m.values.tolist() == [5.0, 7.0] and both.sizes["t01_s"] == 1 and both.sizes["seed"] == 1
    for hs, run in zip((5.0, 7.0), runs, strict=True):
        np.testing.assert_array_equal(both.pdf_envelope.sel(hs_m=hs), run.pdf_envelope.sel(hs_m=hs))
        np.testing.assert_array_equal(both.capsize_time_s.sel(hs_m=hs), run.capsize_time_s.sel(hs_m=hs))
        assert json.loads(both.run_config.sel(hs_m=hs).item())["sea"]["hs_m"] == hs
    assert not np.array_equal(both.pdf_envelope.sel(hs_m=5.0), both.pdf_envelope.sel(hs_m=7.0))
    kept = xr.concat(runs, dim="hs_m")
    assert [json.loads(c)["sea"]["hs_m"] for c in kept.run_config.values.ravel()] == [5, 7]
    assert json.loads(kept.attrs["config_json"])["sea"]["hs_m"] == 5  # attributes: the first run's
