r"""The BEM wave moment (issue 44, item 1: capytaine): the panels of the hull jaxroll reads, the checks a BEM mesh
needs, the ship file's A44(ω), B44(ω), and — where capytaine is installed (`pip install "jaxroll[bem]"`; CI does not
install it and those tests skip) — capytaine's own answers reproduced through jaxroll's path, its Froude–Krylov
moment against `froude_krylov_roll_moment`, and the frequency-domain roll against `linear_roll_variance`.
"""

import json
import math
import sys

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

from jaxroll.ship import (
    MeshNotFitError,
    bem_mesh,
    box_hull,
    c11_hull,
    c11_hull_loading,
    equilibrium,
    loading_condition,
    moment_table,
)
from jaxroll.ship._bem_mesh import check_panel_size, offsets_panels
from jaxroll.ship._hydrostatics import GRAVITY
from jaxroll.ship._surface import hull_surface

RHO = 1025.0


@pytest.fixture(scope="module")
def box():
    """A box barge 60 × 12 × 8 m at d = 4 m, KG = 4.5 m (G 0.5 m above the waterline)."""
    hull = box_hull(60.0, 12.0, 8.0, n_stations=3, n_waterlines=2)
    return hull, loading_condition(hull, kg=4.5, draught=4.0, water_density=RHO)


def _volume(mesh):
    """∇ = ∮ z n_z dS over the wetted panels, both halves (the missing waterplane has z = 0): outward normals."""
    v, f = mesh.mirrored()
    p = v[f]
    n = np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1]) / 2
    tri = f[:, 2] == f[:, 3]
    centre = np.where(tri[:, None], p[:, :3].mean(axis=1), p.mean(axis=1))
    return float(np.sum(centre[:, 2] * n[:, 2]))


# ------------------------------------------------------------------------------------------------------------
# Panels and checks: no capytaine
# ------------------------------------------------------------------------------------------------------------


def test_panels_are_the_hull_jaxroll_reads(box):
    """The wetted panels enclose the loading's volume (divergence theorem, outward normals), exactly for the box
    upright and trimmed (a rigid rotation of the hull) and for the C11-like offsets (every station and waterline kept:
    the polygon hull itself, but for its warped panels); no panel edge exceeds the size asked; G and the roll axis in the BEM frame."""
    hull, loading = box
    mesh = bem_mesh(hull, loading, sinkage=4.0, trim=0.0, panel_size=3.0)
    assert mesh.n_panels == 176  # bottom 20 × 4, sides 2 × 20 × 2, ends 2 × 4 × 2
    assert mesh.panel_size == pytest.approx(3.0)
    assert _volume(mesh) == pytest.approx(60 * 12 * 4, rel=1e-12)
    np.testing.assert_allclose(mesh.centre_of_gravity, [0.0, 0.0, 0.5], atol=1e-12)
    trimmed = bem_mesh(
        hull, loading, sinkage=4.0, trim=1.5, panel_size=3.0
    )  # waterline 3.25 m aft, 4.75 m forward
    assert _volume(trimmed) == pytest.approx(60 * 12 * 4, rel=1e-12)
    assert trimmed.trim_angle == pytest.approx(math.atan(1.5 / 60))
    assert np.max(trimmed.vertices[:, 2]) == pytest.approx(0.0, abs=1e-12)

    hull, loading = c11_hull(), c11_hull_loading()
    eq = equilibrium(hull, loading)
    for size in (6.0, 4.6):
        mesh = bem_mesh(hull, loading, sinkage=float(eq.sinkage), trim=float(eq.trim), panel_size=size)
        assert mesh.panel_size <= size
        # every station and waterline kept: the offsets' polygon hull, but for its warped quadrilaterals (the ends),
        # each split into two plane triangles (measured: −1.1e-4, −0.9e-4)
        assert _volume(mesh) == pytest.approx(float(loading.volume), rel=2e-4)
    assert 3000 <= mesh.n_panels <= 3500  # the benchmark's mesh (benchmarks/bem.py)


