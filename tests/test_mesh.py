"""Hulls from STL (binary, ascii) and offsets CSV: analytic hydrostatics, equivalence, scale, axes, topology.

Analytic references (exact for these polygonal hulls, docs/hydrostatics.md): a box L×B at draught d has
GM0 = d/2 + B²/(12 d) − KG and ΔGM = ζ²/(4 d) with a crest or a trough of amplitude ζ amidships (λ = L); a
prism with V sections (half-breadth y = m z) has KM = (2/3)(1 + m²) d, and on the λ = L wave of amplitude a (no
trim by symmetry) sinkage s = √(d² − a²/2) and KM(a) = (2/3)(1 + m²)(s³ + (3/2) s a²)/d².

Every hull here has 21 stations × 11 waterlines and the same name, so the hydrostatics compile once for all the
tests of this file and of tests/test_sgisc.py (a new hull shape or name costs ~20 s of compilation on CPU).
"""

import math

import numpy as np
import pytest

import jaxroll as jxr
from jaxroll import io

L, B, D, d, KG = 100.0, 20.0, 10.0, 5.0, 6.0
N_ST, N_WL = 21, 11
ZETA = np.array([-1.5, 1.5])  # crest, trough amidships: one shape for every metacentric_height call


def plain(h):
    """The hull with a fixed name/provenance (static fields: part of the compilation cache key)."""
    return jxr.Hull(
        stations=h.stations, waterlines=h.waterlines, half_breadths=h.half_breadths, lpp=h.lpp, depth=h.depth,
        name="test", provenance="",
    )  # fmt: skip


def box_triangles(length=L):
    x = np.linspace(0.0, length, 11)
    z = np.linspace(0.0, D, 3)
    return io.triangulate_offsets(x, z, np.full((11, 3), B / 2))


def read(path, **kw):
    kw.setdefault("lpp", L)
    kw.setdefault("stations", N_ST)
    kw.setdefault("waterlines", N_WL)
    return io.read_stl_hull(path, **kw)


@pytest.mark.parametrize("binary", [True, False])
def test_box_stl_gm_and_delta_gm(tmp_path, binary):
    path = io.write_stl(tmp_path / "box.stl", box_triangles(), binary=binary)
    hull = plain(read(path))
    np.testing.assert_allclose(hull.half_breadths, B / 2, rtol=0, atol=1e-9)
    ld = jxr.loading_condition(hull, kg=KG, draught=d)
    gm0 = float(jxr.hydrostatic_particulars(hull, ld).gm)
    assert gm0 == pytest.approx(d / 2 + B**2 / (12 * d) - KG, abs=1e-9)
    dgm = np.asarray(jxr.metacentric_height(hull, ld, zeta_mid=ZETA)) - gm0
    np.testing.assert_allclose(dgm, 1.5**2 / (4 * d), rtol=0, atol=1e-9)


def test_v_prism_stl_gm_and_delta_gm(tmp_path):
    m, a = 1.0, 1.5
    x = np.linspace(0.0, L, N_ST)
    y = np.tile([0.0, m * D], (N_ST, 1))
    path = io.write_stl(tmp_path / "v.stl", io.triangulate_offsets(x, np.array([0.0, D]), y))
    hull = plain(read(path, stations=x, waterlines=np.linspace(0, D, N_WL)))
    ld = jxr.loading_condition(hull, kg=KG, draught=d)
    gm0 = float(jxr.hydrostatic_particulars(hull, ld).gm)
    assert gm0 == pytest.approx(2 / 3 * (1 + m**2) * d - KG, abs=1e-9)
    s = math.sqrt(d**2 - a**2 / 2)
    km_a = 2 / 3 * (1 + m**2) * (s**3 + 1.5 * s * a**2) / d**2
    gm_waves = np.asarray(jxr.metacentric_height(hull, ld, zeta_mid=ZETA))
    np.testing.assert_allclose(gm_waves, km_a - KG, rtol=0, atol=1e-9)  # crest and trough alike


def wigley_offsets():
    x = np.linspace(0.0, L, N_ST)
    z = np.linspace(0.0, 6.0, N_WL)
    xi = 2 * (x - L / 2) / L
    y = B / 2 * (1 - xi[:, None] ** 2) * (1 - ((6.0 - z[None, :]) / 6.0) ** 2)
    return x, z, np.clip(y, 0, None)


