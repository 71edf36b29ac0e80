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
    hh = read(io.write_stl(tmp_path / "half.stl", half), stations=11, waterlines=3)
    np.testing.assert_allclose(hh.half_breadths, B / 2, atol=1e-9)


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
    assert "apply to STL and CSV hull files only" in capsys.readouterr().err
