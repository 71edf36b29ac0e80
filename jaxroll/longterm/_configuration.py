"""The checks and the recorded configuration of a long-term run (`longterm`)."""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..io import ship_to_dict
from ..roll import check_time_step
from ..roll._equation import _moment_excitation
from ..sea import ITTC, EffectiveWave
from ._cells import BEAM_DEG, SEED_STRIDE

#: What the theory cells are computed with (recorded in the configuration).
THEORY = (
    "jaxroll.theory.passage_risk (by passage_risk_batch, 3 inverse iterations): the envelope FPK model followed "
    "through the exposure (large rolls in groups); cells with λ <= 0 are 0 exactly"
)


def check_time_steps(grid, mask, dt: float, spreading=None) -> None:
    """`check_time_step` for every cell of `mask` (the direct wave moment's bandwidth too where the ship carries
    one; errors only; the warnings come with the cells' problems)."""
    seen = set()
    for s, k, u, i, j in np.argwhere(mask):
        key = (s, k, u, i, j)
        if key in seen:
            continue
        seen.add(key)
        sea, speed, chi = (
            ITTC(float(grid.scatter.hs[i]), float(grid.scatter.t01[j])),
            float(grid.speeds[u]),
            math.radians(float(grid.classes_deg[k])),
        )
        wave = EffectiveWave(sea, grid.ships[s].lpp, speed, chi, spreading=spreading)
        moment = _moment_excitation(grid.ships[s], sea, speed, chi, dt, spreading)  # None without one
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                check_time_step(dt, grid.ships[s], wave, moment)
            except ValueError as e:
                raise ValueError(
                    f"sea state H_s {grid.scatter.hs[i]:g} m, T_z {grid.scatter.tz[j]:g} s, heading "
                    f"{grid.classes_deg[k]:g}°, U {grid.speeds[u]:g} m/s: {e}"
                ) from None


def run_config(
    grid,
    files,
    angles_deg,
    exposure,
    method,
    realizations,
    discard,
    dt,
    excitation,
    filter_order,
    phi0,
    seed,
    hours_per_year,
    auto_share,
    auto_tolerance,
    model_factor,
    skip_weight,
    estimator,
    refine_delta,
    rare_below,
    spreading=None,
) -> dict:
    """The whole configuration (JSON-able): what the dataset's `config_json` attribute holds."""
    from ..io import to_jsonable

    sc = grid.scatter
    return to_jsonable(
        {
            "scatter": {
                "name": sc.name,
                "source": sc.source,
                "hs_m": sc.hs,
                "tz_s": sc.tz,
                "counts": sc.counts,
                "total": sc.total,
                "t01_over_tz": float(sc.t01[0] / sc.tz[0]),
            },
            "ships": [
                {"name": n, "file": f, "weight": float(w), "coefficients": ship_to_dict(s)}
                for n, f, w, s in zip(grid.ship_names, files, grid.ship_weights, grid.ships, strict=True)
            ],
            "headings_deg": grid.headings_deg,
            "heading_weights": grid.heading_weights,
            "heading_classes_deg": grid.classes_deg,
            "heading_convention": "χ between the course and the wave direction: 0° following, 90° beam, 180° head; χ and "
            "360° − χ computed once (port/starboard symmetry)",
            "speeds_m_s": grid.speeds,
            "speed_weights": grid.speed_weights,
            "angles_deg": angles_deg,
            "exposure_s": float(exposure),
            "hours_per_year": float(hours_per_year),
            "method": method,
            "theory": THEORY if method != "monte-carlo" else None,
            "realizations": int(realizations),
            "discard_s": float(discard),
            "dt_s": float(dt),
            "excitation": excitation,
            "filter_order": filter_order if filter_order == "auto" else int(filter_order),
            "phi0_deg": math.degrees(phi0),
            "seed": int(seed),
            "cell_seed_rule": f"s_c = {SEED_STRIDE}·seed + c + 1 (c: the computation cell's index)",
            "auto_share": float(auto_share),
            "auto_tolerance": float(auto_tolerance),
            "model_factor": model_factor if model_factor == "measured" else float(model_factor),
            "skip_weight": float(skip_weight),
            "refine_delta": float(refine_delta),
            "estimator": estimator,
            "rare_below": float(rare_below),
            "rare_rule": (
                "estimator 'splitting': a Monte Carlo cell is estimated by multilevel splitting where its "
                "probability at the largest angle is below rare_below — the theory's (method auto) or its "
                "splitting pilot's (method monte-carlo); the other Monte Carlo cells by brute force"
                if estimator == "splitting"
                else None
            ),
            "beam_deg": BEAM_DEG,
            "spreading": "none" if spreading is None else spreading.label(),
        }
    )