def test_stl_and_offsets_csv_give_the_same_hydrostatics(tmp_path):
    x, z, y = wigley_offsets()
    tri = io.triangulate_offsets(x, z, y, depth=D)
    stl = io.write_stl(tmp_path / "w.stl", tri, binary=False)  # ascii: 12 digits
    csv = io.write_offsets_csv(
        tmp_path / "w.csv", x, [np.stack([row, z], axis=1) for row in y], lpp=L, depth=D
    )
    h_stl = io.read_stl_hull(stl, lpp=L, stations=x, waterlines=z)
    h_csv = io.read_offsets_csv(csv)
    np.testing.assert_allclose(h_stl.half_breadths, h_csv.half_breadths, rtol=0, atol=1e-9)
    assert float(h_stl.depth) == pytest.approx(D) and float(h_csv.depth) == pytest.approx(D)
    # read_hull dispatches on the suffix
    np.testing.assert_array_equal(io.read_hull(csv)[0].half_breadths, h_csv.half_breadths)
    out = []
    for h in (plain(h_stl), plain(h_csv)):
        ld = jxr.loading_condition(h, kg=4.0, draught=4.0)
        p = jxr.hydrostatic_particulars(h, ld)
        row = [float(p.volume), float(p.kb), float(p.bm), float(p.gm), float(p.lcb)]
        out.append(row + list(np.asarray(jxr.metacentric_height(h, ld, zeta_mid=ZETA))))
    np.testing.assert_allclose(out[0], out[1], rtol=1e-9)


def test_model_scale_and_unit_errors(tmp_path):
    small = io.write_stl(tmp_path / "model.stl", box_triangles(length=2.62) / np.array([1.0, 100.0, 100.0]))
    with pytest.raises(io.ModelScaleError, match=r"length 2\.62 m .*MODEL-SCALE file in metres.*hectometres"):
        io.read_stl_hull(small, lpp=2.62)
    hull = io.read_stl_hull(small, lpp=262.0, scale=100, stations=11, waterlines=3)
    assert float(hull.stations[-1]) == pytest.approx(262.0)
    assert float(hull.depth) == pytest.approx(D)
    big = io.write_stl(tmp_path / "mm.stl", box_triangles() * 1000.0)
    with pytest.raises(io.ModelScaleError, match="units='mm'"):
        io.read_stl_hull(big, lpp=100_000.0)
    hull = io.read_stl_hull(big, lpp=L, units="mm", stations=11, waterlines=3)
    assert float(hull.depth) == pytest.approx(D)
    with pytest.warns(
        UserWarning, match="no `lpp` given"
    ):  # L defaults to the length overall, with a warning
        assert float(io.read_stl_hull(big, units="mm", stations=11, waterlines=3).lpp) == pytest.approx(L)


def test_open_and_non_manifold_meshes_are_errors(tmp_path):
    tri = box_triangles()
    side = np.where(np.all(tri[:, :, 1] > B / 2 - 1e-9, axis=1))[0][:2]  # starboard side: not a centre plane
    with pytest.raises(io.MeshError, match="OPEN"):
        read(io.write_stl(tmp_path / "open.stl", np.delete(tri, side, axis=0)))
    with pytest.raises(io.MeshError, match="not 2-manifold"):
        read(io.write_stl(tmp_path / "nm.stl", np.concatenate([tri, tri[:1]])))
    (tmp_path / "bad.stl").write_text("this is not an STL file")
    with pytest.raises(io.MeshError, match="neither a binary STL"):
        read(tmp_path / "bad.stl")


