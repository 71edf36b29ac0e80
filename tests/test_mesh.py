"""Hulls from STL (binary, ascii) and offsets CSV: analytic hydrostatics, equivalence, scale, axes, topology.

Analytic references (exact for these polygonal hulls, docs/hydrostatics.md): a box L×B at draught d has
GM0 = d/2 + B²/(12 d) − KG and ΔGM = ζ²/(4 d) with a crest or a trough of amplitude ζ amidships (λ = L); a
prism with V sections (half-breadth y = m z) has KM = (2/3)(1 + m²) d, and on the λ = L wave of amplitude a (no
trim by symmetry) sinkage s = √(d² − a²/2) and KM(a) = (2/3)(1 + m²)(s³ + (3/2) s a²)/d².

Every hull here has 21 stations × 11 waterlines and the same name, so the hydrostatics compile once for all the
tests of this file and of tests/test_sgisc.py (a new hull shape or name costs ~20 s of compilation on CPU).
"""

import math
import re
import warnings

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
    with pytest.raises(
        io.MeshError, match=r"OPEN along the whole of its flat side y = 0 m .* HALF hull .*--half-hull"
    ):
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
    assert (
        topo["boundary_edges"].shape[0] == 0 and topo["nonmanifold_edges"].shape[0] == 0
    )  # closed by mirrors
    assert topo["volume"] == pytest.approx(L * B * D, rel=1e-12)  # > 0: the mirrors keep the normals outward

    hull, loading = io.read_hull(path, lpp=L, stations=N_ST, waterlines=N_WL)
    assert loading == {
        "draught_m": pytest.approx(d)
    }  # WAMIT's z = 0: the file's waterline, 5 m above the keel
    assert "WAMIT GDF" in hull.provenance and "ISX 1, ISY 1" in hull.provenance
    stl = read(io.write_stl(tmp_path / "box.stl", box_triangles()))
    for a, b in (
        (hull.stations, stl.stations),
        (hull.waterlines, stl.waterlines),
        (hull.half_breadths, stl.half_breadths),
    ):
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
    for a, b in (
        (h.stations, ref.stations),
        (h.waterlines, ref.waterlines),
        (h.half_breadths, ref.half_breadths),
    ):
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
    with pytest.raises(
        io.MeshError, match=r"nothing of the body is above the waterplane z = 0 .* WETTED surface"
    ):
        io.read_gdf_hull(path, lpp=L)
    lid = io.write_gdf(
        tmp_path / "lid.gdf", np.concatenate([wet, box_quadrant_panels()[3:4] * [1, 1, 0]]), isx=1, isy=1
    )
    with pytest.raises(
        io.MeshError, match="WETTED"
    ):  # closed by a lid on z = 0: still nothing above the waterline
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


# ----------------------------------------------------------------------------------------------------------------
# Issue 36 / 37: symmetry, orientation, the datum, other formats, bad input (meshes generated in tests/hull_meshes.py)
# ----------------------------------------------------------------------------------------------------------------


def test_asymmetric_and_skewed_hulls_are_refused_with_the_measured_asymmetry(tmp_path):
    import hull_meshes as hm

    # issue 37 item 1: port side at y = −8 m, starboard flaring from 8 to 10 m (hand: TCB = −0.49 m of the middle)
    path = io.write_stl(tmp_path / "asym.stl", hm.asymmetric_prism())
    with pytest.raises(io.MeshError, match=r"not port–starboard symmetric: .* lies 0\.4[89]\d* m to one side .* "
                       r"differ by up to 2 m \(starboard 7 m, port 9 m"):  # fmt: skip
        read(path, x_ap=0.0)
    skew = box_triangles().copy()
    skew[..., 1] += 0.05 * skew[..., 0]  # sections shifted sideways along the length: TCB 0, still asymmetric
    with pytest.raises(io.MeshError, match=r"not port–starboard symmetric: .* lies 2\.5 m to one side"):
        read(io.write_stl(tmp_path / "skew.stl", skew))


