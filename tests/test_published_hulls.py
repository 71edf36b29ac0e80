"""Hulls with PUBLISHED geometry and PUBLISHED particulars, generated here from their published formulas.

The modified Wigley hull (issue 36 item 4). Source: J.M.J. Journée, "Experiments and calculations on four Wigley
hullforms", report 909, Ship Hydromechanics Laboratory, Delft University of Technology, 1992 (the models Wigley
I–III share the form below; Wigley I: L = 3.000 m, B = 0.300 m, d = 0.1875 m). The form, with ξ = 2x/L from
amidships and ζ = z/d down from the waterline,

    y = (B/2) [(1 − ζ²)(1 − ξ²)(1 + 0.2 ξ²) + ζ²(1 − ζ⁸)(1 − ξ²)⁴],

is the report's; its published form coefficients are C_b = 0.561, C_m = 0.909, C_wp = 0.693, given to three
decimals (accuracy ±0.0005). The hull here is Wigley I at 1:50 (L = 150 m: jaxroll refuses model-scale lengths
unless told the scale, and form coefficients do not depend on it), wall-sided above the waterline to D = 1.6 d.

Two references, each independent of jaxroll's engine: the published coefficients (to their stated three
decimals), and the closed forms of the same analytic surface (∇, KB, BM, BM_L, A_wp as polynomial integrals,
NumPy), which the mesh meets to its own chord error (second order in the spacing: the convergence is checked).
"""

import hull_meshes as hm
import numpy as np
from numpy.polynomial import polynomial as P

import jaxroll as jxr
from jaxroll import io

SCALE = 50.0
L, B, T = 3.0 * SCALE, 0.3 * SCALE, 0.1875 * SCALE
D = 1.6 * T
PUBLISHED = {"block_coefficient": 0.561, "midship_coefficient": 0.909, "waterplane_coefficient": 0.693}


def _integral(coefs) -> float:
    """∫₀¹ of a polynomial given by its coefficients (lowest first)."""
    c = P.polyint(coefs)
    return float(P.polyval(1.0, c) - P.polyval(0.0, c))


def closed_forms() -> dict[str, float]:
    """The modified Wigley hull's exact particulars at d = T (symmetric fore and aft: LCB = LCF = L/2)."""
    one = [1.0]
    fx = P.polymul([1, 0, -1], [1, 0, 0.2])  # (1 − ξ²)(1 + 0.2ξ²): the waterline, and the first term's ξ part
    gx = P.polypow([1, 0, -1], 4)  # (1 − ξ²)⁴
    fz = [1, 0, -1]  # 1 − ζ²
    gz = P.polymul([0, 0, 1], P.polysub(one, [0] * 8 + [1]))  # ζ²(1 − ζ⁸)
    cb = _integral(fx) * _integral(fz) + _integral(gx) * _integral(gz)
    first_moment = _integral(fx) * _integral(P.polymul([0, 1], fz)) + _integral(gx) * _integral(
        P.polymul([0, 1], gz)
    )
    cm = _integral(fz) + _integral(gz)  # η(ξ = 0, ζ)
    cwp = _integral(fx)  # η(ξ, ζ = 0)
    volume = cb * L * B * T
    return dict(
        volume=volume,
        kb=T * (1 - first_moment / cb),  # z above the keel = T(1 − ζ)
        bm=(2 / 3) * (B / 2) ** 3 * L * _integral(P.polypow(fx, 3)) / volume,  # I_T = ∫ (2/3) y³ dx
        bm_longitudinal=B * L**3 / 4 * _integral(P.polymul(fx, [0, 0, 1])) / volume,  # I_L = ∫ 2y x² dx
        waterplane_area=cwp * L * B,
        block_coefficient=cb,
        midship_coefficient=cm,
        waterplane_coefficient=cwp,
        prismatic_coefficient=cb / cm,
        lcb=L / 2,
        lcf=L / 2,
    )


def wigley_particulars(ns, nr):
    tri = hm.modified_wigley(L, B, T, D, ns=ns, nr=nr)
    h = io.hull_from_triangles(tri, lpp=L, x_ap=0.0, name="modified Wigley (Journée 1992), 1:50", stations=21,
                               waterlines=11)  # fmt: skip
    return jxr.hydrostatic_particulars(h, jxr.loading_condition(h, kg=0.5 * D, draught=T))


def test_closed_forms_give_the_published_coefficients():
    # the form transcribed here is the report's: its exact coefficients round to the published ones
    exact = closed_forms()
    for name, value in PUBLISHED.items():
        assert round(exact[name], 3) == value, (name, exact[name])


def test_modified_wigley_mesh_meets_the_published_particulars_and_the_closed_forms():
    exact = closed_forms()
    names = list(exact)
    errs = []
    for ns, nr in ((61, 25), (121, 49)):
        p = wigley_particulars(ns, nr)
        ours = np.array([float(getattr(p, k)) for k in names])
        ref = np.array([exact[k] for k in names])
        errs.append(np.abs(ours - ref) / np.abs(ref))
    # published, to the three decimals the report gives (±0.0005 + the 2 mm waterline chord error at most)
    p = wigley_particulars(121, 49)
    for name, value in PUBLISHED.items():
        assert abs(float(getattr(p, name)) - value) <= 5e-4 + 1e-4, (name, float(getattr(p, name)), value)
    # the closed forms of the same surface: the mesh's chords only (1e-3 relative on 121 × 49), second order
    assert np.all(errs[1] < 1e-3), dict(zip(names, errs[1]))
    converging = errs[0] > 1e-9  # LCB, LCF: exact on both meshes by symmetry
    assert np.all(errs[1][converging] < errs[0][converging] / 2.5), dict(zip(names, errs[0] / errs[1]))