def _triangles(hull, panel_size):
    """The box's closed surface as triangles (both halves), hull frame."""
    q = offsets_panels(hull, panel_size)
    q = np.concatenate([q, (q * [1, -1, 1])[:, ::-1]])
    return np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])


def test_a_mesh_open_below_the_waterline_or_not_floating_is_refused(box):
    hull, loading = box
    tri = _triangles(hull, 3.0)
    centre = tri.mean(axis=1)
    hole = np.argmin(
        np.abs(centre[:, 0] - 30) + np.abs(centre[:, 1] - 6) + np.abs(centre[:, 2] - 1)
    )  # side, 3 m deep
    holed = eqx.tree_at(
        lambda h: h.surface, hull, hull_surface(np.delete(tri, hole, axis=0)), is_leaf=lambda x: x is None
    )
    bem_mesh(eqx.tree_at(lambda h: h.surface, hull, hull_surface(tri), is_leaf=lambda x: x is None), loading,
             sinkage=4.0, trim=0.0)  # fmt: skip
    with pytest.raises(MeshNotFitError, match=r"box: the wetted surface is open below the waterline \(3 free panel "
                       r"edges, e\.g\. at .* m from amidships, .* m deep\)"):  # fmt: skip
        bem_mesh(holed, loading, sinkage=4.0, trim=0.0)
    with pytest.raises(MeshNotFitError, match="does not pierce the free surface .*deck is under water"):
        bem_mesh(hull, loading, sinkage=9.0, trim=0.0, panel_size=3.0)
    with pytest.raises(ValueError, match="`panel_size` is for a hull of offsets"):
        bem_mesh(holed, loading, sinkage=4.0, trim=0.0, panel_size=2.0)


def test_panels_too_coarse_for_the_shortest_wave_are_refused(box):
    hull, loading = box
    mesh = bem_mesh(hull, loading, sinkage=4.0, trim=0.0, panel_size=3.0)
    lam = 2 * math.pi * GRAVITY / 1.5**2  # 27.4 m: λ/6 = 4.57 m ≥ 3 m
    check_panel_size(mesh, 1.5)
    with pytest.raises(MeshNotFitError, match=r"panels up to 3 m long .*ω = 2\.5 rad/s, λ = 9\.859 m\): a panel must be at "
                       r"most λ/6 = 1\.64 m\. Mesh the hull finer .* solve up to ω ≤ 1\.85 rad/s"):  # fmt: skip
        check_panel_size(mesh, 2.5)
    assert lam / 6 > 3