@pytest.mark.parametrize(
    "dims", [(120.0, 20.0, 12.0), (100.0, 10.0, 8.0), (200.0, 40.0, 20.0), (262.0, 40.0, 24.45)]
)
def test_a_twelve_triangle_box_is_symmetric_where_the_sampling_grid_meets_its_diagonals(tmp_path, dims):
    """Issue 45 item 5: a box of 12 triangles (one diagonal per face, the simplest CAD export) whose diagonals pass
    through station × waterline points of the symmetry check's grid (120 × 12: z = x/10 meets x = 12, z = 1.2) was
    refused as asymmetric ("port 0 m"): the two triangles' cut points differ in the last bits and the point fell
    between them. A point on an edge or vertex counts."""
    import hull_meshes as hm

    tri = hm.cad_box(*dims)
    assert tri.shape == (12, 3, 3)
    sym = io._mesh_geometry.symmetry_defect(tri)
    assert sym["max_difference"] == 0.0 and sym["section_offset"] == 0.0
    # every station × waterline of the grid has the box's half-breadth on both sides (edges and vertices counted)
    lo, hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
    st, wl = np.linspace(lo[0], hi[0], 41), np.linspace(lo[2], hi[2], 41)
    for side in (1, -1):
        np.testing.assert_allclose(
            io._mesh_geometry.slice_offsets(tri, st, wl, side=side), dims[1] / 2, rtol=1e-12
        )
    hull = io.read_stl_hull(io.write_stl(tmp_path / "box.stl", tri), lpp=dims[0], x_ap=0.0)
    assert float(hull.lpp) == pytest.approx(dims[0])


def test_inconsistent_normals_refused_then_fixed_and_inverted_meshes_accepted(tmp_path):
    tri = box_triangles()
    bad = tri.copy()
    bad[:5] = bad[:5, ::-1]  # five triangles reversed
    with pytest.raises(
        io.MeshError,
        match=r"orientations \(normals\) are inconsistent: .* 5 of \d+ triangles .*--fix-normals",
    ):
        read(io.write_stl(tmp_path / "bad.stl", bad))
    ref = plain(read(io.write_stl(tmp_path / "box.stl", tri)))
    fixed = plain(read(tmp_path / "bad.stl", fix_normals=True))
    inverted = plain(read(io.write_stl(tmp_path / "inv.stl", tri[:, ::-1])))  # all inward: turned outward
    vols = [float(jxr.hydrostatic_particulars(h, jxr.loading_condition(h, kg=KG, draught=d)).volume)
            for h in (ref, fixed, inverted)]  # fmt: skip
    np.testing.assert_allclose(vols, L * B * d, rtol=1e-12)


def _dome_file(tmp_path, name, **kw):
    import hull_meshes as hm

    return io.write_stl(
        tmp_path / name, hm.frigate(length=L, breadth=B, draught=d, depth=D, ns=31, nr=9, **kw)
    )


