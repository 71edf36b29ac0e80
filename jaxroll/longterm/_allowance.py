"""The exposure theory's model allowance per region of the sea-state map, as measured against an exact-spectrum sea.

`jaxroll.theory.passage_risk` (the envelope FPK model followed through the exposure) was compared with an
independent exact-spectrum simulation over H1/3 4–8 m × T01 8–12 s × head, 150° and following seas × 0 and 5 m/s
× 25–45° × 1 h and 3 h (`python benchmarks/validation_map.py`, reference `benchmarks/exact_reference.py`;
docs/validation.md). The theory is mostly low (ratios 0.48–1.23 at zero speed, 0.28–1.42 at 5 m/s, since its envelope
takes the sea's level over the band the roll locks to; before, 0.34–1.02 and 0.06–0.78), and its error depends on
the speed and on T01 more than on H1/3, heading or angle. So a theory cell's allowance is
asymmetric and per region (speed class × T01 band): the exact value is taken to lie in [P/f_below, min(1,
P·f_above)], f_below = max(1, largest ratio P/P_exact) and f_above = max(1, 1/smallest ratio) over the region's
entries with at least 25 reference exceedances. A cell outside the validated map (H1/3, T01 or speed beyond it) or
in a region never measured takes the widest factors measured and is flagged (`theory_outside_validated_map`); a
region where the theory may be more than `COVERED_FACTOR` times low is not covered by it: `method="auto"` simulates
its cells where they are material, as it does the flagged ones.
"""

from __future__ import annotations

import math

import numpy as np

#: The validated map: (low, high) of H1/3 [m], T01 [s] and speed [m/s].
VALIDATED_MAP = {"hs_m": (4.0, 8.0), "t01_s": (8.0, 12.0), "speed_m_s": (0.0, 5.0)}
#: Speed classes [m/s) and T01 bands [s) of the regions.
SPEED_CLASSES = ((0.0, 0.5), (0.5, math.inf))
T01_BANDS = ((0.0, 9.0), (9.0, 11.0), (11.0, math.inf))
#: (f_below, f_above) per region (speed class, T01 band), measured 2026-12-07 (`python benchmarks/validation_map.py`,
#: "passage allowance" lines); None: no entry there (the map's head seas at 5 m/s and T01 8 s never roll).
MEASURED = {
    (0, 0): (1.225, 1.406),
    (0, 1): (1.145, 2.020),
    (0, 2): (1.120, 2.095),
    (1, 0): None,
    (1, 1): (1.059, 3.597),
    (1, 2): (1.401, 1.929),
}
#: The widest factors measured: the allowance outside the validated map and in unmeasured regions.
WIDEST = tuple(max(v[k] for v in MEASURED.values() if v is not None) for k in (0, 1))
#: A region whose f_above exceeds this is not covered by the theory (`method="auto"` simulates it where material).
COVERED_FACTOR = 4.0


def measured_allowance(hs, t01, speed) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(f_below, f_above, outside, covered) per cell, arrays broadcast from `hs` [m], `t01` [s], `speed` [m/s]: the
    measured factors of the cell's region (the widest outside the validated map or where nothing was measured),
    whether the cell is outside the map, and whether the theory covers it (inside, f_above ≤ `COVERED_FACTOR`)."""
    hs, t01, speed = np.broadcast_arrays(*(np.asarray(x, float) for x in (hs, t01, speed)))
    below, above = np.full(hs.shape, WIDEST[0]), np.full(hs.shape, WIDEST[1])
    for (si, ti), v in MEASURED.items():
        if v is None:
            continue
        (ulo, uhi), (lo, hi) = SPEED_CLASSES[si], T01_BANDS[ti]
        here = (t01 >= lo) & (t01 < hi) & (speed >= ulo) & (speed < uhi)
        below, above = np.where(here, v[0], below), np.where(here, v[1], above)
    tol = 1e-9
    outside = np.zeros(hs.shape, bool)
    for x, key in ((hs, "hs_m"), (t01, "t01_s"), (speed, "speed_m_s")):
        lo, hi = VALIDATED_MAP[key]
        outside |= (x < lo - tol) | (x > hi + tol)
    below, above = np.where(outside, WIDEST[0], below), np.where(outside, WIDEST[1], above)
    return below, above, outside, ~outside & (above <= COVERED_FACTOR)
