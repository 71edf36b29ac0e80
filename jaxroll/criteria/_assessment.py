"""The parametric-roll vulnerability assessment of a loading condition (Level 1, C1, C2) and KGmax curves."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._config import require_float64
from ..ship._fits import ship_from_hull
from ..ship._hull import Hull
from ..ship._hydrostatics import GRAVITY, Loading, loading_condition
from ..ship._ikeda import IkedaRangeError, ikeda_damping
from ..ship._ship import Ship
from ._c2 import C2Result, effective_wave_height, level2_c2
from ._parametric_roll import (
    C1_WAVE_CASES,
    R_PR1,
    REC34_HS,
    REC34_TZ,
    C1Result,
    Level1Result,
    _calm,
    c1_from_gm,
    gm_in_waves,
    is_code_roll_period,
    level1,
    level2_c1,
    r_pr,
)

KNOT = 1852.0 / 3600.0
"""One knot [m/s]."""


@dataclass
class ParametricRollAssessment:
    """Level 1, C1, C2 and the verdict of one loading condition (SI units; radians in `c2.max_roll`)."""

    level1: Level1Result
    c1: C1Result
    c2: C2Result | None
    damping: dict
    ship: Ship | None
    roll_period: float
    roll_period_source: str
    bilge_keel_area: float
    service_speed: float
    verdict: str
    vulnerable: bool
    notes: list = field(default_factory=list)

    def to_xarray(self):
        """The assessment as an `xarray.Dataset` named as in sgisc.json: `level1_*` (with `level1_gm_waves` on
        `crest_position`), `level2_c1_*` (its wave cases on `c1_case`), `damping_*` (on `damping_amplitude`),
        `level2_c2_*` (per case on `c2_case`, `level2_c2_max_roll_deg` on (`c2_case`, `c2_hs`, `c2_tz`)) when C2
        was computed, `vulnerable`; the verdict and notes as attributes."""
        from .._labels import tree_to_dataset
        from .._labels._layouts import SGISC

        tree = {
            "level1": vars(self.level1),
            "level2_c1": vars(self.c1),
            "damping": self.damping,
            "roll_period_s": self.roll_period,
            "roll_period_source": self.roll_period_source,
            "bilge_keel_area_m2": self.bilge_keel_area,
            "service_speed_m_s": self.service_speed,
            "verdict": self.verdict,
            "vulnerable": self.vulnerable,
            "notes": list(self.notes),
        }
        if self.c2 is not None:
            c2 = self.c2
            tree["level2_c2"] = {
                "c2": c2.c2,
                "standard": c2.standard,
                "vulnerable": c2.vulnerable,
                "per_case": c2.per_case,
                "hs_m": REC34_HS,
                "tz_s": REC34_TZ,
                "effective_wave_height_m": c2.effective_wave_height,
                "max_roll_deg": np.degrees(c2.max_roll),
            }
        return tree_to_dataset(tree, SGISC)


def _roll_period(calm, hull, roll_period, roll_gyradius):
    if roll_period is not None and roll_gyradius is not None:
        raise ValueError("give at most one of `roll_period` [s] and `roll_gyradius` [m].")
    gm = float(calm.gm)
    if roll_period is not None:
        return float(roll_period), "given"
    if roll_gyradius is not None:
        return 2 * math.pi * float(roll_gyradius) / math.sqrt(
            GRAVITY * gm
        ), "from the roll gyradius (no added inertia)"
    t = is_code_roll_period(
        breadth=float(calm.waterline_breadth),
        draught=float(calm.draught),
        waterline_length=float(hull.lpp),
        gm=gm,
    )
    return t, "IS Code 2008 Part A 2.3.4 formula"


def assess_parametric_roll(
    hull: Hull,
    loading: Loading,
    *,
    service_speed: float,
    roll_period: float | None = None,
    roll_gyradius: float | None = None,
    bilge_keel_length: float = 0.0,
    bilge_keel_breadth: float = 0.0,
    bilge_keel_area: float | None = None,
    sharp_bilge: bool = False,
    full_load_draught: float | None = None,
    damping=None,
    damping_source: str | None = None,
    skip_c2: bool = False,
) -> ParametricRollAssessment:
    """Vulnerability to parametric rolling of one loading condition: Level 1, Level 2 C1 and C2, and a verdict.

    **Arguments:**

    - `hull`, `loading`: the hull and its loading condition (draught, KG).
    - `service_speed`: V_S [m/s].
    - `roll_period` T_φ [s], or `roll_gyradius` k_xx [m]; default: the IS Code formula.
    - `bilge_keel_length`, `bilge_keel_breadth` [m] (each side): used by R_PR (A_k = 2 l b) and by the Ikeda
        damping; or `bilge_keel_area` A_k [m²] (both sides) for R_PR alone (Ikeda then without bilge keels).
    - `sharp_bilge`: R_PR = 1.87. `full_load_draught`: d_full [m] for Level 1's δd_L.
    - `damping`: (b1 [1/s], b2 [1/rad], b3 [s/rad²]) for C2 with its `damping_source`; default: the simplified
        Ikeda method ([`jaxroll.ship.ikeda_damping`][]).
    - `skip_c2`: stop after C1 (C2 builds the roll model from the hull: hydrostatics and a simulation).

    **Returns:** a [`ParametricRollAssessment`][].
    """
    require_float64("jaxroll.criteria.assess_parametric_roll")
    calm = _calm(hull, loading)
    notes = []
    if bilge_keel_area is None:
        bilge_keel_area = 2.0 * bilge_keel_length * bilge_keel_breadth
    elif bilge_keel_length > 0 or bilge_keel_breadth > 0:
        raise ValueError("give the bilge keels either as length and breadth or as an area, not both.")
    elif bilge_keel_area > 0:
        notes.append(
            "bilge keels given by their area only: R_PR uses it; the Ikeda damping is computed without bilge "
            "keels (conservative), since it needs their length and breadth."
        )
    t_phi, t_source = _roll_period(calm, hull, roll_period, roll_gyradius)
    if damping is None:  # before Level 1 and C1: an unusable estimate is reported at once
        try:
            fit = _ikeda(hull, calm, t_phi, bilge_keel_length, bilge_keel_breadth)
        except IkedaRangeError as e:
            if not skip_c2:
                raise
            fit = dict(source=f"not usable: {e}", b1=None, b2=None, b3=None, out_of_range=[])
            notes.append(
                "C2 skipped; the simplified Ikeda damping is not usable for this hull (see `damping`)."
            )
        if fit["out_of_range"]:
            notes.append(
                f"Ikeda damping: {', '.join(fit['out_of_range'])} outside the regression's range (extrapolated)."
            )
    else:
        b = [float(v) for v in damping]
        fit = dict(source=damping_source or "given", b1=b[0], b2=b[1], b3=b[2])
    l1 = level1(
        hull,
        loading,
        bilge_keel_area=bilge_keel_area,
        sharp_bilge=sharp_bilge,
        full_load_draught=full_load_draught,
    )
    c1 = level2_c1(
        hull,
        loading,
        service_speed=service_speed,
        roll_period=t_phi,
        bilge_keel_area=bilge_keel_area,
        sharp_bilge=sharp_bilge,
    )
    ship, c2 = None, None
    if not skip_c2:
        heff_max = float(np.max(effective_wave_height(float(hull.lpp), REC34_HS[-1], REC34_TZ)))
        zmax = heff_max / 2
        ship = ship_from_hull(
            hull,
            loading,
            roll_period=t_phi,
            damping=[fit["b1"], fit["b2"], fit["b3"]],
            zeta_mid=np.linspace(-zmax, zmax, 13),
            name=f"{hull.name} (parametric-roll assessment)",
        )
        c2 = level2_c2(ship, service_speed=service_speed)
    if not l1.vulnerable:
        verdict = "not vulnerable (Level 1)"
    elif not c1.vulnerable:
        verdict = "not vulnerable (Level 2, first check C1)"
    elif c2 is not None and not c2.vulnerable:
        verdict = "not vulnerable (Level 2, second check C2)"
    elif c2 is None:
        verdict = "VULNERABLE at Level 1 and C1; C2 not computed"
    else:
        verdict = "VULNERABLE at Level 2: a direct stability assessment (or operational measures) is needed"
    return ParametricRollAssessment(
        level1=l1,
        c1=c1,
        c2=c2,
        damping=fit,
        ship=ship,
        roll_period=t_phi,
        roll_period_source=t_source,
        bilge_keel_area=float(bilge_keel_area),
        service_speed=float(service_speed),
        verdict=verdict,
        vulnerable=verdict.startswith("VULNERABLE"),
        notes=notes,
    )


def _ikeda(hull, calm, t_phi, bilge_keel_length, bilge_keel_breadth) -> dict:
    return ikeda_damping(
        lpp=float(hull.lpp),
        breadth=float(calm.waterline_breadth),
        draught=float(calm.draught),
        block_coefficient=float(calm.block_coefficient),
        midship_coefficient=float(calm.midship_coefficient),
        kg=float(calm.kg),
        gm=float(calm.gm),
        roll_period=t_phi,
        bilge_keel_length=bilge_keel_length,
        bilge_keel_breadth=bilge_keel_breadth,
    )


@dataclass
class KGMaxCurve:
    """KGmax [m] against draught [m] for Level 1 and for C1 (NaN where no KG in the scanned range passes)."""

    draught: np.ndarray
    km: np.ndarray
    kg_max_level1: np.ndarray
    kg_max_c1: np.ndarray
    delta_gm1: np.ndarray
    r_pr: np.ndarray

    def to_xarray(self):
        """The curves as an `xarray.Dataset` on `kg_max_draught` (sgisc.json's `kg_max_*` names)."""
        from .._labels import tree_to_dataset
        from .._labels._layouts import SGISC

        return tree_to_dataset(
            {
                "kg_max": {
                    "draught_m": self.draught,
                    "km_m": self.km,
                    "kg_max_level1_m": self.kg_max_level1,
                    "kg_max_c1_m": self.kg_max_c1,
                    "delta_gm1_m": self.delta_gm1,
                    "r_pr": self.r_pr,
                }
            },
            SGISC,
        )


def kg_max_curve(
    hull: Hull,
    draughts,
    *,
    service_speed: float,
    roll_gyradius: float | None = None,
    bilge_keel_area: float = 0.0,
    sharp_bilge: bool = False,
    gm_min: float = 0.05,
    gm_max: float | None = None,
    kg_step: float = 0.01,
) -> KGMaxCurve:
    """KGmax curves of the parametric-roll Level 1 and C1 over draughts (even keel).

    ΔGM1 and the KM in waves do not depend on KG (the balance does not), so each draught needs one set of
    hydrostatics: Level 1 gives KGmax = KM − ΔGM1/R_PR in closed form; C1 is scanned over KG from KM − gm_max up to
    KM − gm_min in steps of `kg_step`, and KGmax is the KG below which every scanned KG passes (C1 ≤ R_PR1).
    T_φ follows GM: from `roll_gyradius` k [m] (2πk/√(g GM)) or, by default, the IS Code formula.

    **Arguments:** `hull`; `draughts` [m]; `service_speed` V_S [m/s]; `roll_gyradius` [m]; `bilge_keel_area` A_k
    [m²], `sharp_bilge`; `gm_min`, `gm_max` [m] (default gm_max: B/4), `kg_step` [m].

    **Returns:** a [`KGMaxCurve`][].
    """
    require_float64("jaxroll.criteria.kg_max_curve")
    ds = np.atleast_1d(np.asarray(draughts, float))
    out = {k: [] for k in ("km", "l1", "c1", "dgm1", "rpr")}
    lam, h = C1_WAVE_CASES[:, 1], C1_WAVE_CASES[:, 2]
    for d in ds:
        try:
            probe = loading_condition(hull, kg=0.0, draught=float(d))
            r1 = level1(hull, probe, bilge_keel_area=bilge_keel_area, sharp_bilge=sharp_bilge)
            km = r1.gm  # KG = 0
            km_waves = gm_in_waves(hull, probe, wavelengths=lam, heights=h)
        except ValueError as e:  # say which point of the curve: its draughts are not the assessed loading's
            raise ValueError(f"KGmax curve at the draught {float(d):.4g} m above the baseline: {e}") from None
        calm = _calm(hull, probe)
        breadth = float(calm.waterline_breadth)
        rpr = r_pr(
            lpp=float(hull.lpp),
            breadth=breadth,
            midship_coefficient=float(calm.midship_coefficient),
            bilge_keel_area=bilge_keel_area,
            sharp_bilge=sharp_bilge,
        )
        top = breadth / 4 if gm_max is None else gm_max
        kgs = np.arange(km - top, km - gm_min + 1e-12, kg_step)
        kg_ok = math.nan
        for kg in kgs:
            gm = km - kg
            if roll_gyradius is None:
                t = is_code_roll_period(
                    breadth=breadth, draught=float(d), waterline_length=float(hull.lpp), gm=gm
                )
            else:
                t = 2 * math.pi * roll_gyradius / math.sqrt(GRAVITY * gm)
            res = c1_from_gm(km_waves - kg, gm, r_pr_value=rpr, roll_period=t, service_speed=service_speed)
            if res.c1 > R_PR1:
                break
            kg_ok = kg
        out["km"].append(km)
        out["l1"].append(km - r1.delta_gm1 / rpr)
        out["c1"].append(kg_ok)
        out["dgm1"].append(r1.delta_gm1)
        out["rpr"].append(rpr)
    return KGMaxCurve(
        draught=ds,
        km=np.asarray(out["km"]),
        kg_max_level1=np.asarray(out["l1"]),
        kg_max_c1=np.asarray(out["c1"]),
        delta_gm1=np.asarray(out["dgm1"]),
        r_pr=np.asarray(out["rpr"]),
    )
