"""Hull hydrostatics: box barge and Wigley closed forms, balance, signs, gradients, errors, CLI, notebook."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_labelled_output, run_notebook

import jaxroll  # noqa: F401  (enables float64)
from jaxroll import (
    Hull,
    box_hull,
    c11_hull,
    c11_hull_ship,
    equilibrium,
    gz_curve,
    hull_hydrostatics,
    hydrostatic_particulars,
    load_hull,
    load_ship,
    loading_condition,
    metacentric_height,
    wigley_hull,
)
from jaxroll.io._hull_file import hull_from_dict, hull_to_toml, loading_from_dict
from jaxroll.ship._fits import (
    default_heel_grid,
    default_zeta_grid,
    fit_delta_gm_polynomial,
    ship_from_hydrostatics,
)
from jaxroll.ship._hull import C11_GM0, c11_like_hull, scale_hull
from jaxroll.ship._hydrostatics import (
    GRAVITY,
    SEAWATER_DENSITY,
    buoyancy,
    c11_hull_loading,
)
from jaxroll.ship._ship import restoring_fields_from_gz, validate_ship

# Box barge L x B x D floating at draught d with centre of gravity at KG.
L, B, D, d, KG = 100.0, 20.0, 12.0, 5.0, 6.0
BM = B**2 / (12 * d)
GM = BM + d / 2 - KG


@pytest.fixture(scope="module")
def box():
    return box_hull(L, B, D)


@pytest.fixture(scope="module")
def box_loading(box):
    return loading_condition(box, kg=KG, draught=d)


@pytest.fixture(scope="module")
def c11():
    return c11_hull()


@pytest.fixture(scope="module")
def c11_loading():
    return c11_hull_loading()


@pytest.fixture(scope="module")
def c11_solution(c11, c11_loading):
    # Default grids: the CLI test below reuses this compilation.
    return hull_hydrostatics(c11, c11_loading)


def close(actual, expected, *, rtol, atol):
    np.testing.assert_allclose(np.asarray(actual), np.asarray(expected), rtol=rtol, atol=atol)


# ------------------------------------------------------------------------------------------------------------
# Box barge: closed forms
# ------------------------------------------------------------------------------------------------------------


def test_box_calm_particulars(box, box_loading):
    p = hydrostatic_particulars(box, box_loading)
    close(p.volume, L * B * d, rtol=1e-12, atol=0)
    close(p.displacement, L * B * d * SEAWATER_DENSITY, rtol=1e-12, atol=0)
    close(p.kb, d / 2, rtol=0, atol=1e-12)
    close(p.bm, BM, rtol=0, atol=1e-12)
    close(p.gm, GM, rtol=0, atol=1e-12)
    close(p.km, BM + d / 2, rtol=0, atol=1e-12)
    close(p.lcb, L / 2, rtol=0, atol=1e-10)
    close(p.trim, 0.0, rtol=0, atol=1e-10)
    close(p.waterplane_area, L * B, rtol=1e-12, atol=0)
    close(p.lcf, L / 2, rtol=0, atol=1e-10)
    close(p.bm_longitudinal, L**2 / (12 * d), rtol=1e-12, atol=0)
    for c in (p.block_coefficient, p.midship_coefficient, p.prismatic_coefficient, p.waterplane_coefficient):
        close(c, 1.0, rtol=1e-12, atol=0)


def test_box_gz_wall_sided(box, box_loading):
    # Wall-sided formula holds until the bilge emerges: tan φ < d / (B/2), φ < 26.57°; beyond, GZ is below it.
    phi = jnp.radians(jnp.array([-20.0, -5.0, 0.0, 2.0, 5.0, 10.0, 15.0, 20.0, 25.0, 26.0, 35.0, 50.0]))
    gz = gz_curve(box, box_loading, phi)
    wall_sided = jnp.sin(phi) * (GM + 0.5 * BM * jnp.tan(phi) ** 2)
    close(gz[:10], wall_sided[:10], rtol=0, atol=1e-11)
    assert np.all(np.asarray(gz[10:]) < np.asarray(wall_sided[10:]))
    # Positive heel (starboard down) gives a positive, righting GZ when GM > 0.
    assert float(gz[5]) > 0 > float(gz[0])


@pytest.mark.parametrize("zeta", [-2.0, 2.0], ids=["crest", "trough"])
def test_box_in_wave_against_sectional_closed_form(box, box_loading, zeta):
    # Each section is a rectangle whose centre-line draught is d_x = d + η(x)/cos φ (η is earth-vertical), so
    # ∇ = B ∫ d_x dx is kept with sinkage d cos φ and no trim, and summing the wall-sided sectional moments
    # gives GZ = sin φ [BM + (d² + ζ²/(2cos²φ))/(2d) − KG + ½ BM tan²φ], valid while no deck edge or bilge
    # crosses.
    phi = jnp.radians(jnp.array([0.0, 5.0, 10.0, 15.0]))
    eq = equilibrium(box, box_loading, heel=phi, zeta_mid=zeta)
    close(eq.sinkage, d * jnp.cos(phi), rtol=0, atol=1e-9)
    close(eq.trim, 0.0, rtol=0, atol=1e-9)
    close(eq.volume, L * B * d, rtol=1e-12, atol=0)
    close(eq.lcb, L / 2, rtol=0, atol=1e-9)
    kb_wave = (d**2 + zeta**2 / (2 * jnp.cos(phi) ** 2)) / (2 * d)
    expected = jnp.sin(phi) * (BM + kb_wave - KG + 0.5 * BM * jnp.tan(phi) ** 2)
    close(eq.gz, expected, rtol=0, atol=1e-10)
    assert bool(jnp.all(eq.converged))


@pytest.mark.parametrize("zeta", [-3.0, -1.0, 1.0, 3.0])
def test_box_delta_gm_even_in_zeta(box, box_loading, zeta):
    # Upright box in a wave of length L: no sinkage or trim, KB rises by ζ²/(4d) and BM is unchanged, so
    # ΔGM = ζ²/(4d) for crest and trough alike.
    p = hydrostatic_particulars(box, box_loading, zeta_mid=zeta)
    close(p.draught, d, rtol=0, atol=1e-10)
    close(p.trim, 0.0, rtol=0, atol=1e-10)
    close(p.kb, (d**2 + zeta**2 / 2) / (2 * d), rtol=0, atol=1e-11)
    close(p.bm, BM, rtol=0, atol=1e-11)
    close(p.gm - GM, zeta**2 / (4 * d), rtol=0, atol=1e-11)
    close(metacentric_height(box, box_loading, zeta_mid=zeta), p.gm, rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------------------------------------
# Wigley hull: closed forms and convergence
# ------------------------------------------------------------------------------------------------------------

WL, WB, WT, WD = 100.0, 10.0, 6.25, 10.0


def test_wigley_closed_forms():
    hull = wigley_hull(WL, WB, WT, WD, n_stations=65, n_waterlines=33)
    b = buoyancy(hull, WT)
    # BM = d(horizontal centre of buoyancy)/dφ − KB at fixed waterline (the volume is stationary in φ at φ =
    # 0).
    h = 1e-6
    bp, bn = buoyancy(hull, WT, heel=h), buoyancy(hull, WT, heel=-h)
    bm = (bp.horizontal_centre - bn.horizontal_centre) / (2 * h) - b.vertical_centre
    # Discretisation error O(Δx², Δz²): 5e-4 of the volume at this resolution (see the convergence test).
    close(b.volume, 4 / 9 * WL * WB * WT, rtol=1e-3, atol=0)
    close(b.vertical_centre, 5 * WT / 8, rtol=1e-4, atol=0)
    close(bm, 3 / 35 * WB**2 / WT, rtol=1e-3, atol=0)
    close(b.lcb, WL / 2, rtol=0, atol=1e-9)
    close(b.horizontal_centre, 0.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("refine", ["both", "stations", "waterlines"])
def test_wigley_second_order_convergence(refine):
    exact_v, exact_kb = 4 / 9 * WL * WB * WT, 5 * WT / 8
    vols, kbs = [], []
    for n in (9, 17, 33):
        ns = 2 * n - 1 if refine in ("both", "stations") else 33
        nw = n if refine in ("both", "waterlines") else 33
        b = buoyancy(wigley_hull(WL, WB, WT, WD, n_stations=ns, n_waterlines=nw), WT)
        vols.append(float(b.volume))
        kbs.append(float(b.vertical_centre))
    # Every Wigley section has the same shape, so KB does not depend on the stations at all.
    checks = ((vols, exact_v),) if refine == "stations" else ((vols, exact_v), (kbs, exact_kb))
    for values, exact in checks:
        if refine == "both":
            e = np.abs(np.asarray(values) - exact)
        else:  # the fixed direction's error is common to all three: use successive differences
            e = np.abs(np.diff(values))
        order = np.log2(e[:-1] / e[1:])
        assert np.all(np.abs(order - 2.0) < 0.2), (refine, order)


# ------------------------------------------------------------------------------------------------------------
# The representative C11-like hull
# ------------------------------------------------------------------------------------------------------------


def test_c11_hull_matches_table_1(c11, c11_solution):
    p = c11_solution.particulars
    assert c11.name == "C11-like hull (representative)"
    close(c11.lpp, 262.0, rtol=0, atol=0)
    close(c11.max_breadth, 40.0, rtol=0, atol=1e-9)
    close(c11.depth, 24.45, rtol=0, atol=0)
    close(p.draught, 11.5, rtol=0, atol=1e-9)
    # Table 1's Δ = 6.7247e7 kg and Cb = 0.56 are consistent only at ρ = 1000; at ρ = 1025 both within 2 %.
    close(p.displacement, 6.7247e7, rtol=0.02, atol=0)
    close(p.block_coefficient, 0.56, rtol=0.02, atol=0)
    close(p.gm, C11_GM0, rtol=0, atol=1e-3)
    close(p.trim, 0.0, rtol=0, atol=1e-8)
    assert 0.96 < float(p.midship_coefficient) < 0.99


def test_c11_file_is_the_formula():
    formula = c11_like_hull()
    text = hull_to_toml(formula, {"kg_m": 15.0, "draught_m": 11.5})
    again, loading = hull_from_dict(tomllib.loads(text))
    assert loading == {"kg_m": 15.0, "draught_m": 11.5}
    shipped = c11_hull()
    for h in (again, shipped):
        close(h.stations, formula.stations, rtol=0, atol=5.1e-5)
        close(h.waterlines, formula.waterlines, rtol=0, atol=5.1e-5)
        close(h.half_breadths, formula.half_breadths, rtol=0, atol=5.1e-5)


def test_the_shipped_hull_file_holds_the_models_c11_hull():
    """`c11_hull()` and `c11_hull_loading()` read no file (the model knows no file format, issue 45); the packaged
    `jaxroll/data/c11_hull.toml`, which `jaxroll sgisc` and users read, holds the same numbers to the last bit."""
    from jaxroll.io._hull_file import read_hull_file
    from jaxroll.ship import c11_hull_path

    hull, loading = read_hull_file(c11_hull_path())
    model = c11_hull()
    for field in ("stations", "waterlines", "half_breadths", "lpp", "depth"):
        np.testing.assert_array_equal(getattr(hull, field), getattr(model, field), err_msg=field)
    assert (hull.name, hull.provenance) == (model.name, model.provenance)
    from_file, ours = loading_from_dict(hull, loading), c11_hull_loading()
    for field in ("displacement", "kg", "lcg", "water_density", "draught"):
        np.testing.assert_array_equal(getattr(from_file, field), getattr(ours, field), err_msg=field)


def test_balance_conserved_everywhere(c11, c11_loading, c11_solution):
    sol = c11_solution
    assert bool(jnp.all(sol.converged))
    assert float(sol.max_volume_error) < 1e-10
    assert float(sol.max_lcb_error) < 1e-8
    # Independent check: the balanced waterlines, fed back without balance, displace the mass with LCB = LCG.
    zz, pp = jnp.meshgrid(sol.zeta_mid, sol.heels, indexing="ij")
    b = jax.vmap(lambda s, t, p, z: buoyancy(c11, s, trim=t, heel=p, zeta_mid=z))(
        sol.sinkage.ravel(), sol.trim.ravel(), pp.ravel(), zz.ravel()
    )
    close(b.volume, c11_loading.volume, rtol=1e-10, atol=0)
    close(b.lcb, c11_loading.lcg, rtol=0, atol=1e-7)
    close(b.horizontal_centre - c11_loading.kg * jnp.sin(pp.ravel()), sol.gz.ravel(), rtol=0, atol=1e-10)


def test_c11_wave_signs(c11_solution):
    sol = c11_solution
    z = np.asarray(sol.zeta_mid)
    dgm = np.asarray(sol.delta_gm)
    # Trough amidships (ζ_mid > 0) raises GM, crest amidships lowers it (CONVENTIONS.md; the paper's C1 > 0).
    assert np.all(dgm[z > 0] > 0) and np.all(dgm[z < 0] < 0)
    assert float(sol.delta_gm_coefficients[0]) == 0.0
    assert float(sol.delta_gm_coefficients[1]) > 0
    close(sol.delta_gm[z == 0], 0.0, rtol=0, atol=1e-12)
    i20 = int(np.argmin(np.abs(np.degrees(np.asarray(sol.heels)) - 20)))
    assert float(sol.gz[0, i20]) < float(sol.gz_calm[i20]) < float(sol.gz[-1, i20])
    # Calm row of the table equals the separate calm curve.
    close(sol.gz[z == 0][0], sol.gz_calm, rtol=0, atol=1e-10)
    # Fits reproduce the table.
    poly = sum(c * sol.zeta_mid**k for k, c in enumerate(sol.delta_gm_coefficients))
    close(poly, sol.delta_gm, rtol=0, atol=5 * float(sol.delta_gm_fit_rms))
    assert float(sol.delta_gm_fit_rms) < 0.05
    assert float(sol.gz_fit_rms) < 0.05


def test_gm_is_the_slope_of_the_free_trim_gz(c11, c11_loading, c11_solution):
    # GM is ∂GZ/∂φ at φ = 0 with sinkage and trim held (they are stationary there by symmetry). The hull has
    # kinks at its offsets (the calm waterline is one), which add a c·φ|φ| term to GZ: the central difference
    # is off by c·h, hence the tiny step.
    h = 1e-6
    sol = c11_solution
    zeta = jnp.array([0.0, -3.0, 3.0])
    idx = jnp.searchsorted(sol.zeta_mid, zeta[1:])
    close(sol.zeta_mid[idx], zeta[1:], rtol=0, atol=1e-12)
    gm = jnp.concatenate([sol.gm0[None], sol.gm[idx]])
    # Same shapes and options as the CLI's figure curves (heels (1, 37), amplitudes (3, 1)): one compilation.
    heel = jnp.concatenate([jnp.array([-h, h]), jnp.radians(jnp.linspace(5.0, 90.0, 35))])[None, :]
    eq = equilibrium(c11, c11_loading, heel=heel, zeta_mid=zeta[:, None], throw=False)
    assert bool(jnp.all(eq.converged))
    slope = (eq.gz[:, 1] - eq.gz[:, 0]) / (2 * h)
    close(gm, slope, rtol=0, atol=1e-5)


def test_ship_from_hull(c11, c11_solution):
    ship = c11_hull_ship()
    validate_ship(ship)
    sol = c11_solution
    close(ship.gm0, C11_GM0, rtol=0, atol=1e-3)
    close(ship.roll_period, 24.4, rtol=0, atol=0)
    close(ship.delta_gm, sol.delta_gm_coefficients, rtol=1e-12, atol=1e-15)
    close(
        ship.restoring,
        restoring_fields_from_gz(sol.gz_coefficients, float(sol.gm0), 24.4),
        rtol=1e-12,
        atol=0,
    )
    close(ship.displacement, sol.particulars.displacement, rtol=1e-12, atol=0)
    close(ship.damping, jaxroll.c11_representative().damping, rtol=0, atol=0)
    assert "REPRESENTATIVE" in ship.provenance
    gy = ship_from_hydrostatics(sol, c11, roll_gyradius=16.0, added_inertia=0.2)
    close(
        gy.roll_period,
        2 * math.pi * 16.0 * math.sqrt(1.2) / math.sqrt(GRAVITY * float(sol.gm0)),
        rtol=1e-12,
        atol=0,
    )


# ------------------------------------------------------------------------------------------------------------
# Gradients against central finite differences
# ------------------------------------------------------------------------------------------------------------


def test_grad_matches_finite_difference(c11):
    # A scalar through everything: scaled hull -> loading -> balanced GM(ζ) -> least-squares ΔGM fit -> the
    # fitted GM in a 3 m trough, GM0 + Σ C_k 3^k. Gradient w.r.t. (breadth factor, KG) vs a central
    # difference.
    zeta = jnp.array([-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0])

    def fitted_gm_3m(breadth, kg):
        hull = scale_hull(c11, breadth=breadth)
        loading = loading_condition(hull, kg=kg, draught=11.5)
        gm = metacentric_height(hull, loading, zeta_mid=zeta)
        c, _ = fit_delta_gm_polynomial(zeta, gm - gm[3], degree=3)
        return gm[3] + jnp.sum(c * 3.0 ** jnp.arange(7, dtype=float))

    x0 = (jnp.asarray(1.0), jnp.asarray(15.5))
    grad = jax.jit(jax.grad(fitted_gm_3m, argnums=(0, 1)))(*x0)
    f = jax.jit(fitted_gm_3m)
    fd_breadth = (f(x0[0] + 1e-5, x0[1]) - f(x0[0] - 1e-5, x0[1])) / 2e-5
    fd_kg = (f(x0[0], x0[1] + 1e-4) - f(x0[0], x0[1] - 1e-4)) / 2e-4
    close(grad[0], fd_breadth, rtol=1e-6, atol=0)
    close(grad[1], fd_kg, rtol=0, atol=1e-7)
    close(grad[1], -1.0, rtol=0, atol=1e-9)  # KG enters GM only as −KG
    assert float(grad[0]) > 1.0  # a wider ship has a larger GM


# ------------------------------------------------------------------------------------------------------------
# Validation: every message
# ------------------------------------------------------------------------------------------------------------


def _offsets(**changes):
    kw = dict(
        stations=[0.0, 50.0, 100.0],
        waterlines=[0.0, 5.0],
        half_breadths=[[1.0, 2.0], [3.0, 4.0], [1.0, 2.0]],
        lpp=100.0,
        depth=10.0,
    )
    kw.update(changes)
    return kw


@pytest.mark.parametrize(
    "changes, match",
    [
        (dict(stations=[0.0]), r"`stations` must be a 1-D list of at least 2"),
        (dict(waterlines=[[0.0, 5.0]]), r"`waterlines` must be a 1-D list of at least 2"),
        (
            dict(half_breadths=[[1.0, 2.0], [3.0, 4.0]]),
            r"one row per station and one column per waterline, shape \(3, 2\)",
        ),
        (
            dict(half_breadths=[[1.0, 2.0], [3.0, math.nan], [1.0, 2.0]]),
            r"`half_breadths` contains a non-finite value \(nan\) at index \(1, 1\)",
        ),
        (dict(stations=[0.0, math.inf, 100.0]), r"`stations` contains a non-finite value"),
        (dict(lpp=-1.0), r"`lpp` must be a finite length > 0 \[m\]; got -1.0"),
        (dict(depth=math.nan), r"`depth` must be a finite length > 0"),
        (
            dict(stations=[0.0, 60.0, 50.0]),
            r"`stations` must be strictly increasing; got stations\[2\] = 50.0 after stations\[1\] = 60.0",
        ),
        (dict(waterlines=[5.0, 5.0]), r"`waterlines` must be strictly increasing.*remove duplicates"),
        (
            dict(half_breadths=[[1.0, 2.0], [3.0, -4.0], [1.0, 2.0]]),
            r"half-breadths must be >= 0 .* got -4.0 at station 1 \(x = 50.0 m\), waterline 1 \(z = 5.0 m\)",
        ),
        (dict(half_breadths=[[0.0, 0.0]] * 3), r"every half-breadth is zero"),
        (dict(depth=4.0), r"highest waterline z = 5.0 m is above the depth D = 4.0 m"),
        (
            dict(stations=[-50.0, 0.0, 50.0]),
            r"does not contain amidships x = Lpp/2 = 50.0 m.*station_origin = \"amidships\"",
        ),
    ],
)
def test_hull_validation_messages(changes, match):
    with pytest.raises(ValueError, match=match):
        Hull(**_offsets(**changes))


def _hull_dict(**hull_changes):
    table = dict(
        lpp_m=100.0,
        depth_m=10.0,
        stations_m=[0.0, 50.0, 100.0],
        waterlines_m=[0.0, 5.0],
        half_breadths_m=[[1.0, 2.0], [3.0, 4.0], [1.0, 2.0]],
    )
    table.update(hull_changes)
    return {"name": "test", "hull": table}


@pytest.mark.parametrize(
    "data, match",
    [
        ([1, 2], r"a hull file must be a TOML table"),
        ({"hull": {}, "ship": 1}, r"unknown top-level field\(s\) \['ship'\]"),
        ({"name": "x"}, r"missing \[hull\] table"),
        (_hull_dict(breadth_m=3.0), r"unknown field\(s\) \['breadth_m'\] in \[hull\]"),
        (
            {"hull": {"lpp_m": 1.0}},
            r"missing field\(s\) \['depth_m', 'half_breadths_m', 'stations_m', 'waterlines_m'\]",
        ),
        (_hull_dict(lpp_m="262"), r"\[hull\] lpp_m must be a number \[m\]; got '262'"),
        (_hull_dict(stations_m=[0.0, "a", 100.0]), r"\[hull\] stations_m\[1\] must be a number"),
        (_hull_dict(waterlines_m=[]), r"\[hull\] waterlines_m must be a non-empty list"),
        (_hull_dict(half_breadths_m=[1.0, 2.0, 3.0]), r"half_breadths_m must be a list of rows"),
        (_hull_dict(half_breadths_m=[[1.0, 2.0], [3.0, 4.0]]), r"has 2 rows but there are 3 stations"),
        (
            _hull_dict(half_breadths_m=[[1.0, 2.0], [3.0], [1.0, 2.0]]),
            r"ragged: row 1 \(station x = 50.0 m\) has 1 values but there are 2 waterlines",
        ),
        (
            _hull_dict(half_breadths_m=[[1.0, 2.0], [3.0, True], [1.0, 2.0]]),
            r"half_breadths_m\[1\]\[1\] must be a number",
        ),
        (_hull_dict(station_origin="fp"), r"station_origin must be \"ap\" .* or \"amidships\"; got 'fp'"),
        (_hull_dict(stations_m=[-50.0, 0.0, -10.0]), r"test.toml: `stations` must be strictly increasing"),
        ({**_hull_dict(), "loading": 3}, r"\[loading\] must be a table"),
        ({**_hull_dict(), "loading": {"gm_m": 1.0}}, r"unknown field\(s\) \['gm_m'\] in \[loading\]"),
        ({**_hull_dict(), "loading": {"kg_m": "high"}}, r"\[loading\] kg_m must be a number"),
        (
            {**_hull_dict(), "loading": {"draught_m": 3.0, "displacement_kg": 1e6}},
            r"gives both draught_m and displacement_kg",
        ),
    ],
)
def test_hull_file_messages(data, match):
    with pytest.raises(ValueError, match=match):
        hull_from_dict(data, source="test.toml")


def test_hull_file_amidships_origin_and_io_errors(tmp_path):
    hull, _ = hull_from_dict(_hull_dict(stations_m=[-50.0, 0.0, 50.0], station_origin="amidships"))
    close(hull.stations, [0.0, 50.0, 100.0], rtol=0, atol=0)
    with pytest.raises(FileNotFoundError, match=r"Hull file '.*nope.toml' does not exist"):
        load_hull(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[hull\nlpp_m = 3")
    with pytest.raises(ValueError, match=r"bad.toml: not valid TOML"):
        load_hull(bad)
    nan = tmp_path / "nan.toml"
    nan.write_text(
        "[hull]\nlpp_m = 100.0\ndepth_m = 10.0\nstations_m = [0.0, 50.0, 100.0]\nwaterlines_m = [0.0, 5.0]\n"
        "half_breadths_m = [[1.0, nan], [3.0, 4.0], [1.0, 2.0]]\n"
    )
    with pytest.raises(
        ValueError, match=r"nan.toml: `half_breadths` contains a non-finite value \(nan\) at index \(0, 1\)"
    ):
        load_hull(nan)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(kg=5.0), r"Give exactly one of `draught` \[m\] and `displacement` \[kg\]"),
        (dict(kg=5.0, draught=3.0, displacement=1e6), r"Give exactly one of `draught`"),
        (dict(kg=math.nan, draught=3.0), r"`kg` must be a finite number; got nan"),
        (dict(kg=[1.0, 2.0], draught=3.0), r"`kg` must be a scalar; got shape \(2,\)"),
        (dict(kg=5.0, draught=3.0, water_density=-1.0), r"`water_density` must be > 0"),
        (dict(kg=5.0, displacement=0.0), r"`displacement` must be > 0"),
        (dict(kg=5.0, draught=10.0), r"draught d = 10.0 m is at or above the depth D = 10.0 m"),
        (
            dict(kg=5.0, draught=0.0),
            r"draught d = 0.0 m is at or below the lowest waterline of the offsets, z = 0.0 m",
        ),
        (
            dict(kg=5.0, displacement=1e9),
            r"displacement 1e\+09 kg is more than the hull can float: .* displaces 5\.6375e\+06 kg",
        ),
        (
            dict(kg=5.0, draught=3.0, lcg=120.0),
            r"LCG = 120.0 m is outside the hull \(stations span x = 0.0 .. 100.0 m",
        ),
    ],
)
def test_loading_messages(kwargs, match):
    hull = Hull(**_offsets())
    with pytest.raises(ValueError, match=match):
        loading_condition(hull, **kwargs)


def test_other_messages(box, box_loading, c11_solution, c11):
    with pytest.raises(
        ValueError, match=r"KG is required: give `kg` \[m\] \(CLI: --kg\) or set \[loading\] kg_m"
    ):
        loading_from_dict(box, {"draught_m": 3.0})
    with pytest.raises(ValueError, match=r"`zeta_max` must be a finite amplitude > 0 \[m\]; got -1.0"):
        default_zeta_grid(-1.0)
    with pytest.raises(ValueError, match=r"give at least 7 amplitudes; got n_zeta = 5"):
        default_zeta_grid(3.0, 5)
    with pytest.raises(ValueError, match=r"`heel_max` must be in \(0, π/2\] rad \(0–90°\); got 70.0 rad"):
        default_heel_grid(70.0)
    with pytest.raises(ValueError, match=r"give at least 5 heels; got n_heel = 3"):
        default_heel_grid(1.0, 3)
    with pytest.raises(ValueError, match=r"at least 6 distinct non-zero amplitudes"):
        hull_hydrostatics(box, box_loading, zeta_mid=[-1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match=r"at least 4 distinct non-zero heels"):
        hull_hydrostatics(box, box_loading, heels=[0.0, 0.1])
    with pytest.raises(
        ValueError, match=r"`heels` must be in radians within \[−π/2, π/2\]; got max \|φ\| = 60.0"
    ):
        hull_hydrostatics(box, box_loading, heels=[0.0, 15.0, 30.0, 45.0, 60.0])
    with pytest.raises(ValueError, match=r"`zeta_mid` and `heels` must be 1-D grids"):
        hull_hydrostatics(box, box_loading, zeta_mid=np.ones((2, 7)))
    with pytest.raises(ValueError, match=r"`degree` must be between 1 and 6"):
        fit_delta_gm_polynomial(jnp.ones(8), jnp.ones(8), degree=7)
    with pytest.raises(
        ValueError, match=r"give exactly one of `roll_period` \[s\] and `roll_gyradius` \[m\]"
    ):
        ship_from_hydrostatics(c11_solution, c11)
    with pytest.raises(ValueError, match=r"`roll_period` must be a finite period > 0 \[s\]; got -3.0"):
        ship_from_hydrostatics(c11_solution, c11, roll_period=-3.0)


def test_unbalanceable_loading_raises(box):
    # LCG at the bow: no trim can bring the LCB there before the deck dips, so the balance cannot converge.
    loading = loading_condition(box, kg=KG, draught=d, lcg=L)
    with pytest.raises(RuntimeError, match=r"quasi-static balance \(sinkage and trim\) did not converge"):
        equilibrium(box, loading, heel=jnp.zeros(4), zeta_mid=0.0)  # shapes of the wave test: no recompile


# ------------------------------------------------------------------------------------------------------------
# CLI, plots, notebook
# ------------------------------------------------------------------------------------------------------------


def test_cli_end_to_end_c11(tmp_path, c11_solution, capsys):
    from jaxroll._cli import main

    out = tmp_path / "hs"
    kg = float(c11_solution.particulars.kg)
    argv = [
        "hydrostatics",
        "c11",
        "--kg",
        repr(kg),
        "--draught",
        "11.5",
        "--roll-period",
        "24.4",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    stdout = capsys.readouterr().out
    assert "REPRESENTATIVE" in stdout
    for name in ("hydrostatics.json", "ship.toml", "gz_curves.png", "delta_gm.png", "body_plan.png"):
        assert (out / name).stat().st_size > 0
    ship = load_ship(out / "ship.toml")
    close(ship.gm0, c11_solution.gm0, rtol=1e-12, atol=0)
    close(ship.delta_gm, c11_solution.delta_gm_coefficients, rtol=1e-9, atol=1e-12)
    close(ship.roll_period, 24.4, rtol=0, atol=0)
    data = json.loads((out / "hydrostatics.json").read_text())
    assert data["jaxroll_version"] == jaxroll.__version__
    assert len(data["tables"]["gz_m"]) == 13 and len(data["tables"]["gz_m"][0]) == 15
    assert data["tables"]["heel_deg"][-1] == pytest.approx(70.0)
    assert data["balance_check"]["all_converged"] is True
    assert set(data["fits"]["delta_gm_coefficients"]) == {f"c{k}" for k in range(7)}
    close(data["calm_water"]["gm_m"], c11_solution.gm0, rtol=1e-12, atol=0)
    assert_labelled_output(out, "hydrostatics")


def test_cli_table_worker_imports_nothing(tmp_path):
    """`jaxroll hydrostatics` loads and dispatches the table in a worker thread while its main thread imports
    matplotlib and xarray: the worker must import no module (two threads importing at once can wait on each other's
    import locks). In a fresh process (the program stored by `test_cli_end_to_end_c11`), every import made by
    another thread than the main one is recorded."""
    import subprocess
    import sys

    code = f"""