def test_datum_sonar_dome_skeg_and_z0_at_the_waterline(tmp_path):
    import hull_meshes as hm

    # a sonar dome 3 m below the keel line at file z = 0: the keel line is the default baseline, with a warning
    # naming both datums and the option
    path = _dome_file(tmp_path, "dome.stl", dome=3.0)
    with pytest.warns(UserWarning, match=r"lowest point \(file z = -2\.9\d* m.* local protrusion .* keel line at "
                      r"file z = 0 m .*--baseline-z -2\.9.*--draught-datum lowest or --kg-datum lowest"):  # fmt: skip
        h = read(path, x_ap=0.0)
    assert h.datum.baseline_file_z == 0.0 and h.datum.lowest_point_file_z == pytest.approx(-2.99, abs=0.01)
    assert "keel line" in h.datum.source
    assert float(h.waterlines[0]) == pytest.approx(-2.99, abs=0.01)  # the dome stays below the baseline
    # the draught measured from the keel line: the same hull volume as without the dome plus the dome's
    plain_hull = read(_dome_file(tmp_path, "nodome.stl"), x_ap=0.0)
    v = [float(jxr.hydrostatic_particulars(x, jxr.loading_condition(x, kg=KG, draught=d)).volume)
         for x in (h, plain_hull)]  # fmt: skip
    dome_volume = hm.volume(
        hm.frigate(length=L, breadth=B, draught=d, depth=D, ns=31, nr=9, dome=3.0)
    ) - hm.volume(hm.frigate(length=L, breadth=B, draught=d, depth=D, ns=31, nr=9))
    # the dome's stations are meshed at other heights, so the hulls above the keel differ by their chords: 1 %
    assert v[0] - v[1] == pytest.approx(dome_volume, rel=1e-2)
    # the lowest point on request: no warning, the datum recorded as given
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        low = read(path, x_ap=0.0, baseline_z=h.datum.lowest_point_file_z)
    assert low.datum.source.startswith("given") and float(low.waterlines[0]) == pytest.approx(0.0, abs=1e-12)
    # a skeg aft is a protrusion too
    with pytest.warns(UserWarning, match=r"local protrusion below the keel line"):
        read(_dome_file(tmp_path, "skeg.stl", skeg=1.5), x_ap=0.0)
    # file z = 0 at the waterline: the lowest point is the baseline, the warning gives the draught it implies
    with pytest.warns(UserWarning, match=r"the file's z = 0 lies inside the hull, 5 m above its lowest point .* "
                      r"--baseline-z 0 .*--draught-datum 0 or --kg-datum 0.* the draught is 5 m"):  # fmt: skip
        wl = read(_dome_file(tmp_path, "wl.stl", z0=-d), x_ap=0.0)
    assert wl.datum.baseline_file_z == pytest.approx(-d)
    # file z = 0 at the deck: nothing to warn about
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        deck = read(_dome_file(tmp_path, "deck.stl", z0=-D), x_ap=0.0)
    assert deck.datum.baseline_file_z == pytest.approx(-D)


def test_datum_options_contradicting_the_geometry_are_refused(tmp_path):
    path = _dome_file(tmp_path, "dome.stl", dome=3.0)
    with pytest.raises(io.MeshError, match=r"baseline z = 2 m \[file z, m\] is 2 m ABOVE the keel line .*"
                       r"--baseline-z 0 \(the keel line\) or -2\.9"):  # fmt: skip
        read(path, x_ap=0.0, baseline_z=2.0)
    with pytest.raises(io.MeshError, match=r"baseline z = -20 m .* BELOW the lowest point"):
        read(path, x_ap=0.0, baseline_z=-20.0)


def test_meshio_formats_read_like_the_stl(tmp_path):
    meshio = pytest.importorskip("meshio")
    tri = box_triangles()
    pts = tri.reshape(-1, 3)
    cells = np.arange(pts.shape[0]).reshape(-1, 3)
    ref = read(io.write_stl(tmp_path / "box.stl", tri))
    for suffix in (".obj", ".ply", ".vtk", ".msh"):
        path = tmp_path / f"box{suffix}"
        meshio.write(
            str(path),
            meshio.Mesh(pts, [("triangle", cells)]),
            **({"binary": False} if suffix == ".msh" else {}),
        )
        h, loading = io.read_hull(path, lpp=L, stations=N_ST, waterlines=N_WL)
        assert loading == {}
        np.testing.assert_allclose(h.half_breadths, ref.half_breadths, rtol=0, atol=1e-9)
        assert h.surface is not None and h.surface.n_triangles == ref.surface.n_triangles
    # the same checks as an STL: an open OBJ is refused
    meshio.write(str(tmp_path / "open.obj"), meshio.Mesh(pts, [("triangle", cells[:-2])]))
    with pytest.raises(io.MeshError, match="the mesh is OPEN"):
        io.read_hull(tmp_path / "open.obj", lpp=L)
    meshio.write(str(tmp_path / "tet.vtk"), meshio.Mesh(pts[:4], [("tetra", np.array([[0, 1, 2, 3]]))]))
    with pytest.raises(io.MeshError, match=r"no triangle or quad cells \(cells: \['tetra'\]\)"):
        io.read_hull(tmp_path / "tet.vtk", lpp=L)


