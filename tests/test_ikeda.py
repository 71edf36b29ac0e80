"""Simplified Ikeda roll damping (Kawahara, Maekawa & Ikeda) and its conversion to jaxroll's b1, b2; the ship
file's damping source.

Reference value: B̂44 = 0.010156148773301035 for L/B = 6, B/d = 4, C_B = 0.65, C_m = 0.98, φa = 10°,
b_BK/B = 0.025, l_BK/L = 0.2, OG/d = −0.2, ω̂ = 0.6, L = 300 m (g = 9.81) — the regression test of the Python
port of the authors' Fortran in github.com/martinlarsalbert/rolldecay-estimators
(rolldecayestimators/tests/test_simplified_ikeda.py), itself cross-checked there against P. Piehl's independent
port. The paper's own worked tables were not retrievable (docs/sgisc.md).
"""

import math
import tomllib

import pytest

import jaxroll as jxr
from jaxroll.ship import IkedaRangeError, ikeda_damping, simplified_ikeda

LPP = 300.0
B = LPP / 6
D = B / 4
CASE = dict(lpp=LPP, breadth=B, draught=D, block_coefficient=0.65, midship_coefficient=0.98, og=-0.2 * D)
C11 = dict(lpp=262.0, breadth=40.0, draught=11.5, block_coefficient=0.55, midship_coefficient=0.976, kg=15.53,
           gm=1.93, roll_period=24.4)  # fmt: skip


def test_reference_value_of_the_authors_program():
    w = 0.6 / math.sqrt(B / 2 / 9.81)
    r = simplified_ikeda(**CASE, roll_amplitude=math.radians(10), omega=w, bilge_keel_length=0.2 * LPP,
                         bilge_keel_breadth=0.025 * B, gravity=9.81)  # fmt: skip
    assert r.total == pytest.approx(0.010156148773301035, rel=1e-9)
    assert r.out_of_range == []
    assert r.total == pytest.approx(r.friction + r.wave + r.eddy + r.bilge_keel, rel=1e-15)


def test_amplitude_dependence_of_the_components():
    w = 0.5 / math.sqrt(B / 2 / 9.80665)
    r1, r2 = (simplified_ikeda(**CASE, roll_amplitude=math.radians(a), omega=w) for a in (5.0, 15.0))
    assert r2.friction == pytest.approx(r1.friction, rel=1e-12)  # Kato: B_F independent of φa
    assert r2.wave == pytest.approx(r1.wave, rel=1e-12)  # linear wave damping
    assert r2.eddy == pytest.approx(3 * r1.eddy, rel=1e-12)  # eddy ∝ φa (quadratic damping)
    assert r1.bilge_keel == 0.0


def test_jaxroll_coefficients_reproduce_the_equivalent_linear_damping():
    bare = ikeda_damping(**C11)
    assert bare["fit_rms"] < 1e-12  # without bilge keels B_eq is exactly linear in φa
    assert bare["b1"] > 0 and bare["b2"] > 0 and bare["b3"] == 0.0
    assert "no bilge keels" in bare["source"] and "Ikeda" in bare["source"]
    keels = ikeda_damping(**C11, bilge_keel_length=65.5, bilge_keel_breadth=0.4)
    assert keels["b2"] > bare["b2"] and "65.5 m x 0.4 m" in keels["source"]
    # per-unit-inertia conversion: ζ = B44/(2 ω0 (I + A)), I + A = ρ g ∇ GM/ω0²
    w0 = 2 * math.pi / 24.4
    vol = 262.0 * 40.0 * 11.5 * 0.55
    b44 = bare["b_hat"][0] * 1025.0 * vol * 40.0**2 * math.sqrt(2 * 9.80665 / 40.0)
    zeta = b44 / (2 * w0 * 1025.0 * 9.80665 * vol * 1.93 / w0**2)
    assert bare["zeta_eq"][0] == pytest.approx(zeta, rel=1e-12)


def test_out_of_range_and_bad_inputs():
    r = simplified_ikeda(**(CASE | dict(block_coefficient=0.45)), roll_amplitude=0.1, omega=0.5)
    assert "CB" in r.out_of_range
    with pytest.raises(ValueError, match="gm"):
        ikeda_damping(**(C11 | dict(gm=-0.5)))
    with pytest.raises(ValueError, match="bilge_keel_length"):
        ikeda_damping(**C11, bilge_keel_length=-1.0)


def test_ship_file_records_the_damping_source():
    fit = ikeda_damping(**C11)
    ship = jxr.c11_representative()
    text = jxr.ship_to_toml(ship, damping_source=fit["source"])
    data = tomllib.loads(text)
    assert data["damping"]["source"] == fit["source"]
    back = jxr.ship_from_dict(data)
    assert f"[damping: {fit['source']}]" in back.provenance
    assert jxr.io.damping_source(data) == fit["source"]
    # files without the key stay valid (backwards compatible); a non-text source is an error
    assert jxr.io.damping_source(tomllib.loads(jxr.ship_to_toml(ship))) is None
    data["damping"]["source"] = 1.0
    with pytest.raises(ValueError, match="source must be text"):
        jxr.ship_from_dict(data)


def test_negative_estimate_outside_the_range_is_an_error_naming_the_parameters():
    # a box barge 100 × 20 × 5 m (C_B = C_m = 1): the eddy term's regression goes negative (issue 37 item 12)
    box = dict(lpp=100.0, breadth=20.0, draught=5.0, block_coefficient=1.0, midship_coefficient=1.0, kg=6.0,
               gm=3.1667, roll_period=12.0)  # fmt: skip
    with pytest.raises(IkedaRangeError, match=r"outside its validity range: CB = 1\.000 \(range 0\.5–0\.85\), CM = "
                       r"1\.000 \(range 0\.9–0\.99\); it extrapolates to a NEGATIVE damping .*--damping B1 B2 B3"):  # fmt: skip
        ikeda_damping(**box)
    assert issubclass(IkedaRangeError, ValueError)
    # inside the ranges the estimate stands (the C11 reference case)
    assert ikeda_damping(**C11)["b1"] > 0