def test_capytaine_missing_names_the_extra(box, monkeypatch, tmp_path, capsys):
    from jaxroll._cli import main
    from jaxroll.ship import BemNotInstalledError, bem_roll_coefficients

    monkeypatch.setitem(sys.modules, "capytaine", None)
    with pytest.raises(
        BemNotInstalledError, match=r'capytaine, which is not installed: pip install "jaxroll\[bem\]"'
    ):
        bem_roll_coefficients(*box, omega=[0.5])
    assert main(["hydrostatics", "c11", "--wave-moment", "bem", "--out", str(tmp_path / "hs")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        'jaxroll hydrostatics: error: --wave-moment bem needs capytaine, which is not installed: pip install "jaxroll[bem]".'
    )


def test_bem_options_without_the_bem_are_refused(tmp_path, capsys):
    from jaxroll._cli import main

    argv = ["hydrostatics", "c11", "--bem-lid", "--bem-headings", "13", "--out", str(tmp_path / "hs")]
    assert main(argv) == 2
    assert capsys.readouterr().err.strip() == (
        "jaxroll hydrostatics: error: --bem-headings, --bem-lid set(s) the BEM: give --wave-moment bem, or leave it out."
    )


def test_ship_file_carries_a44_b44_and_old_files_load(tmp_path):
    """A BEM table's A44(ω), B44(ω) round-trip through the ship file; a file without them (froude-krylov) loads as
    before; one of the two alone, or a wrong length, is refused."""
    from jaxroll.io import load_ship, ship_from_dict, ship_to_dict, ship_to_toml
    from jaxroll.ship import c11_representative

    ship = c11_representative()
    omega, headings = np.linspace(0.0, 2.0, 5), np.array([0.0, math.pi / 2, math.pi])
    moment = np.outer(np.sin(headings), omega**2) * (1e6 + 2e5j)
    added, damping = np.linspace(3e9, 2e9, 5), np.array([0.0, 1e7, 5e8, 3e8, 1e8])
    table = moment_table(
        omega, headings, moment, ship, source="bem", added_inertia=added, radiation_damping=damping
    )
    bem_ship = eqx.tree_at(lambda s: s.wave_moment, ship, table, is_leaf=lambda x: x is None)
    path = tmp_path / "ship.toml"
    path.write_text(ship_to_toml(bem_ship))
    back = load_ship(path).wave_moment
    assert back.source == "bem"
    np.testing.assert_array_equal(np.asarray(back.added_inertia), added)
    np.testing.assert_array_equal(np.asarray(back.radiation_damping), damping)
    a, b = back.radiation(1.25)
    assert (float(a), float(b)) == pytest.approx((2.375e9, 4e8))
    plain = ship_to_dict(eqx.tree_at(lambda s: (s.wave_moment.added_inertia, s.wave_moment.radiation_damping), bem_ship,
                                     (None, None), is_leaf=lambda x: x is None))  # fmt: skip
    assert "added_inertia_kg_m2" not in plain["wave_moment"]
    assert ship_from_dict(plain).wave_moment.added_inertia is None
    with pytest.raises(ValueError, match="carries no added inertia or radiation damping"):
        ship_from_dict(plain).wave_moment.radiation(0.3)
    half = ship_to_dict(bem_ship)
    del half["wave_moment"]["radiation_damping_N_m_s"]
    with pytest.raises(
        ValueError, match="give both added_inertia_kg_m2 and radiation_damping_N_m_s, or neither"
    ):
        ship_from_dict(half, source="s.toml")
    short = ship_to_dict(bem_ship)
    short["wave_moment"]["added_inertia_kg_m2"] = added[:-1].tolist()
    with pytest.raises(
        ValueError, match=r"added inertia A44 \[kg m²\] must be one finite value >= 0 per frequency"
    ):
        ship_from_dict(short, source="s.toml")


# ------------------------------------------------------------------------------------------------------------
# With capytaine
# ------------------------------------------------------------------------------------------------------------

OMEGA = np.array([0.4, 0.8, 1.2])
HEADINGS = np.radians([0.0, 60.0, 90.0, 120.0, 180.0])


@pytest.fixture(scope="module")
def box_bem(box):
    pytest.importorskip("capytaine")
    from jaxroll.ship import bem_roll_coefficients

    return bem_roll_coefficients(*box, omega=OMEGA, headings=HEADINGS, panel_size=3.0)


def test_capytaines_own_answers_are_reproduced(box, box_bem):
    """capytaine driven directly — its own box mesh (`mesh_parallelepiped`, the same 176 panels), its frame and
    conventions (e^{−iωt}, wave direction β from x towards port, roll about +x through G) — against
    `bem_roll_coefficients` through jaxroll's mesh and conventions (e^{iωt}: the conjugate; χ = −β)."""
    cpt = pytest.importorskip("capytaine")
    mesh = cpt.mesh_parallelepiped(size=(60.0, 12.0, 4.0), center=(0.0, 0.0, -2.0), resolution=(20, 4, 2),
                                   missing_sides={"top"})  # fmt: skip
    body = cpt.FloatingBody(mesh, dofs=cpt.rigid_body_dofs(only=["Roll"], rotation_center=(0.0, 0.0, 0.5)))
    solver = cpt.BEMSolver()
    r = box_bem
    assert r.n_panels == mesh.nb_faces == 176
    for i, w in enumerate(OMEGA, start=1):
        rad = solver.solve(cpt.RadiationProblem(body=body, radiating_dof="Roll", omega=w, rho=RHO, g=GRAVITY))
        assert r.added_inertia[i] == pytest.approx(rad.added_mass["Roll"], rel=1e-6)
        assert r.radiation_damping[i] == pytest.approx(rad.radiation_damping["Roll"], rel=1e-6)
        for j, chi in enumerate(HEADINGS):
            pb = cpt.DiffractionProblem(body=body, wave_direction=-chi, omega=w, rho=RHO, g=GRAVITY)
            total = solver.solve(pb).forces["Roll"] + cpt.bem.airy_waves.froude_krylov_force(pb)["Roll"]
            ours = r.diffraction[j, i] + r.froude_krylov_panels[j, i]
            assert abs(ours - np.conj(total)) <= 1e-6 * np.max(np.abs(r.excitation[:, i]))
    assert r.added_inertia[0] > 0 and r.radiation_damping[0] == 0 and np.all(r.excitation[:, 0] == 0)
    # head and following seas: no roll moment on a hull symmetric port and starboard
    assert np.max(np.abs(r.excitation[[0, -1]])) <= 1e-9 * np.max(np.abs(r.excitation))


def test_capytaines_froude_krylov_converges_to_jaxrolls(box):
    """capytaine's Froude–Krylov moment (one point per panel) on jaxroll's panels against
    `froude_krylov_roll_moment` (exact for the hull): the error falls as the panel size squared. Beam seas, ω = 0.8
    rad/s: the long-wave cancellation of BM against KG − KB makes the roll moment of a low-GM hull sensitive to the
    quadrature (20 % at panels of 1.5 m on this box of GM 0.5 m): why the BEM table takes jaxroll's."""
    cpt = pytest.importorskip("capytaine")
    from jaxroll.ship import froude_krylov_roll_moment
    from jaxroll.ship._bem import _body

    hull, loading = box
    exact = complex(froude_krylov_roll_moment(hull, loading, 0.8, math.pi / 2))
    errors = []
    for size in (1.5, 0.75, 0.375):
        body = _body(cpt, bem_mesh(hull, loading, sinkage=4.0, trim=0.0, panel_size=size), False, "box")
        pb = cpt.DiffractionProblem(body=body, wave_direction=-math.pi / 2, omega=0.8, rho=RHO, g=GRAVITY)
        errors.append(abs(np.conj(cpt.bem.airy_waves.froude_krylov_force(pb)["Roll"]) - exact) / abs(exact))
    assert errors[0] < 0.21  # measured: 0.204, 0.0510, 0.0132 (GM 0.5 m: BM 3 m against KG − KB 2.5 m)
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.05)
    assert errors[1] / errors[2] == pytest.approx(4.0, rel=0.05)