def _cli(argv, tmp_path, capsys):
    from jaxroll._cli import main

    code = main([*argv, "--out", str(tmp_path / "out")])
    return code, capsys.readouterr()


def test_cli_bad_hull_input_exits_2_with_the_numbers(tmp_path, capsys, monkeypatch):
    import hull_meshes as hm

    monkeypatch.setenv("JAXROLL_CACHE_DIR", "")
    box = io.write_stl(tmp_path / "box.stl", box_triangles())
    base = ["hydrostatics", str(box), "--lpp", "100", "--roll-period", "10"]
    cases = [
        ([*base, "--kg", "6", "--draught", "12"], r"draught d = 12\.0 m is at or above the depth D = 10\.0 m"),
        ([*base, "--kg", "6", "--draught", "5", "--baseline-z", "3"], r"is 3 m ABOVE the keel line"),
        ([*base, "--kg", "6", "--draught", "5", "--half-hull"], r"--half-hull\) but the mesh is closed"),
        ([*base, "--kg", "6", "--displacement", "10250"], r"only 0\.\d+ % of the hull's height .*tonnes given as kg"),
        (["hydrostatics", str(io.write_stl(tmp_path / "mm.stl", box_triangles() * 1000)), "--lpp", "100", "--kg",
          "6", "--draught", "5", "--roll-period", "10"], r"length 100000 m is outside 24–500 m.*--units mm"),
        (["hydrostatics", str(io.write_stl(tmp_path / "a.stl", hm.asymmetric_prism())), "--lpp", "100", "--kg",
          "6", "--draught", "5", "--roll-period", "10"], r"not port–starboard symmetric"),
    ]  # fmt: skip
    for argv, match in cases:
        code, out = _cli(argv, tmp_path, capsys)
        assert code == 2, (argv, out.err)
        assert re.search(match, out.err), (match, out.err)
        assert not (tmp_path / "out").exists()


def test_cli_sgisc_box_barge_names_ikedas_range_and_damping(tmp_path, capsys, monkeypatch):
    # issue 37 item 12: a valid box barge (C_B = C_m = 1) is outside simplified Ikeda's range
    monkeypatch.setenv("JAXROLL_CACHE_DIR", "")
    for path in (io.write_stl(tmp_path / "box.stl", box_triangles()), write_box_gdf(tmp_path)):
        argv = ["sgisc", str(path), "--lpp", "100", "--kg", "6", "--draught", "5", "--speed-kn", "10",
                "--roll-period", "12"]  # fmt: skip
        code, out = _cli(argv, tmp_path, capsys)
        assert code == 2
        assert re.search(r"simplified Ikeda roll damping is outside its validity range: CB = 1\.000 \(range "
                         r"0\.5–0\.85\), CM = 1\.000 \(range 0\.9–0\.99\); it extrapolates to a NEGATIVE damping .* "
                         r"--damping B1 B2 B3", out.err), out.err  # fmt: skip
        assert "damping coefficients must be >= 0" not in out.err


def test_kg_above_the_deck_warns():
    with pytest.warns(
        UserWarning, match=r"KG = 12 m is above the deck: the hull's depth is D = 10 m .*--baseline-z"
    ):
        jxr.loading_condition(jxr.box_hull(L, B, D), kg=12.0, draught=d)


