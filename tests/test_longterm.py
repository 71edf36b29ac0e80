"""Long-term risk (`jaxroll.longterm`, `jaxroll longterm`, `jaxroll merge`): the scatter diagram and its checks, the
cells' weights and symmetry, the theory per cell against the per-cell route, the long-term integral and the
per-year conversion, the Monte Carlo cell against `jaxroll risk` trial for trial, `--method auto` against a
brute-force Monte Carlo, parts, processes and checkpoints bit for bit, bad input."""

import json
import math
import os
import re
import socket
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import xarray as xr
from helpers import SHIP, assert_labelled_output

import jaxroll as jxr
from jaxroll._cli import main
from jaxroll.io import read_dataset, write_dataset
from jaxroll.longterm import (
    EFFORT_FRACTIONS,
    METHODS,
    T01_OVER_TZ,
    ScatterError,
    neyman_allocation,
    parse_scatter,
)
from jaxroll.longterm._allowance import measured_allowance
from jaxroll.longterm._cells import make_grid
from jaxroll.longterm._risk import annual, auto_cells, longterm_probability
from jaxroll.longterm._theory import class_template, class_theory

PUBLISHED_ROWS = [3050, 22575, 23810, 19128, 13289, 8328, 4806, 2586, 1309, 626, 285, 124, 51, 21, 8, 3, 1]
PUBLISHED_COLUMNS = [0, 0, 1, 165, 2091, 9280, 19922, 24879, 20870, 12898, 6245, 2479, 837, 247, 66, 16, 3, 1]
ANGLES = (math.radians(25.0), math.radians(35.0))  # two angles everywhere: the theory programs compile once
SMALL = "hs_m,8.5,9.5\n5.5,10,20\n7.5,5,0\n"  # 3 sea states with weight, one without


@pytest.fixture(scope="module")
def small_csv(tmp_path_factory):
    path = tmp_path_factory.mktemp("scatter") / "small.csv"
    path.write_text(SMALL)
    return path


# ----------------------------------------------------------------------------------------------------------
# The scatter diagram
# ----------------------------------------------------------------------------------------------------------


def test_rec34_matches_the_published_sums_and_the_criteria_transcription():
    from jaxroll.criteria._parametric_roll import REC34_HS, REC34_SCATTER, REC34_TZ

    d = jxr.rec34_scatter()
    assert d.counts.sum() == pytest.approx(100_000.0, abs=1e-9)
    np.testing.assert_array_equal(d.hs, np.arange(0.5, 17.0, 1.0))
    np.testing.assert_array_equal(d.tz, np.arange(1.5, 19.0, 1.0))
    # cells are given to 0.1: a published (integer) sum is the sum of the unrounded cells, rounded
    tolerance = 0.5 + 0.05 * np.count_nonzero(d.counts, axis=1)
    assert np.all(np.abs(d.counts.sum(axis=1) - PUBLISHED_ROWS) <= tolerance)
    tolerance = 0.5 + 0.05 * np.count_nonzero(d.counts, axis=0)
    assert np.all(np.abs(d.counts.sum(axis=0) - PUBLISHED_COLUMNS) <= tolerance)
    # typed independently of the criteria module's table: they agree cell for cell
    np.testing.assert_array_equal(d.counts, REC34_SCATTER)
    np.testing.assert_array_equal(d.hs, REC34_HS)
    np.testing.assert_array_equal(d.tz, REC34_TZ)


def test_t01_over_tz_of_the_ittc_spectrum():
    """T01 = 1.0864 T_z for jaxroll's ITTC spectrum: its moments by quadrature (m2 converges as ω⁻³)."""
    from scipy.integrate import quad

    assert T01_OVER_TZ == pytest.approx(1.0864348, abs=1e-7)
    sea = jxr.ITTC(4.0, 9.0)
    s = lambda w: float(sea(jnp.asarray(w)))  # noqa: E731
    m = [
        quad(lambda w, n=n: w**n * s(w), 0.0, np.inf, limit=400, epsabs=0, epsrel=1e-11)[0] for n in range(3)
    ]
    t01 = 2 * math.pi * m[0] / m[1]
    tz = 2 * math.pi * math.sqrt(m[0] / m[2])
    assert t01 == pytest.approx(9.0, rel=1e-8)
    assert t01 / tz == pytest.approx(T01_OVER_TZ, rel=1e-8)


def test_scatter_file_is_sorted_and_normalised(tmp_path):
    d = parse_scatter("# a comment\n\nhs_m,9.5,8.5\n7.5,0,5\n5.5,20,10\n", "x.csv")
    np.testing.assert_array_equal(d.hs, [5.5, 7.5])
    np.testing.assert_array_equal(d.tz, [8.5, 9.5])
    np.testing.assert_array_equal(d.counts, [[10, 20], [5, 0]])
    assert d.probability.sum() == pytest.approx(1.0, rel=1e-15, abs=0)
    np.testing.assert_allclose(d.t01, T01_OVER_TZ * d.tz, rtol=1e-15, atol=0)


BAD_SCATTER = [
    ("hs,8.5\n5.5,1\n", ":1: the first row must be 'hs_m"),
    ("hs_m\n5.5\n", ":1: the first row must be 'hs_m"),
    ("hs_m,8.5,9.5\n5.5,1\n", ":2: 2 fields, but the header has 3"),
    ("hs_m,8.5\n5.5,abc\n", ":2: the count 'abc' is not a number"),
    ("hs_m,8.5\nSum,3\n", ":2: the H_s 'Sum' is not a number"),
    ("hs_m,8.5,9.5\n5.5,1,-2\n", ":2: the count of T_z = 9.5 s is negative"),
    ("hs_m,8.5,9.5\n5.5,1,nan\n", ":2: the count of T_z = 9.5 s is nan"),
    ("hs_m,8.5\n5.5,0\n6.5,0\n", "every count is zero"),
    ("hs_m,8.5\n5.5,1\n# comment\n5.5,2\n", ":4: H_s = 5.5 m repeats the row of line 2"),
    ("hs_m,8.5,0.5\n5.5,1,0\n", ":1: T_z = 0.5 s is outside the sensible range"),
    ("hs_m,8.5,45\n5.5,1,0\n", ":1: T_z = 45 s is outside the sensible range"),
    ("hs_m,8.5,8.5\n5.5,1,0\n", ":1: T_z 8.5 s appears in more than one column"),
    ("hs_m,2.5\n6.5,1\n", ":2: H_s = 6.5 m with T_z = 2.5 s has a count"),
    ("hs_m,8.5\n-1,1\n", ":2: H_s = -1 m is outside"),
    ("", "no data"),
    # issue 45 item 3: counts that overflow when summed gave P_LT = 0 with only a NumPy warning
    ("hs_m,8.5,9.5\n4.5,1e308,1e308\n", "the counts sum to more than the largest number"),
]