def cuboid(x0, x1, y0, y1, z0, z1):
    v = np.array([[x, y, z] for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)], float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return np.array(
        [[v[a], v[b], v[c]] for q in quads for a, b, c in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
    )


def test_axes_convention_and_half_hull(tmp_path):
    tri = box_triangles()
    # a file with forward = −z and up = +y (x_body = −z_file, z_body = y_file)
    rot = np.stack([tri[..., 1], tri[..., 2], -tri[..., 0]], axis=-1)
    path = io.write_stl(tmp_path / "r.stl", rot)
    h = read(path, forward="-z", up="+y", stations=11, waterlines=3)
    np.testing.assert_allclose(h.half_breadths, B / 2, atol=1e-9)
    assert float(h.depth) == pytest.approx(D)
    with pytest.raises(io.MeshError, match="a ship is longest along x"):  # read with the default axes
        read(path)
    # a half-hull open along its centre plane is mirrored
    half = cuboid(0, L, 0, B / 2, 0, D)
    half = half[~np.all(np.abs(half[:, :, 1]) < 1e-12, axis=1)]  # remove the centre-plane face
    path = io.write_stl(tmp_path / "half.stl", half)
    with pytest.raises(io.MeshError, match=r"OPEN along the whole of its flat side y = 0 m .* HALF hull .*--half-hull"):
        read(path, stations=11, waterlines=3)  # refused without the flag, with the reason
    hh = read(path, stations=11, waterlines=3, half_hull=True)
    np.testing.assert_allclose(hh.half_breadths, B / 2, atol=1e-9)
    assert "half-hull, mirrored" in hh.provenance
    with pytest.raises(io.MeshError, match=r"half_hull=True \(--half-hull\) but the mesh is closed"):
        read(io.write_stl(tmp_path / "whole.stl", tri), half_hull=True)


def test_hydrostatics_cli_reads_stl_and_refuses_an_open_one_first(tmp_path, capsys, monkeypatch):
    from jaxroll._cli import main

    monkeypatch.setenv("JAXROLL_CACHE_DIR", "")
    tri = box_triangles()
    side = np.where(np.all(tri[:, :, 1] > B / 2 - 1e-9, axis=1))[0][:2]
    path = io.write_stl(tmp_path / "open.stl", np.delete(tri, side, axis=0))
    argv = ["hydrostatics", str(path), "--lpp", "100", "--kg", "6", "--draught", "5", "--roll-period", "10"]
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    assert "the mesh is OPEN" in capsys.readouterr().err and not (tmp_path / "out").exists()
    assert main(["hydrostatics", "c11", "--scale", "100", "--out", str(tmp_path / "out")]) == 2
    assert "apply to STL, GDF and CSV hull files only" in capsys.readouterr().err


# ----------------------------------------------------------------------------------------------------------------
# WAMIT GDF (low-order panels): the same triangles, the same path, the same hydrostatics as the STL
# ----------------------------------------------------------------------------------------------------------------

# The box L × B × D = 100 × 20 × 10 m in WAMIT's frame: origin amidships on the waterline (draught d = 5 m), z up,
# one quadrant (x > 0, y > 0) given and ISX = ISY = 1. Written by hand, with the format's liberties: comments after
# the header numbers, a panel spread over two lines, commas, a Fortran D exponent, triangles (a repeated vertex).
# Vertices run counter-clockwise seen from the fluid (WAMIT's rule: normals out of the body).
BOX_GDF = """box barge quadrant, x > 0 and y > 0
1.0  9.80665        ULEN GRAV
1 1                 ISX ISY
5                   NPAN
50 0 -5   50 10 -5   50 10 5   50 0 5
0 10 -5   0 10 5
50 10 5   50 10 -5
0, 0, -5, 0, 10, -5, 0.5D+02, 10, -5, 50, 0, -5
0 0 5   50 10 5   0 10 5   0 10 5
0 0 5   50 0 5   50 10 5   0 0 5
"""


def write_box_gdf(tmp_path, text=BOX_GDF, name="box.gdf"):
    path = tmp_path / name
    path.write_text(text)
    return path


def box_quadrant_panels():
    """The 5 panels (5, 4, 3) of BOX_GDF."""
    data = " ".join(BOX_GDF.splitlines()[4:]).replace(",", " ").replace("D", "E")
    return np.array(data.split(), dtype=float).reshape(5, 4, 3)


def test_gdf_box_has_the_stl_box_hydrostatics(tmp_path):
    path = write_box_gdf(tmp_path)
    tri = io.read_gdf(path)
    # 3 quads → 6 triangles, the deck's two triangular panels → 1 each (degenerate halves dropped); × 4 by ISX, ISY
    assert tri.shape == (4 * (3 * 2 + 1 + 1), 3, 3)
    pts = tri.reshape(-1, 3)
    np.testing.assert_array_equal(pts.min(axis=0), [-50.0, -10.0, -5.0])
    np.testing.assert_array_equal(pts.max(axis=0), [50.0, 10.0, 5.0])
    topo = io._mesh.mesh_topology(tri)
    assert topo["boundary_edges"].shape[0] == 0 and topo["nonmanifold_edges"].shape[0] == 0  # closed by mirrors
    assert topo["volume"] == pytest.approx(L * B * D, rel=1e-12)  # > 0: the mirrors keep the normals outward

    hull, loading = io.read_hull(path, lpp=L, stations=N_ST, waterlines=N_WL)
    assert loading == {"draught_m": pytest.approx(d)}  # WAMIT's z = 0: the file's waterline, 5 m above the keel
    assert "WAMIT GDF" in hull.provenance and "ISX 1, ISY 1" in hull.provenance
    stl = read(io.write_stl(tmp_path / "box.stl", box_triangles()))
    for a, b in ((hull.stations, stl.stations), (hull.waterlines, stl.waterlines), (hull.half_breadths, stl.half_breadths)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
    out = []
    for h in (plain(hull), plain(stl)):
        ld = jxr.loading_condition(h, kg=KG, draught=loading["draught_m"])
        p = jxr.hydrostatic_particulars(h, ld)
        out.append([float(p.volume), float(p.gm), *np.asarray(jxr.metacentric_height(h, ld, zeta_mid=ZETA))])
    np.testing.assert_allclose(out[0], out[1], rtol=0, atol=1e-9)
    assert out[0][0] == pytest.approx(L * B * d, rel=1e-12)
    assert out[0][1] == pytest.approx(d / 2 + B**2 / (12 * d) - KG, abs=1e-9)  # GM0 = 3.1667 m


@pytest.mark.parametrize("isx, isy", [(0, 0), (1, 0), (0, 1)])
def test_gdf_symmetry_flags_expand_to_the_same_body(tmp_path, isx, isy):
    full = io._gdf._expand_symmetry(box_quadrant_panels(), np.arange(5), dict(isx=1, isy=1), "q")  # 20 panels
    given = full[np.all(full[..., 0] >= 0, axis=1) | (not isx)]  # the x > 0 half where ISX = 1
    given = given[np.all(given[..., 1] >= 0, axis=1) | (not isy)]
    assert len(given) == 20 // 2 ** (isx + isy)
    path = io.write_gdf(tmp_path / f"b{isx}{isy}.gdf", given, isx=isx, isy=isy)
    tri = io.read_gdf(path)
    assert tri.shape[0] == io.read_gdf(write_box_gdf(tmp_path)).shape[0] == 32
    assert io._mesh.mesh_topology(tri)["volume"] == pytest.approx(L * B * D, rel=1e-12)
    h = io.read_gdf_hull(path, lpp=L, stations=N_ST, waterlines=N_WL)
    np.testing.assert_allclose(h.half_breadths, B / 2, rtol=0, atol=1e-9)
    assert float(h.depth) == pytest.approx(D)


def test_gdf_units_come_from_grav_and_ulen_scales_nothing(tmp_path):
    ref = io.read_gdf_hull(write_box_gdf(tmp_path), lpp=L, stations=N_ST, waterlines=N_WL)
    panels = box_quadrant_panels()
    # feet: GRAV = 32.174 ft/s² and the coordinates in feet; ULEN = 328 (WAMIT's reference length) changes nothing
    ft = io.write_gdf(tmp_path / "ft.gdf", panels / 0.3048, ulen=328.0, grav=32.174, isx=1, isy=1)
    h = io.read_gdf_hull(ft, lpp=L, stations=N_ST, waterlines=N_WL)
    for a, b in ((h.stations, ref.stations), (h.waterlines, ref.waterlines), (h.half_breadths, ref.half_breadths)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
    assert "GRAV 32.174 (unit ft)" in h.provenance
    # millimetres by GRAV = 9806.65 mm/s²; read_hull's default units="m" defers to GRAV
    mm = io.write_gdf(tmp_path / "mm.gdf", panels * 1000, grav=9806.65, isx=1, isy=1)
    h, ld = io.read_hull(mm, lpp=L, stations=N_ST, waterlines=N_WL)
    np.testing.assert_allclose(h.half_breadths, ref.half_breadths, rtol=0, atol=1e-9)
    assert ld["draught_m"] == pytest.approx(d)
    # a GRAV that is no unit's g: metres, with a warning; units= overrides GRAV, with a warning
    odd = io.write_gdf(tmp_path / "odd.gdf", panels, grav=1.0, isx=1, isy=1)
    with pytest.warns(UserWarning, match=r"GRAV = 1 on line 2 is not the acceleration of gravity"):
        h = io.read_gdf_hull(odd, lpp=L, stations=N_ST, waterlines=N_WL)
    np.testing.assert_allclose(h.half_breadths, ref.half_breadths, rtol=0, atol=1e-9)
    wrong = io.write_gdf(tmp_path / "wrong.gdf", panels * 1000, grav=9.81, isx=1, isy=1)  # mm with g in m/s²
    with pytest.raises(io.ModelScaleError, match="units='mm'"):  # the same scale check as an STL
        io.read_gdf_hull(wrong, lpp=L)
    with pytest.warns(UserWarning, match=r"units='mm' overrides the unit of GRAV = 9.81 on line 2 \(m\)"):
        h = io.read_gdf_hull(wrong, units="mm", lpp=L, stations=N_ST, waterlines=N_WL)
    np.testing.assert_allclose(h.half_breadths, ref.half_breadths, rtol=0, atol=1e-9)


def _lines(text, **repl):
    out = text.splitlines()
    for k, v in repl.items():
        out[int(k[1:]) - 1] = v
    return "\n".join(out) + "\n"


MALFORMED_GDF = {
    "header": ("box\n1.0 9.80665\n", r"box\.gdf: a WAMIT GDF starts with 4 header lines .* has 2 line"),
    "ulen_grav": (_lines(BOX_GDF, l2="ULEN GRAV"), r"box\.gdf:2: expected `ULEN GRAV`"),
    "isx_isy": (_lines(BOX_GDF, l3="2 1"), r"box\.gdf:3: expected `ISX ISY` \(each 0, or 1"),
    "npan": (_lines(BOX_GDF, l4="five"), r"box\.gdf:4: expected `NPAN`"),
    "higher_order": (_lines(BOX_GDF, l4="5 1"), r"box\.gdf:4: IGDEF = 1 .* higher-order WAMIT geometry"),
    "too_few_panels": (_lines(BOX_GDF, l4="6"), r"box\.gdf:10: the file ends after 60 numbers .* NPAN = 6 .*TRUNCATED in panel 6"),
    "too_many_panels": (_lines(BOX_GDF, l4="4"), r"box\.gdf:10: 12 number\(s\) after the NPAN = 4 panels .*set NPAN = 5"),
    "non_numeric": (_lines(BOX_GDF, l6="0 10 -5   0 ten 5"), r"box\.gdf:6: 'ten' is not a number \(panel 2 of NPAN = 5, vertex 2\)"),
    "truncated": ("\n".join(BOX_GDF.splitlines()[:7]) + "\n50 0", r"box\.gdf:8: the file ends after 26 numbers .*TRUNCATED in panel 3"),
    "both_sides": (_lines(BOX_GDF, l5="50 0 -5   50 -10 -5   50 10 5   50 0 5"), r"box\.gdf:3: ISY = 1 says y = 0 is a plane of symmetry .* both sides \(y from -10 to 10\)"),
    "in_the_plane": (_lines(BOX_GDF, l10="0 0 5   50 0 5   50 0 -5   0 0 -5"), r"box\.gdf:10: panel 5 lies in the plane of symmetry y = 0 \(ISY = 1\)"),
}  # fmt: skip


@pytest.mark.parametrize("case", MALFORMED_GDF)
def test_malformed_gdf_names_the_line(tmp_path, case):
    text, match = MALFORMED_GDF[case]
    with pytest.raises(ValueError, match=match) as e:
        io.read_gdf(write_box_gdf(tmp_path, text))
    assert isinstance(e.value, io.MeshError)


def test_wetted_surface_meshes_are_refused(tmp_path):
    # the box's wetted part only (z <= 0), as a GDF for WAMIT: open at the waterplane
    wet = box_quadrant_panels()[:3].copy()
    wet[..., 2] = np.minimum(wet[..., 2], 0.0)
    path = io.write_gdf(tmp_path / "wet.gdf", wet, isx=1, isy=1)
    with pytest.raises(io.MeshError, match=r"nothing of the body is above the waterplane z = 0 .* WETTED surface"):
        io.read_gdf_hull(path, lpp=L)
    lid = io.write_gdf(tmp_path / "lid.gdf", np.concatenate([wet, box_quadrant_panels()[3:4] * [1, 1, 0]]), isx=1, isy=1)
    with pytest.raises(io.MeshError, match="WETTED"):  # closed by a lid on z = 0: still nothing above the waterline
        io.read_gdf_hull(lid, lpp=L)
    # the same surface from an STL (no WAMIT frame): the open-mesh check names the open top
    tri = box_triangles()
    deck = np.all(np.abs(tri[:, :, 2] - D) < 1e-9, axis=1)
    with pytest.raises(io.MeshError, match=r"the mesh is OPEN at its top: .* WETTED surface"):
        read(io.write_stl(tmp_path / "wet.stl", tri[~deck]))


def test_hydrostatics_cli_reads_gdf_options_and_refuses_a_wetted_one_first(tmp_path, capsys, monkeypatch):
    from jaxroll._cli import main

    monkeypatch.setenv("JAXROLL_CACHE_DIR", "")
    wet = box_quadrant_panels()[:3].copy()
    wet[..., 2] = np.minimum(wet[..., 2], 0.0)
    path = io.write_gdf(tmp_path / "wet.gdf", wet, isx=1, isy=1)
    argv = ["hydrostatics", str(path), "--lpp", "100", "--units", "m", "--kg", "6", "--roll-period", "10"]
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2  # the mesh options are accepted for a .gdf
    assert "only the WETTED surface" in capsys.readouterr().err and not (tmp_path / "out").exists()


# ----------------------------------------------------------------------------------------------------------------
# An independent reader: numpy-stl (a dev extra) reads the same files to the same triangles
# ----------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("binary", [True, False])
def test_stl_reader_agrees_with_numpy_stl(tmp_path, binary):
    stl_mesh = pytest.importorskip("stl.mesh")
    x, z, y = wigley_offsets()
    for name, tri in (("box", box_triangles()), ("wigley", io.triangulate_offsets(x, z, y, depth=D))):
        path = io.write_stl(tmp_path / f"{name}.stl", tri, binary=binary)
        theirs = stl_mesh.Mesh.from_file(str(path))
        ours = io.read_stl(path)
        assert ours.shape == theirs.vectors.shape == tri.shape
        # both hold the file's float32 (binary) or parse its 12-digit decimals (ascii; numpy-stl into float32)
        np.testing.assert_array_equal(ours.astype(np.float32), theirs.vectors)
        if binary:
            np.testing.assert_array_equal(ours, theirs.vectors.astype(float))
        volume, cog, _ = theirs.get_mass_properties()
        assert float(volume) == pytest.approx(abs(io._mesh.mesh_topology(ours)["volume"]), rel=1e-6)
    # the box's numbers: numpy-stl's volume and centroid against jaxroll's sliced hull at the draught d
    v_box, cog_box, _ = stl_mesh.Mesh.from_file(str(tmp_path / "box.stl")).get_mass_properties()
    assert float(v_box) == pytest.approx(L * B * D, rel=1e-6)
    np.testing.assert_allclose(cog_box, [L / 2, 0.0, D / 2], atol=1e-4)
    h = plain(read(tmp_path / "box.stl"))
    p = jxr.hydrostatic_particulars(h, jxr.loading_condition(h, kg=KG, draught=d))
    assert float(p.volume) == pytest.approx(float(v_box) * d / D, rel=1e-6)  # a box: V(d) = V d / D
    assert float(p.waterplane_area) == pytest.approx(float(v_box) / D, rel=1e-6)  # A_WP = V / D