def test_frequency_domain_roll_against_the_constant_coefficient_roll(box, box_bem):
    """The roll RAO of the frequency-domain solution, φ/a = F / (C44 − ω²(I_dry + A44(ω)) + iω(B_v + B44(ω))), against
    jaxroll's roll equation with its constant coefficients — I44 = I_dry + A44(ω0) from the roll period, the damping
    b1 I44 = B_v + B44(ω0) — through `linear_roll_variance`'s path: equal at ω0, and E[φ²] in a beam sea close."""
    pytest.importorskip("capytaine")
    from jaxroll import ITTC, RollProblem
    from jaxroll.ship import (
        bem_roll_period,
        bem_wave_moment,
        c11_representative,
        hydrostatic_particulars,
        roll_inertia,
    )
    from jaxroll.theory import linear_roll_variance

    hull, loading = box
    gm = float(hydrostatic_particulars(hull, loading).gm)
    mass = float(loading.displacement)
    c = box_bem
    # the roll period of a dry gyradius 0.35 B with the BEM's A44 at it (as `jaxroll hydrostatics --roll-gyradius`)
    dry = mass * (0.35 * 12.0) ** 2
    period = bem_roll_period(c, mass, gm, 0.35 * 12.0)
    ship = eqx.tree_at(lambda s: (s.displacement, s.gm0, s.roll_period, s.damping), c11_representative(),
                       tuple(jnp.asarray(x) for x in (mass, gm, period, [0.02, 0.0, 0.0])))  # fmt: skip
    ship = eqx.tree_at(lambda s: s.wave_moment, ship, bem_wave_moment(c, ship), is_leaf=lambda x: x is None)
    i44, w0 = float(roll_inertia(ship)), 2 * math.pi / period
    assert i44 == pytest.approx(dry + float(np.interp(w0, c.omega, c.added_inertia)), rel=1e-9)
    sea = ITTC(0.5, 6.0)
    problem = RollProblem.from_sea(ship, sea, heading=math.pi / 2, dt=0.1, phi0=0.0)
    jaxroll_var = float(linear_roll_variance(problem))
    # frequency domain: the BEM's A44(ω), B44(ω), F(ω) linear between its frequencies, as the table
    w = np.linspace(1e-3, float(c.omega[-1]), 20001)
    a44, b44 = np.interp(w, c.omega, c.added_inertia), np.interp(w, c.omega, c.radiation_damping)
    f = np.interp(w, c.omega, c.excitation[2].real) + 1j * np.interp(w, c.omega, c.excitation[2].imag)
    b_visc = 0.02 * i44 - float(np.interp(w0, c.omega, c.radiation_damping))
    rao = f / (mass * GRAVITY * gm - w**2 * (dry + a44) + 1j * w * (b_visc + b44))
    const = f / (i44 * (w0**2 - w**2) + 1j * w * 0.02 * i44)
    k0 = np.argmin(np.abs(w - w0))
    assert abs(rao[k0] / const[k0] - 1) < 2e-3
    s = np.asarray(sea(w))
    freq_var = float(np.trapezoid(np.abs(rao) ** 2 * s, w))
    const_var = float(np.trapezoid(np.abs(const) ** 2 * s, w))
    assert const_var == pytest.approx(jaxroll_var, rel=2e-3)  # the same constant-coefficient roll
    # measured: 5.3349e-05 rad² both, 5.1838e-05 rad² with A44(ω), B44(ω) (−2.8 %), Tφ 14.31 s
    assert freq_var == pytest.approx(jaxroll_var, rel=0.05)