@pytest.mark.parametrize("text, message", BAD_SCATTER)
def test_bad_scatter_file_is_refused_with_file_and_line(text, message, tmp_path, capsys):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ScatterError, match=None) as e:
        jxr.read_scatter(path)
    assert str(path) in str(e.value) and message in str(e.value)
    out = tmp_path / "out"
    assert main(["longterm", "--scatter", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxroll longterm: error: --scatter: ") and message in err and str(path) in err
    assert not out.exists()  # before any computation


BAD_OPTIONS = [
    (["--heading-weights", "1,2"], "--heading-weights has 2 weights for 24 headings"),
    (["--heading", "180,150", "--heading-weights", "0,0"], "--heading-weights sum to zero"),
    (["--heading", "180,150", "--heading-weights", "1,-1"], "--heading-weights must be finite numbers >= 0"),
    (["--speed", "0,5", "--speed-weights", "1"], "--speed-weights has 1 weights for 2 speeds"),
    (["--speed", "0,5", "--speed-weights", "0,0"], "--speed-weights sum to zero"),
    (["--ship-weights", "1,1"], "--ship-weights has 2 weights for 1 ships"),
    (["--angle", "72"], "--angle 72° is not below the angle of vanishing stability"),
    (["--angle", "30,95"], "--angle must be distinct angles in (0, 90) degrees"),
    (["--heading", "360"], "--heading must be all or a list of angles in degrees in [0, 360)"),
    (["--heading", "180,head"], "--heading repeats a heading"),
    (["--speed", "-1"], "--speed must be distinct finite speeds >= 0"),
    (["--hours", "0"], "--hours must be a finite number > 0"),
    (["--part", "3/2"], "--part must be i/N with integers 1 <= i <= N"),
    (["--realizations", "0"], "--realizations must be >= 1"),
    (["--scatter", "nowhere.csv"], "--scatter: scatter file 'nowhere.csv' not found"),
    (["--estimator", "magic"], "--estimator must be one of brute-force"),
    (["--model-factor", "0.5"], "--model-factor must be measured or a number >= 1"),
    (
        ["--model-factor", "wide"],
        "--model-factor must be measured or a number >= 1 (1: the theory taken as exact); got 'wide'",
    ),
    (["--filter-order", "eight"], "--filter-order must be auto or an integer between 3 and 12"),
    (["--skip-weight", "1"], "--skip-weight must be in [0, 1)"),
    (["--refine-delta", "-0.1"], "--refine-delta must be in [0, 1)"),
    # issue 45 items 4 and 6: absurd values that were accepted (P = 0) or ended in a traceback
    (["--speed", "1e6"], "--speed: U = 1e+06 m/s is a Froude number of 1.97e+04 for C11 (representative)"),
    (["--hours", "10000"], "--hours (10000 h) is longer than the 8766 h at sea per year (--hours-per-year)"),
    (["--hours-per-year", "1e9"], "--hours-per-year must be at most 8766 h"),
    (["--seed", str(10**14)], "--seed must be an integer in [0, 999999999999]"),
]


@pytest.mark.parametrize("argv, message", BAD_OPTIONS, ids=[m[:30] for _, m in BAD_OPTIONS])
def test_bad_options_exit_2_before_any_computation(argv, message, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["longterm", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("jaxroll longterm: error: ") and message in err, err
    assert not out.exists()


# ----------------------------------------------------------------------------------------------------------
# Cells, weights, the long-term integral
# ----------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (
            dict(scatter=123),
            r"`scatter` must be 'rec34', the path of a scatter CSV file or a ScatterDiagram; got 123",
        ),
        (dict(ships="c11"), r"`ships` must be a Ship or a sequence of Ships .*got 'c11' \(str\)"),
        (dict(checkpoint=123), r"`checkpoint` must be the path of a folder \(or None\); got 123 \(int\)"),
        (dict(seed=10**14), r"`seed` must be an integer in \[0, 999999999999\]"),
        (dict(seed=1.5), r"`seed` must be an integer; got 1\.5 \(float\)"),
        (dict(exposure="3h"), r"`exposure` must be a number; got '3h' \(str\)"),
        (dict(speeds=[1e6]), r"`speeds`: U = 1e\+06 m/s is a Froude number"),
        (
            dict(exposure=1e4 * 3600.0, hours_per_year=5000.0),
            r"`exposure` \(10000 h\) is longer than the 5000 h",
        ),
        (dict(hours_per_year=1e9), r"`hours_per_year` must be at most 8766 h"),
        (dict(heading_weights=[1e308, 1e308], headings=[math.pi, 0.0], speeds=[3e6]), r"Froude"),
    ],
)
def test_api_refuses_bad_arguments_with_a_message(kwargs, message):
    """Issue 45 item 6: raw TypeError/AttributeError/OverflowError before; one ValueError naming the argument."""
    kwargs = {"scatter": SMALL_SCATTER, **kwargs}
    with pytest.raises(ValueError, match=message):
        jxr.longterm(**kwargs)


SMALL_SCATTER = parse_scatter(SMALL, "small.csv")
CALM = "hs_m,8.5,9.5\n0.5,1,1\n1.0,1,1\n"  # no cell rolls: every probability is 0 exactly (λ <= 0)


def test_numpy_numbers_are_accepted_and_no_negative_zero_is_written(tmp_path, capsys):
    """Issue 45 items 6 and 9: NumPy integers and floats were refused as seeds and exposures; "per year: P = -0"
    was printed (and -0.0 written) where nothing is exceeded. Weights of 1e308 (whose sum overflows) normalise."""
    calm = parse_scatter(CALM, "calm.csv")
    ds = jxr.longterm(
        calm,
        headings=[math.pi, math.radians(150.0)],
        heading_weights=[1e308, 1e308],
        seed=np.int64(3),
        exposure=np.float32(1800.0),
        realizations=np.int32(10),
        hours_per_year=np.float64(5000.0),
        angles=ANGLES,
    )
    assert (ds.seed.values // 1_000_000 == 3).all() and float(ds.exposures_per_year) == 5000.0 * 2
    np.testing.assert_array_equal(np.unique(ds.weight.sum(("hs", "tz", "speed", "ship")).values), [0.5])
    for v in ds.data_vars.values():
        if v.dtype.kind == "f":
            assert not np.signbit(v.values[v.values == 0]).any(), v.name
    assert float(ds.longterm_per_year_probability[0]) == 0.0
    path = tmp_path / "calm.csv"
    path.write_text(CALM)
    out = tmp_path / "out"
    argv = [
        "longterm",
        "--scatter",
        str(path),
        "--heading",
        "180",
        "--angle",
        "25",
        "--quiet",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "per year: P = 0," in text and "-0" not in text
    assert not re.search(r"-0\.0\b(?!\d)|-0[,\n]", (out / "longterm.json").read_text())


def test_weights_classes_and_seeds():
    d = parse_scatter(SMALL, "small.csv")
    h = [math.radians(x) for x in (180.0, 30.0, 330.0, 90.0)]
    grid = make_grid(d, [SHIP, SHIP], ["a", "b"], [3, 1], h, [1, 2, 3, 4], [0.0, 4.0], [1, 1])
    w = grid.weight
    assert w.shape == (2, 2, 4, 2, 2) and w.sum() == pytest.approx(1.0, rel=1e-14, abs=0)
    np.testing.assert_allclose(w[0, 1, 2, 1, 0], 20 / 35 * 3 / 10 * 0.5 * 0.75, rtol=1e-14, atol=0)
    np.testing.assert_array_equal(grid.classes_deg, [180.0, 30.0, 90.0])  # 330° is 30° (port/starboard)
    np.testing.assert_array_equal(grid.heading_class, [0, 1, 1, 2])
    np.testing.assert_allclose(grid.comp_weight.sum(), 1.0, rtol=1e-14, atol=0)
    seeds = grid.seeds(7)
    assert seeds.min() == 7_000_001 and np.unique(seeds).size == seeds.size
    with pytest.raises(ValueError, match="`heading_weights` has 3 weights for 4 values"):
        make_grid(d, [SHIP], ["a"], None, h, [1, 2, 3], [0.0], None)
    with pytest.raises(ValueError, match="`headings` repeats a heading"):
        make_grid(d, [SHIP], ["a"], None, [1.0, 1.0], None, [0.0], None)


def test_long_term_integral_interval_and_per_year():
    rng = np.random.default_rng(0)
    w = rng.random((5, 3))
    w /= w.sum()
    p = rng.random((5, 3, 2)) * 0.3
    var = rng.random((5, 3, 2)) * 1e-4
    lo, hi = p / 1.25, np.minimum(1, 1.25 * p)
    lt = longterm_probability(w, p, var, lo, hi)
    np.testing.assert_allclose(lt["probability"], (w[..., None] * p).sum(axis=(0, 1)), rtol=1e-14, atol=0)
    sd = np.sqrt((w[..., None] ** 2 * var).sum(axis=(0, 1)))
    np.testing.assert_allclose(
        lt["upper"],
        lt["probability"] + 1.959963984540054 * sd + (w[..., None] * (hi - p)).sum(axis=(0, 1)),
        rtol=1e-14,
        atol=0,
    )
    ny = 1000.0
    yr = annual(w, p, var, lo, hi, ny)
    # Poisson numbers of exposures per cell (mean w_c N_y): exceedances Poisson with mean N_y Σ w P
    np.testing.assert_allclose(yr["probability"], 1 - np.exp(-ny * lt["probability"]), rtol=1e-12, atol=0)
    np.testing.assert_allclose(yr["rate"], ny * lt["probability"], rtol=1e-14, atol=0)
    np.testing.assert_allclose(yr["upper"], 1 - np.exp(-ny * lt["upper"]), rtol=1e-12, atol=0)
    small = annual(w, p * 1e-6, var, lo * 1e-6, hi * 1e-6, ny)  # the rate form is the small-probability limit
    np.testing.assert_allclose(small["probability"], small["rate"], rtol=1e-3, atol=0)


def test_per_year_probability_never_exceeds_the_expected_count():
    """Issue 42 item 6: a storm cell of tiny weight met 0.01 times a year with P_c near 1. The old product form
    1 − Π (1 − P_c)^(w_c N_y) gave P_year ≈ 0.43 against 0.029 expected exceedances; P(N ≥ 1) ≤ E[N] must hold."""
    ny = 8766 / 3.0
    w = np.array([1 - 3.4e-6, 3.4e-6])  # the storm: w N_y = 0.0099 exposures a year
    p = np.array([[6.6e-6], [1.0 - 1e-9]])  # calm cell 6.6e-6 per exposure; the storm all but certain
    zero = np.zeros_like(p)
    yr = annual(w, p, zero, p, p, ny)
    rate = ny * (w[:, None] * p).sum(axis=0)
    np.testing.assert_allclose(yr["rate"], rate, rtol=1e-14)
    np.testing.assert_allclose(yr["probability"], -np.expm1(-rate), rtol=1e-14)
    assert 0.028 < rate[0] < 0.030 and yr["probability"][0] <= rate[0]
    old = 1 - np.prod((1 - p) ** (ny * w[:, None]), axis=0)  # what the corrected formula gave
    assert old[0] > 0.15  # (0.19 here): above the expected count, which is impossible
    # the bound over random tables, P_c up to 1
    rng = np.random.default_rng(1)
    for _ in range(200):
        w = rng.dirichlet(np.full(6, 0.2))
        p = rng.random((6, 3)) ** rng.uniform(0.1, 5)
        yr = annual(w, p, zero[:1].repeat(6, 0).repeat(3, 1), p, p, rng.uniform(1, 1e4))
        assert np.all(yr["probability"] <= yr["rate"] * (1 + 1e-12))
        assert np.all((0 <= yr["probability"]) & (yr["probability"] <= 1))


def test_auto_rule_and_neyman_allocation():
    w = np.array([0.5, 0.3, 0.1, 0.1])
    p = np.array([[0.01], [0.5], [0.2], [0.0]])  # contributions 0.005, 0.15, 0.02, 0: P_LT 0.175
    doubt = np.array([False, False, False, True])
    dominant, material = auto_cells(w, p, doubt, np.ones(4, bool), share=0.9, tolerance=0.01)
    np.testing.assert_array_equal(dominant, [False, True, True, False])  # 0.15 + 0.02 >= 0.9 × 0.175
    np.testing.assert_array_equal(material, [False, False, False, True])  # worst case 0.1 > 0.01 × 0.175
    n = neyman_allocation(np.array([0.4, 0.1, 0.5]), np.array([0.1, 0.1, 0.0]), 1000, 50)
    a = np.array([0.4 * math.sqrt(0.09), 0.1 * math.sqrt(0.09), 0.5 * math.sqrt(0.01 * 0.99)])
    np.testing.assert_array_equal(n, np.maximum(50, np.round(a / a.sum() * 1000)))


# ----------------------------------------------------------------------------------------------------------
# Theory per cell
# ----------------------------------------------------------------------------------------------------------


def test_class_theory_is_passage_risk_cell_by_cell(monkeypatch):
    """A class's cells give `jaxroll.theory.passage_risk`'s numbers, cell by cell (solved `SEAS_PER_CALL` at a time
    by `passage_risk_batch`, with the screen's envelopes); cells with λ <= 0 (by the screen, on passage_risk's own
    (ρ, θ) grid) never reach it and are 0, as its own `exists` makes them."""
    from jaxroll.longterm import _theory

    hs = np.array([6.0, 1.5, 7.0])  # 1.5 m: the roll dies out (λ < 0)
    t01 = np.array([10.0, 10.0, 9.0])
    seen = []
    solve = _theory._batch_dispatch

    def counting(ship, waves, *args, **kw):
        seen.append([float(w.sea.hs) for w in waves])
        return solve(ship, waves, *args, **kw)

    monkeypatch.setattr(_theory, "_batch_dispatch", counting)
    r = class_theory(
        SHIP, class_template(SHIP, 0.0, 180.0), hs, t01, np.asarray(ANGLES), 1800.0, refine_delta=0.0
    )
    assert r["lyapunov_exponent"][1] < 0 < min(r["lyapunov_exponent"][0], r["lyapunov_exponent"][2])
    # calls of `SEAS_PER_CALL` seas (padded with skipped repeats), the live cells shared out over the devices
    assert all(len(s) == _theory.SEAS_PER_CALL for s in seen) and {h for s in seen for h in s} == {6.0, 7.0}
    for i in range(3):
        wave = jxr.EffectiveWave(jxr.ITTC(float(hs[i]), float(t01[i])), SHIP.lpp, 0.0, "head")
        one = jxr.theory.passage_risk(
            SHIP, wave, np.asarray(ANGLES), jnp.asarray([1800.0]), num_iterations=_theory.NUM_ITERATIONS
        )
        np.testing.assert_allclose(
            r["probability"][i], np.asarray(one.probability)[:, 0], rtol=1e-10, atol=1e-300
        )
        # the capsize rate (λ_1 of a nearly singular system, ~1e-9 1/s) carries the screen's envelope fit
        # (vmapped) to 3e-9 relative
        np.testing.assert_allclose(
            r["capsize_probability"][i], float(one.capsize_probability[0]), rtol=1e-8, atol=1e-300
        )
        if i == 1:
            assert not bool(one.exists)
    assert np.all(r["probability"][1] == 0) and r["probability"][0, 0] > 0


def test_two_pass_theory_refines_the_cells_the_rule_names():
    """Two passes (`refine_delta` δ): pass 1 is `passage_risk(extrapolate=False)` everywhere λ > 0, pass 2 the
    extrapolated one on the smallest set carrying 1 − δ of Σ w P1 per angle; the long-term value lies within the
    stated bound of the all-refined one (cells left at pass 1 carry ≤ δ of Σ w P1 and lie in [0, r·P1])."""
    from jaxroll.longterm._theory import refine_set

    hs = np.array([6.0, 1.5, 7.0, 4.5, 5.5, 3.5])
    t01 = np.array([10.0, 10.0, 9.0, 10.0, 8.0, 11.0])
    w = np.array([0.05, 0.3, 0.02, 0.3, 0.03, 0.3])
    tm = class_template(SHIP, 0.0, 180.0)
    delta = 0.2
    two = class_theory(SHIP, tm, hs, t01, np.asarray(ANGLES), 1800.0, weight=w, refine_delta=delta)
    full = class_theory(SHIP, tm, hs, t01, np.asarray(ANGLES), 1800.0, weight=w, refine_delta=0.0)
    live = full["lyapunov_exponent"] > 0
    np.testing.assert_array_equal(two["lyapunov_exponent"] > 0, live)
    assert np.all(full["refined"] == live)
    # the rule, by hand: per angle, largest w·P1 first until 1 − δ of the sum
    expect = np.zeros(hs.size, bool)
    for a in range(len(ANGLES)):
        c = w * two["pass1_probability"][:, a]
        order = np.argsort(-c, kind="stable")
        k = int(np.searchsorted(np.cumsum(c[order]), (1 - delta) * c.sum() * (1 - 1e-12))) + 1
        expect[order[:k]] = True
    np.testing.assert_array_equal(two["refined"], expect & live)
    np.testing.assert_array_equal(refine_set(w, two["pass1_probability"], live, delta), two["refined"])
    rough = live & ~two["refined"]
    assert rough.any() and two["refined"].any()  # both kinds of cell in this example
    # refined cells: the extrapolated value; the others: pass 1
    np.testing.assert_allclose(
        two["probability"][two["refined"]], full["probability"][two["refined"]], rtol=1e-9
    )
    np.testing.assert_array_equal(two["probability"][rough], two["pass1_probability"][rough])
    for a in range(len(ANGLES)):
        s1 = np.sum(w * two["pass1_probability"][:, a])
        assert np.sum((w * two["pass1_probability"][:, a])[rough]) <= delta * s1 * (1 + 1e-12)
        lt_two, lt_full = np.sum(w * two["probability"][:, a]), np.sum(w * full["probability"][:, a])
        # the stated bound: |ΔP_LT| <= max(1, r − 1) · Σ_rough w P1 <= max(1, r − 1) · δ · Σ w P1
        r = two["pass_ratio"][0]
        assert abs(lt_two - lt_full) <= max(1.0, r - 1.0) * delta * s1
        # and the all-refined value inside the two-pass allowance [Σ w P − Σ_rough w P1, Σ w P + (r − 1) Σ_rough w P1]
        rough_sum = np.sum((w * two["pass1_probability"][:, a])[rough])
        assert lt_two - rough_sum <= lt_full <= lt_two + (r - 1) * rough_sum + 1e-300
    # pass 1 (one grid, first order in Δs) lies above pass 2 wherever they differ (the allowance's premise)
    assert np.all(two["pass1_probability"][live] >= full["probability"][live] * (1 - 1e-6))


def test_zero_speed_headings_mirror():
    """At zero speed χ and 180° − χ are one problem (the reuse `_run._twin` makes): the same effective-wave
    spectrum, so the same theory."""
    w = jnp.linspace(0.05, 2.0, 400)
    a = jxr.EffectiveWave(jxr.ITTC(6.0, 10.0), SHIP.lpp, 0.0, math.radians(30.0))
    b = jxr.EffectiveWave(jxr.ITTC(6.0, 10.0), SHIP.lpp, 0.0, math.radians(150.0))
    np.testing.assert_allclose(np.asarray(a.spectrum(w)), np.asarray(b.spectrum(w)), rtol=1e-12, atol=1e-300)
    ra = jxr.theory.passage_risk(SHIP, a, np.asarray(ANGLES), jnp.asarray([1800.0]))
    rb = jxr.theory.passage_risk(SHIP, b, np.asarray(ANGLES), jnp.asarray([1800.0]))
    np.testing.assert_allclose(np.asarray(ra.probability), np.asarray(rb.probability), rtol=1e-9, atol=0)


@pytest.fixture(scope="module")
def theory_run(small_csv):
    h = [math.radians(x) for x in (180.0, 150.0, 210.0, 90.0)]
    return jxr.longterm(
        small_csv,
        headings=h,
        heading_weights=[4, 2, 1, 1],
        angles=ANGLES,
        exposure=1800.0,
        hours_per_year=5000.0,
    )


def test_longterm_by_theory(theory_run):
    ds = theory_run
    assert ds.probability.dims == ("hs", "tz", "heading_deg", "speed", "ship", "angle_deg")
    w, p = ds.weight.values, ds.probability.values
    np.testing.assert_allclose(w.sum(), 1.0, rtol=1e-14, atol=0)
    np.testing.assert_allclose(
        ds.longterm_probability.values, np.nansum(w[..., None] * p, axis=(0, 1, 2, 3, 4)), rtol=1e-13, atol=0
    )
    np.testing.assert_array_equal(p[:, :, 1], p[:, :, 2])  # 150° and 210°: one problem
    beam = ds.sel(heading_deg=90.0)
    assert np.all(beam.probability.sel(hs=5.5).values == 0) and np.all(
        beam.capsize_probability.sel(hs=5.5) == 0
    )
    assert np.all(beam.method.sel(hs=5.5).values == METHODS.index("no_excitation"))
    empty = ds.sel(hs=7.5, tz=9.5)
    assert np.all(np.isnan(empty.probability.values)) and np.all(
        empty.method.values == METHODS.index("zero_weight")
    )
    assert np.all(ds.method.sel(hs=5.5, heading_deg=[180.0, 150.0, 210.0]).values == METHODS.index("theory"))
    # theory cells: the interval is the measured model allowance [P/f_below, f_above P] of the cell's region
    # (none is doubtful here)
    assert not ds.theory_doubtful.values.any()
    pt = ds.probability.sel(hs=5.5, heading_deg=180.0).values  # (tz, speed, ship, angle)
    below, above, outside, _ = measured_allowance(
        5.5, ds.tz.values[:, None] * T01_OVER_TZ, ds.speed.values[None]
    )
    np.testing.assert_allclose(
        ds.probability_lower.sel(hs=5.5, heading_deg=180.0).values,
        pt / below[..., None, None],
        rtol=1e-15,
        atol=0,
    )
    np.testing.assert_allclose(
        ds.probability_upper.sel(hs=5.5, heading_deg=180.0).values,
        np.minimum(1.0, pt * above[..., None, None]),
        rtol=1e-15,
        atol=0,
    )
    np.testing.assert_array_equal(
        ds.theory_outside_validated_map.sel(hs=5.5, heading_deg=180.0).values[..., 0], outside
    )
    lt = ds.longterm_probability.values
    np.testing.assert_allclose(
        ds.longterm_probability_ci95.values[:, 0], lt - ds.longterm_model_below.values, rtol=1e-14, atol=0
    )
    assert np.all(ds.longterm_sampling_sd.values == 0)
    ny = 5000.0 * 3600 / 1800.0
    q = np.nan_to_num(p)
    np.testing.assert_allclose(
        ds.longterm_per_year_probability.values,
        -np.expm1(-ny * (w[..., None] * q).sum(axis=(0, 1, 2, 3, 4))),
        rtol=1e-12,
        atol=0,
    )
    np.testing.assert_allclose(ds.longterm_per_year_rate.values, ny * lt, rtol=1e-14, atol=0)
    cfg = json.loads(ds.attrs["config_json"])
    assert cfg["heading_classes_deg"] == [180.0, 150.0, 90.0] and ds.attrs["jax_version"] == jax.__version__
    summary = jxr.longterm_summary(ds)
    top = summary["longterm"]["25"]["dominating_cells"]
    assert top[0]["share"] >= top[1]["share"] and sum(c["share"] for c in top) == pytest.approx(
        1.0, rel=1e-12
    )


def test_skipped_weight_is_a_bound_in_the_interval(small_csv, theory_run):
    h = [math.radians(x) for x in (180.0, 150.0, 210.0, 90.0)]
    ds = jxr.longterm(
        small_csv,
        headings=h,
        heading_weights=[4, 2, 1, 1],
        angles=ANGLES,
        exposure=1800.0,
        hours_per_year=5000.0,
        skip_weight=0.06,
    )
    left = ds.method.values == METHODS.index("left_out")
    assert left.any() and 0 < float(ds.left_out_weight) <= 0.06
    np.testing.assert_allclose(float(ds.left_out_weight), ds.weight.values[left].sum(), rtol=1e-14, atol=0)
    full = theory_run
    assert np.all(ds.longterm_probability.values <= full.longterm_probability.values)
    assert np.all(ds.longterm_probability_ci95.values[:, 1] >= full.longterm_probability.values)


# ----------------------------------------------------------------------------------------------------------
# Monte Carlo per cell
# ----------------------------------------------------------------------------------------------------------


def test_monte_carlo_cell_is_jaxroll_risk_trial_for_trial(tmp_path):
    """The cell's recorded `jaxroll risk` command reproduces it: the same exceedances and capsizes; and the cell's
    counts at every effort fraction are those of `monte_carlo_max_roll` with the cell's seed, trial by trial."""
    csv = tmp_path / "one.csv"
    csv.write_text("hs_m,8.5\n7.5,1\n")
    ds = jxr.longterm(
        csv, angles=ANGLES, exposure=360.0, discard=100.0, method="monte-carlo", realizations=16, seed=4
    )
    cell = ds.isel(hs=0, tz=0, heading_deg=0, speed=0, ship=0)
    seed = int(cell.seed)
    assert seed == 4_000_001
    summary = jxr.longterm_summary(ds)
    command = next(iter(summary["longterm"].values()))["dominating_cells"][0]["risk_command"]
    assert f"--seed {seed - 1}" in command
    problem = jxr.RollProblem.from_sea(SHIP, jxr.ITTC(7.5, float(cell.t01)), heading="head")
    stats = jxr.monte_carlo_max_roll(
        problem, jax.random.key(seed), angle_deg=25.0, num_realizations=16, duration=460.0, discard=100.0
    )
    for e, f in enumerate(EFFORT_FRACTIONS):
        m = max(1, round(f * 16))
        for a, angle in enumerate((25.0, 35.0)):
            k = int(np.sum(stats.capsized[:m] | (stats.max_abs_phi_deg[:m] > angle)))
            assert int(cell.n_exceeded_effort[e, a]) == k
    assert int(cell.n_capsized) == stats.n_capsized
    argv = command.split()[1:] + ["--duration", "400", "--out", str(tmp_path / "risk"), "--quiet"]
    assert main(argv) == 0
    direct = json.loads((tmp_path / "risk" / "risk.json").read_text())["direct"]
    assert direct["n_realizations"] == 16 and direct["n_capsized"] == int(cell.n_capsized)
    assert direct["probability"] == int(cell.n_exceeded[0]) / 16 == float(cell.probability[0])


@pytest.mark.slow  # ~2-4 min: 18 filter fits, brute force and auto
def test_auto_lies_within_the_brute_force_interval(tmp_path):
    """3 × 3 sea states × 3 headings (150° and 210° one class): `auto` (theory, Monte Carlo on the dominating
    cells) against every cell by Monte Carlo, seeded; tolerance from both standard errors and auto's allowance."""
    csv = tmp_path / "three.csv"
    csv.write_text("hs_m,8.5,9.5,10.5\n4.5,30,40,20\n5.5,20,30,20\n6.5,8,12,8\n")
    kw = dict(
        headings=[math.pi, math.radians(150), math.radians(210)],
        angles=ANGLES,
        exposure=900.0,
        discard=300.0,
        realizations=200,
        seed=1,
    )
    brute = jxr.longterm(csv, method="monte-carlo", **kw)
    auto = jxr.longterm(csv, method="auto", **kw)
    n_mc = int((auto.method.values == METHODS.index("monte_carlo")).sum())
    assert 0 < n_mc < int((brute.method.values == METHODS.index("monte_carlo")).sum())
    for a in range(2):
        pa, pb = float(auto.longterm_probability[a]), float(brute.longterm_probability[a])
        sd = math.hypot(float(auto.longterm_sampling_sd[a]), float(brute.longterm_sampling_sd[a]))
        allowance = max(float(auto.longterm_model_below[a]), float(auto.longterm_model_above[a]))
        assert abs(pa - pb) <= 3 * sd + allowance, (a, pa, pb, sd, allowance)
        assert float(brute.longterm_probability_ci95[a, 0]) <= float(auto.longterm_probability_ci95[a, 1])
        assert float(auto.longterm_probability_ci95[a, 0]) <= float(brute.longterm_probability_ci95[a, 1])


# ----------------------------------------------------------------------------------------------------------
# Parts, processes, checkpoints: the same dataset bit for bit
# ----------------------------------------------------------------------------------------------------------


def _assert_same(a, b):
    xr.testing.assert_identical(a, b)
    for v in a.variables:
        np.testing.assert_array_equal(a[v].values, b[v].values, err_msg=v)


def _results(folder):
    """A written longterm.nc without its run time (the one number two runs of the same problem differ in) and
    without when and by which command line it was written (CF's `history`, `date_created`)."""
    ds = read_dataset(folder / "longterm.nc").drop_vars("run_time_s", errors="ignore")
    ds.attrs = {k: v for k, v in ds.attrs.items() if k not in ("history", "date_created")}
    return ds


def _roundtrip(ds, path):
    write_dataset(path, ds)
    return read_dataset(path)


@pytest.mark.parametrize("method", ["theory", "monte-carlo", "auto"])
def test_two_parts_merged_equal_one_run(method, small_csv, tmp_path):
    # auto computes every cell's theory in each part (to choose its Monte Carlo cells): two heading classes keep
    # its three runs short; the other methods split the four
    headings = (180.0, 90.0) if method == "auto" else (180.0, 150.0, 210.0, 90.0)
    kw = dict(
        headings=[math.radians(x) for x in headings],
        heading_weights=[4, 2, 1, 1][: len(headings)],
        angles=ANGLES,
        exposure=1800.0,
        hours_per_year=5000.0,
        method=method,
        realizations=6,
        discard=100.0,
    )
    whole = jxr.longterm(small_csv, **kw)
    parts = [_roundtrip(jxr.longterm(small_csv, part=f"{i}/2", **kw), tmp_path / f"p{i}.nc") for i in (2, 1)]
    assert parts[0].attrs["part"] == "2/2" and parts[0].computed.values.any()
    assert not (parts[0].computed.values & parts[1].computed.values).any()
    merged = jxr.merge_longterm(parts)
    _assert_same(_roundtrip(merged, tmp_path / "merged.nc"), _roundtrip(whole, tmp_path / "whole.nc"))
    with pytest.raises(ValueError, match="each part 1/2 … 2/2 exactly once"):
        jxr.merge_longterm([parts[0], parts[0]])


def test_cli_parts_merge_and_outputs(small_csv, tmp_path, capsys):
    common = [
        "--scatter",
        str(small_csv),
        "--heading",
        "180,150,210,90",
        "--heading-weights",
        "4,2,1,1",
        "--angle",
        "25,35",
        "--hours",
        "0.5",
        "--hours-per-year",
        "5000",
        "--quiet",
    ]
    assert main(["longterm", *common, "--out", str(tmp_path / "whole")]) == 0
    for i in (1, 2):
        assert main(["longterm", *common, "--part", f"{i}/2", "--out", str(tmp_path / "parts")]) == 0
    files = sorted(str(p) for p in (tmp_path / "parts").glob("longterm.part-*-of-2.nc"))
    assert len(files) == 2
    assert main(["merge", *files, "--out", str(tmp_path / "merged")]) == 0
    _assert_same(_results(tmp_path / "merged"), _results(tmp_path / "whole"))
    for name in ("longterm.json", "longterm_scatter.png", "longterm_polar.png", "longterm_ci.png"):
        assert (tmp_path / "whole" / name).is_file()
    payload = json.loads((tmp_path / "whole" / "longterm.json").read_text())
    assert payload["config"]["method"] == "theory" and list(payload["longterm"]) == ["25", "35"]
    assert set(payload["longterm"]["25"]) >= {
        "probability",
        "probability_ci95",
        "per_year",
        "dominating_cells",
    }
    assert "per_year_assumptions" in payload and payload["versions"]["jax_version"] == jax.__version__
    assert_labelled_output(tmp_path / "whole", "longterm")
    capsys.readouterr()
    assert main(["merge", files[0], "--out", str(tmp_path / "bad")]) == 2
    assert "each part 1/2 … 2/2 exactly once" in capsys.readouterr().err


@pytest.fixture(scope="module")
def calm_parts(tmp_path_factory):
    """Two parts of a cheap run (a calm scatter: every theory cell is 0 exactly), written and read back."""
    folder = tmp_path_factory.mktemp("calm_parts")
    kw = dict(headings=[math.pi, math.radians(150.0)], angles=ANGLES, exposure=1800.0, hours_per_year=5000.0)
    calm = parse_scatter(CALM, "calm.csv")
    return [_roundtrip(jxr.longterm(calm, part=f"{i}/2", **kw), folder / f"p{i}.nc") for i in (1, 2)]


def _edited(ds, edit, *, redigest=False):
    from jaxroll.longterm._dataset import part_digest

    ds = edit(ds.copy(deep=True))
    if redigest:  # as someone who recomputes the digest would: the range checks behind it
        ds.attrs["part_sha256"] = part_digest(ds)
    return ds


def _tripled(ds):
    ds["weight"] = ds.weight * 3
    return ds


def _set(var, value):
    def edit(ds):
        ds[var] = ds[var].where(~ds.computed, value)
        return ds

    return edit


def _attr(key, value):
    def edit(ds):
        ds.attrs[key] = value
        return ds

    return edit


MERGE_REFUSALS = [
    (_tripled, False, r"part 1/2\) was changed since jaxroll wrote it .*part_sha256"),
    (_set("probability", 7.0), False, r"was changed since jaxroll wrote it"),
    (_tripled, True, r"its cell weights do not sum to 1"),
    (_set("probability", 7.0), True, r"probability holds values outside \[0, 1\]"),
    (_set("capsize_probability", np.nan), True, r"a cell it computed has no probability \(NaN\)"),
    (
        _attr("jaxroll_version", "0.0.1"),
        True,
        r"written by another jaxroll or JAX \(jaxroll_version 0\.0\.1 \(this",
    ),
    (_attr("jax_version", "0.4.0"), True, r"written by another jaxroll or JAX \(jax_version 0\.4\.0"),
    (lambda ds: ds.drop_vars("seed"), False, r"lacks the variables seed: rerun that part"),
    (_attr("config_json", "[" * 5000 + "]" * 5000), False, r"its config_json attribute is not the JSON"),
    (_attr("part", "one/2"), False, r"its part attribute 'one/2' is not i/N"),
]


@pytest.mark.parametrize("edit, redigest, message", MERGE_REFUSALS)
def test_merge_refuses_edited_foreign_or_broken_parts(calm_parts, edit, redigest, message, tmp_path, capsys):
    """Issue 45 items 1, 6 and 10: a part whose weights were tripled merged into 3 × P_LT; other versions, NaN and
    7 as probabilities, a missing variable (KeyError), a config_json 5000 deep (RecursionError) and a bad part
    attribute ("invalid literal for int()") merged without a word or ended in a traceback."""
    bad = _edited(calm_parts[0], edit, redigest=redigest)
    with pytest.raises(ValueError, match=message):
        jxr.merge_longterm([bad, calm_parts[1]])
    path = tmp_path / "bad.nc"
    write_dataset(path, bad)
    other = tmp_path / "p2.nc"
    write_dataset(other, calm_parts[1])
    assert main(["merge", str(path), str(other), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"jaxroll merge: error: {path}") and re.search(message, err), err
    assert not (tmp_path / "out").exists()


def test_merged_parts_are_the_one_run(calm_parts, capsys):
    merged = jxr.merge_longterm(calm_parts)
    assert "part" not in merged.attrs and "part_sha256" not in merged.attrs
    assert calm_parts[0].attrs["part_sha256"] != calm_parts[1].attrs["part_sha256"]
    kw = dict(headings=[math.pi, math.radians(150.0)], angles=ANGLES, exposure=1800.0, hours_per_year=5000.0)
    _assert_same(merged, jxr.longterm(parse_scatter(CALM, "calm.csv"), **kw))
    with pytest.raises(SystemExit):
        main(["merge", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "bit for bit the same longterm.nc" not in text and "not the same bytes" in text


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def test_two_processes_equal_one(small_csv, tmp_path):
    """`jaxroll longterm --distributed` in 2 localhost processes writes the dataset of one process, bit for bit
    (Monte Carlo cells shared among the processes, each on its own devices)."""
    argv = [
        "longterm",
        "--scatter",
        str(small_csv),
        "--heading",
        "180,150",
        "--angle",
        "25,35",
        "--hours",
        "0.1",
        "--discard",
        "60",
        "--method",
        "monte-carlo",
        "--realizations",
        "6",
        "--quiet",
    ]
    assert main([*argv, "--out", str(tmp_path / "one")]) == 0
    env = {k: v for k, v in os.environ.items() if k != "JAX_NUM_CPU_DEVICES"}
    env.update(
        JAX_NUM_CPU_DEVICES="1",
        JAX_PLATFORMS="cpu",
        JAXROLL_NUM_PROCESSES="2",
        JAX_COORDINATOR_ADDRESS=f"localhost:{_free_port()}",
    )
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "jaxroll", *argv, "--distributed", "--out", str(tmp_path / "two")],
            env={**env, "JAXROLL_PROCESS_ID": str(pid)},
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for pid in (0, 1)
    ]
    for p in procs:
        _, err = p.communicate(timeout=600)
        assert p.returncode == 0, err[-3000:]
    _assert_same(_results(tmp_path / "two"), _results(tmp_path / "one"))


class Interrupt(Exception):
    pass


def test_checkpoint_resumes_cell_by_cell(small_csv, tmp_path):
    kw = dict(
        headings=[math.pi, math.radians(150)],
        angles=ANGLES,
        exposure=360.0,
        discard=60.0,
        method="monte-carlo",
        realizations=6,
    )
    whole = jxr.longterm(small_csv, **kw)
    calls = []

    def stop_after_first_cell(done, total, phase):  # in the second cell, once the first is saved
        calls.append(done)
        if done >= 12:
            raise Interrupt

    with pytest.raises(Interrupt):
        jxr.longterm(small_csv, checkpoint=tmp_path / "ck", progress=stop_after_first_cell, **kw)
    assert len(list((tmp_path / "ck").glob("mc_*.npz"))) == 1
    seen = []
    resumed = jxr.longterm(
        small_csv, checkpoint=tmp_path / "ck", progress=lambda d, t, p: seen.append(d), **kw
    )
    _assert_same(resumed, whole)
    assert seen[0] == 6  # the first cell came from the checkpoint
    # an edited unit file changes nothing: its digest fails, it is said and the unit computed again
    unit = sorted((tmp_path / "ck").glob("mc_*.npz"))[0]
    with np.load(unit, allow_pickle=False) as z:
        members = {k: z[k] for k in z.files}
    name = next(k for k in members if k != "__meta__" and members[k].dtype.kind == "f" and members[k].size)
    members[name] = members[name] + 1.0
    np.savez(unit, **members)
    with pytest.warns(
        UserWarning, match=r"checkpoint file .*mc_.*\.npz is unreadable, changed since jaxroll"
    ):
        again = jxr.longterm(small_csv, checkpoint=tmp_path / "ck", **kw)
    _assert_same(again, whole)


# ----------------------------------------------------------------------------------------------------------
# Notebook
# ----------------------------------------------------------------------------------------------------------


def test_notebook_runs_in_smoke_mode(tmp_path, monkeypatch):
    from helpers import run_notebook

    ns = run_notebook("07_longterm.ipynb", tmp_path, monkeypatch)
    assert "ds" in ns and float(ns["ds"].longterm_probability[0]) > 0


def test_a_fifo_in_place_of_a_unit_checkpoint_is_recomputed_not_a_hang(tmp_path):
    """Issue 45 item 7: a FIFO in place of a long-term unit's checkpoint hung the run (killed after 120 s)."""
    import threading

    kw = dict(headings=[math.pi], angles=ANGLES, exposure=1800.0, hours_per_year=5000.0, checkpoint=tmp_path)
    calm = parse_scatter(CALM, "calm.csv")
    ref = jxr.longterm(calm, **kw)
    (unit,) = tmp_path.glob("theory_*.npz")
    unit.unlink()
    os.mkfifo(unit)
    box = {}

    def run():
        with pytest.warns(UserWarning, match=r"theory_.*\.npz is not a regular file \(a FIFO"):
            box["ds"] = jxr.longterm(calm, **kw)

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(60)
    assert not t.is_alive() and "ds" in box
    _assert_same(box["ds"], ref)
    assert unit.is_file()  # saved again over the FIFO


def test_the_recorded_risk_command_is_shell_quoted(calm_parts, tmp_path):
    """Issue 45 item 11: a ship path with a space and ';' became a command line that ran `touch …` when pasted."""
    import shlex

    ds = jxr.merge_longterm(calm_parts)
    cfg = json.loads(ds.attrs["config_json"])
    evil = str(tmp_path / "my ship;touch PWNED;.toml")
    cfg["ships"][0]["file"] = evil
    ds.attrs["config_json"] = json.dumps(cfg)
    from jaxroll.longterm import risk_command

    command = risk_command(ds, dict(hs=0, tz=0, heading_deg=0, speed=0, ship=0))
    words = shlex.split(command)
    assert words[:2] == ["jaxroll", "risk"] and words[-2:] == ["--ship", evil]
    assert words[words.index("--seed") + 1] == str(int(ds.seed.values[0, 0, 0, 0, 0]) - 1)
    subprocess.run(["bash", "-c", "true" + command.removeprefix("jaxroll")], cwd=tmp_path, check=True)
    assert not (tmp_path / "PWNED").exists()


def test_figures_draw_every_angle_with_labelled_axes(calm_parts):
    """Issue 45 item 19: only the first --angle was drawn; the theory-only interval figure was one bar with no x
    axis; the scatter chart's colour bars had no label (its cell labels ~5 px high)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from jaxroll.plotting import longterm_ci_figure, longterm_polar_figure, longterm_scatter_figure

    ds = jxr.merge_longterm(calm_parts)  # two angles
    fig = longterm_scatter_figure(ds)
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_label() != "<colorbar>"]
    assert len(panels) == 3 and "25°" in panels[1].get_title() and "35°" in panels[2].get_title()
    bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert [ax.get_ylabel() for ax in bars] == [
        "occurrence [%]",
        "share of P_LT at 25° [%]",
        "share of P_LT at 35° [%]",
    ]
    assert all(t.get_fontsize() >= 6.5 for ax in panels for t in ax.texts)
    plt.close(fig)
    fig = longterm_polar_figure(ds)
    polar = [ax for ax in fig.axes if ax.name == "polar" and ax.get_visible()]
    labels = [ax.get_xlabel() for ax in fig.axes if ax.get_label() == "<colorbar>"]
    assert len(polar) == 3 and [x.split("\n")[0] for x in labels] == [
        "P(max |φ| > 25° within 0.5 h)", "P(max |φ| > 35° within 0.5 h)", "P(capsize within 0.5 h)"
    ]  # fmt: skip
    plt.close(fig)
    fig = longterm_ci_figure(ds)
    (ax,) = fig.axes
    assert ax.get_xlabel() == "roll angle [deg]" and [t.get_text() for t in ax.get_xticklabels()] == [
        "25°",
        "35°",
    ]
    plt.close(fig)