def test_cli_draught_and_kg_from_another_datum(tmp_path, capsys, monkeypatch):
    # issue 36 item 1: the baseline stays the keel line (the dome is a protrusion), the draught and KG are given
    # from the dome's lowest point: the same loading as given from the baseline, recorded in config.datum
    import json

    import hull_meshes as hm
    from helpers import assert_labelled_output

    monkeypatch.setenv("JAXROLL_CACHE_DIR", "")
    path = io.write_stl(tmp_path / "dome.stl", hm.frigate(length=L, breadth=B, draught=d, depth=D, ns=21, nr=7,
                                                           dome=2.0))  # fmt: skip
    with pytest.warns(UserWarning, match="local protrusion"):
        low = read(path, x_ap=0.0).datum.lowest_point_file_z
    base = ["hydrostatics", str(path), "--lpp", str(L), "--x-ap", "0", "--roll-period", "10", "--n-zeta", "7",
            "--n-heel", "5", "--stations", str(N_ST), "--waterlines", str(N_WL)]  # fmt: skip
    argv = [*base, "--draught", str(d - low), "--draught-datum", "lowest", "--kg", str(KG - low), "--kg-datum",
            f"{low!r}"]  # fmt: skip
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*local protrusion")
        code, out = _cli(argv, tmp_path, capsys)
    assert code == 0, out.err
    assert (
        "KG given from the given reference (file z = " in out.out
        and "draughts given from the lowest" in out.out
    )
    doc = json.loads((tmp_path / "out" / "hydrostatics.json").read_text())
    cfg = doc["config"]
    assert cfg["kg_m"] == pytest.approx(KG, abs=1e-9) and doc["calm_water"]["draught_m"] == pytest.approx(
        d, abs=1e-6
    )
    assert cfg["kg_given_m"] == pytest.approx(KG - low) and cfg["draught_given_m"] == pytest.approx(d - low)
    datum = cfg["datum"]
    assert datum["baseline_file_z_m"] == 0.0 and datum["lowest_point_file_z_m"] == pytest.approx(low)
    assert datum["draught_datum"] == {"option": "lowest", "file_z_m": low, "above_baseline_m": low}
    assert datum["kg_datum"]["option"] == pytest.approx(low) and datum["kg_datum"][
        "above_baseline_m"
    ] == pytest.approx(low)
    assert_labelled_output(tmp_path / "out", "hydrostatics")
    # the same condition given from the baseline: the same displacement and GM
    with pytest.warns(UserWarning, match="local protrusion"):
        h = read(path, x_ap=0.0)
    ref = jxr.hydrostatic_particulars(h, jxr.loading_condition(h, kg=KG, draught=d))
    assert doc["calm_water"]["displacement_kg"] == pytest.approx(float(ref.displacement), rel=1e-9)
    assert doc["calm_water"]["gm_m"] == pytest.approx(float(ref.gm), abs=1e-9)


def test_cli_datum_options_contradicting_the_hull_exit_2_before_computing(tmp_path, capsys, monkeypatch):
    import hull_meshes as hm

    monkeypatch.setenv("JAXROLL_CACHE_DIR", "")
    path = io.write_stl(tmp_path / "dome.stl", hm.frigate(length=L, breadth=B, draught=d, depth=D, ns=21, nr=7,
                                                           dome=2.0))  # fmt: skip
    base = [str(path), "--lpp", str(L), "--x-ap", "0", "--roll-period", "10"]
    cases = [
        (["hydrostatics", *base, "--kg", "6", "--draught", "12", "--draught-datum", "lowest"],
         r"--draught 12 m from the lowest point \(file z = -1\.8\d* m\) is d = 10\.1\d* m above the baseline: at or "
         r"above the depth D = 10 m \(the deck\)\. Check --draught-datum"),
        (["hydrostatics", *base, "--kg", "1", "--kg-datum", "lowest", "--draught", "5"],
         r"--kg 1 m from the lowest point \(file z = -1\.8\d* m\) is -0\.8\d* m above the baseline: the centre of "
         r"gravity would be at or below the bottom of the hull\. Check --kg-datum"),
        (["sgisc", *base, "--kg", "6", "--draught", "5", "--full-load-draught", "12", "--draught-datum", "keel",
          "--speed-kn", "10", "--skip-c2"], r"--full-load-draught 12 m from the keel line \(file z = 0 m\) is d = 12 m"),
        (["hydrostatics", "c11", "--kg-datum", "keel"], r"--kg-datum apply to STL, GDF and CSV hull files only"),
        # issue 45 item 2: a datum whose height is not given was ignored without a word
        (["hydrostatics", *base, "--gm", "2", "--kg-datum", "keel", "--draught", "5"],
         r"--kg-datum \(it applies to --kg, and no --kg was given: KG comes from --gm .*\) would be ignored"),
        (["hydrostatics", *base, "--kg", "6", "--displacement", "5e6", "--draught-datum", "keel"],
         r"--draught-datum \(it applies to --draught, and no --draught was given: the loading comes from "
         r"--displacement .*\) would be ignored"),
        # a hull file in millimetres read as metres (--units m, the default): L = 100 000 m, refused with the unit
        (["hydrostatics", str(io.write_stl(tmp_path / "mm.stl", box_triangles() * 1000)), "--kg", "6", "--draught",
          "5", "--roll-period", "10"], r"mm\.stl \(length overall\): .*in mm it would be 100 m.*--units mm"),
    ]  # fmt: skip
    for argv, match in cases:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", ".*local protrusion")
            code, out = _cli(argv, tmp_path, capsys)
        assert code == 2, (argv, out.err)
        assert re.search(match, out.err), (match, out.err)
        assert not (tmp_path / "out").exists()
    # a reference that is neither a name nor a number: argparse's usage error (exit 2)
    with pytest.raises(SystemExit) as e:
        _cli(
            ["sgisc", *base, "--kg", "6", "--draught", "5", "--kg-datum", "deck", "--speed-kn", "10"],
            tmp_path,
            capsys,
        )
    assert e.value.code == 2
    assert (
        "--kg-datum: give baseline, keel, lowest or a file z [m, full scale]; got 'deck'"
        in capsys.readouterr().err
    )