def test_cli_hydrostatics_wave_moment_bem(box, tmp_path, capsys):
    """`jaxroll hydrostatics HULL --wave-moment bem --roll-gyradius K` on a box hull file: ship.toml carries F, A44,
    B44 (source "bem"), the roll period is that of Δ k_xx² + A44(ω0); a panel size too coarse is refused (exit 2)."""
    pytest.importorskip("capytaine")
    from jaxroll._cli import main
    from jaxroll.io import hull_to_toml, load_ship
    from jaxroll.ship import roll_inertia

    hull, loading = box
    path = tmp_path / "box.toml"
    path.write_text(hull_to_toml(hull))
    base = ["hydrostatics", str(path), "--draught", "4", "--kg", "4.5", "--zeta-max", "2", "--roll-gyradius", "4.2", "--wave-moment",
            "bem", "--bem-frequencies", "3", "--bem-omega-max", "1.2", "--bem-headings", "3"]  # fmt: skip
    assert main([*base, "--bem-panel-size", "3", "--out", str(tmp_path / "hs")]) == 0
    out = capsys.readouterr().out
    assert "BEM (capytaine, 176 panels ≤ 3 m, 3 frequencies × 3 headings)" in out
    ship = load_ship(tmp_path / "hs" / "ship.toml")
    table = ship.wave_moment
    assert table.source == "bem" and np.asarray(table.omega).tolist() == pytest.approx([0.0, 0.4, 0.8, 1.2])
    mass = float(ship.displacement)
    a0 = float(table.radiation(float(ship.omega0))[0])
    assert float(roll_inertia(ship)) == pytest.approx(mass * 4.2**2 + a0, rel=1e-9)
    record = json.loads((tmp_path / "hs" / "hydrostatics.json").read_text())["bem"]
    assert record["added_inertia_at_roll_frequency_kg_m2"] == pytest.approx(a0, rel=1e-9)
    assert record["dry_gyradius_m"] == pytest.approx(4.2, rel=1e-9)
    import xarray as xr

    with xr.open_dataset(
        tmp_path / "hs" / "hydrostatics.nc"
    ) as ds:  # the labelled twin: the table and the record
        assert ds["ship_wave_moment_added_inertia_kg_m2"].attrs["units"] == "kg m2"
        assert ds["ship_wave_moment_moment_real_N"].dims == (
            "wave_moment_heading_rad",
            "wave_moment_omega_rad_s",
        )
        assert float(ds["bem_added_inertia_at_roll_frequency_kg_m2"]) == pytest.approx(a0, rel=1e-9)
    assert main([*base, "--bem-panel-size", "9", "--out", str(tmp_path / "coarse")]) == 2
    err = capsys.readouterr().err
    assert (
        "box: panels up to 7.5 m long are too coarse for the shortest wave asked" in err
        and "λ/6 = 7.13 m" in err
    )