import sys, threading
imported = []
class Spy:
    def find_spec(self, name, path=None, target=None):
        if threading.current_thread() is not threading.main_thread():
            imported.append(name)
sys.meta_path.insert(0, Spy())
from jaxroll._cli import main
code = main(["hydrostatics", "c11", "--out", {str(tmp_path / "hs")!r}])
print(code, imported)
"""
    root = Path(__file__).resolve().parents[1]
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=root)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "0 []"


def test_cli_balance_that_fails_is_an_error_line(tmp_path, capsys):
    """A loading no trim can balance (LCG at the FP): one line and exit 2, nothing written (the same program as
    `test_cli_end_to_end_c11`'s: no compilation)."""
    from jaxroll._cli import main

    out = tmp_path / "hs"
    assert main(["hydrostatics", "c11", "--lcg", "262", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert (
        "jaxroll hydrostatics: error: the quasi-static balance (sinkage and trim) did not converge for "
        in err
    )
    assert "of the 195 (ζ_mid, φ) cases" in err and "--lcg" in err and "Traceback" not in err
    assert not out.exists() or not any(out.iterdir())


def test_cli_errors(tmp_path, box, capsys):
    from jaxroll._cli import main

    hull_file = tmp_path / "box.toml"
    hull_file.write_text(hull_to_toml(box, {"kg_m": KG, "draught_m": d}))
    assert main(["hydrostatics", str(hull_file), "--out", str(tmp_path / "o")]) == 2
    assert "roll period is not a hydrostatic quantity: give --roll-period S" in capsys.readouterr().err
    assert main(["hydrostatics", str(tmp_path / "missing.toml")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["hydrostatics", str(hull_file), "--roll-period", "9", "--zeta-max", "-1"]) == 2
    assert "--zeta-max must be a finite number > 0" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["hydrostatics", "--help"])
    assert e.value.code == 0


def test_plots_return_axes(box, box_loading):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from jaxroll.plotting._hydrostatics import plot_body_plan, plot_delta_gm, plot_gz_curves

    phi = np.radians(np.arange(0.0, 31.0, 10.0))
    z = np.linspace(-1.0, 1.0, 7)
    axes = [
        plot_body_plan(box, draught=d),
        plot_gz_curves(phi, {"calm": np.sin(phi)}, fit=(1.0, (0.0, 0.0, 0.0, 0.0)), fit_heel_max=0.5),
        plot_delta_gm(z, z**2, [0, 0, 1, 0, 0, 0, 0], reference=[0, 0.5, 0, 0, 0, 0, 0]),
    ]
    for ax in axes:
        assert isinstance(ax, matplotlib.axes.Axes)
        plt.close(ax.figure)


def test_notebook_smoke(tmp_path, monkeypatch):
    run_notebook("05_hydrostatics.ipynb", tmp_path, monkeypatch)
    assert (tmp_path / "jaxroll-out" / "ship_from_c11_hull.toml").is_file()  # not into notebooks/ (issue 13)