def test_fast_mesh_geometry_is_the_loop_it_replaced(monkeypatch):
    """The section bottoms computed for spanning (station, triangle) pairs only, and the orientation of a surface
    whose normals already agree found without the breadth-first search (issue 36: 40 → 2 ms and 37 → 9 ms of a
    3 500-triangle STL's reading), give the same numbers as the per-station loop and the search: exact equality,
    on hulls with a sonar dome, flat ends, a surface turned inward, two parts (one inward) and 50 flipped facets."""
    import hull_meshes as hm

    from jaxroll.io import _mesh_geometry as geometry

    def bottoms_by_loop(tri, stations):
        lo = tri.reshape(-1, 3).min(axis=0)
        segs = [geometry._section_segments(tri, x, strict=x <= lo[0]) for x in stations]
        return np.array([s[..., 1].min() if s.shape[0] else np.nan for s in segs])

    def orient_by_search(tri):
        with monkeypatch.context() as m:
            m.setattr(geometry, "_consistent_parts", lambda faces: None)
            return geometry.orient_consistently(tri)

    frigate = hm.frigate(dome=3.0)
    flipped = frigate.copy()
    pick = np.random.default_rng(0).choice(len(frigate), 50, replace=False)
    flipped[pick] = flipped[pick][:, ::-1]
    meshes = {
        "frigate": frigate, "box": hm.box(), "wigley": hm.wigley(), "inward": frigate[:, ::-1],
        "two parts": np.concatenate([hm.box(), hm.box()[:, ::-1] + np.array([300.0, 0.0, 0.0])]), "flipped": flipped,
    }  # fmt: skip
    for name, tri in meshes.items():
        lo, hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
        stations = np.concatenate(
            [np.linspace(lo[0] - 1, hi[0] + 1, 203), [lo[0], hi[0]], np.unique(tri[:, :, 0])[::7]]
        )
        np.testing.assert_array_equal(
            geometry.section_bottoms(tri, stations), bottoms_by_loop(tri, stations), err_msg=name
        )
        fast, search = geometry.orient_consistently(tri), orient_by_search(tri)
        np.testing.assert_array_equal(fast[0], search[0], err_msg=name)
        assert fast[1] == search[1], name
    assert geometry._consistent_parts(geometry._welded_faces(flipped)) is None  # searched
    parts = geometry._consistent_parts(geometry._welded_faces(meshes["two parts"]))
    assert len(np.unique(parts)) == 2 and orient_by_search(meshes["two parts"])[1] == hm.box().shape[0]