def test_the_lid_changes_nothing_below_the_irregular_frequencies(box):
    """`lid=True` (capytaine's lid just below the waterplane) removes the irregular frequencies; below the first one
    (≈ 1.8 rad/s for this box, capytaine's estimate) the answers are the same within the discretisation."""
    pytest.importorskip("capytaine")
    from jaxroll.ship import bem_roll_coefficients

    plain = bem_roll_coefficients(*box, omega=[0.8], headings=[math.pi / 2], panel_size=3.0)
    lid = bem_roll_coefficients(*box, omega=[0.8], headings=[math.pi / 2], panel_size=3.0, lid=True)
    assert lid.lid and lid.n_panels > plain.n_panels and lid.irregular_frequency > 10  # measured 15.7 rad/s
    assert 1.5 < plain.irregular_frequency < 2.2
    assert lid.added_inertia[1] == pytest.approx(plain.added_inertia[1], rel=0.02)
    assert lid.radiation_damping[1] == pytest.approx(plain.radiation_damping[1], rel=0.02)
    assert abs(lid.excitation[0, 1] - plain.excitation[0, 1]) < 0.02 * abs(plain.excitation[0, 1])


def test_a_mesh_hull_runs_on_its_own_triangles(box, box_bem):
    """A hull read from a mesh keeps its own triangles (here the box's quadrilaterals split into triangles, both
    halves): the same A44 and F as the quadrilateral panels within the discretisation. B44 of the roll (a small
    difference of large pressures for a box whose G is near the waterline) converges slowly: at 3 m panels the two
    meshes differ by 13–36 %, at 1.5 m by 4–6 % (measured at ω = 0.8, 1.2 rad/s: quadrilaterals 4.88e5, 2.82e6,
    triangles 4.58e5, 2.72e6 N m s; 3 m quadrilaterals 7.90e5, 3.69e6)."""
    pytest.importorskip("capytaine")
    from jaxroll.ship import bem_roll_coefficients

    hull, loading = box
    meshed = eqx.tree_at(
        lambda h: h.surface, hull, hull_surface(_triangles(hull, 3.0)), is_leaf=lambda x: x is None
    )
    c = bem_roll_coefficients(meshed, loading, omega=OMEGA, headings=HEADINGS)
    assert c.n_panels == 352 and c.panel_size == pytest.approx(math.hypot(3.0, 3.0))
    np.testing.assert_allclose(c.added_inertia, box_bem.added_inertia, rtol=0.03)
    assert np.max(np.abs(c.excitation - box_bem.excitation)) < 0.05 * np.max(np.abs(box_bem.excitation))
    fine = {}
    for name, h, size in (("quads", hull, 1.5), ("triangles", meshed, None)):
        if size is None:
            h = eqx.tree_at(
                lambda x: x.surface, hull, hull_surface(_triangles(hull, 1.5)), is_leaf=lambda x: x is None
            )
        fine[name] = bem_roll_coefficients(
            h, loading, omega=[0.8, 1.2], headings=[math.pi / 2], panel_size=size
        )
    np.testing.assert_allclose(
        fine["triangles"].radiation_damping, fine["quads"].radiation_damping, rtol=0.08
    )
