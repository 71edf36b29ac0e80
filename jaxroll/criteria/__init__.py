"""IMO second generation intact stability criteria (MSC.1/Circ.1627): vulnerability to parametric rolling.

Level 1 (ΔGM1/GM against R_PR), Level 2 first check C1 (16 wave cases) and second check C2 (roll in the regular
waves of the scatter table, jaxroll's roll equation), the combined assessment and KGmax curves. Tables,
constants and their verification status: docs/sgisc.md.
"""

from ._assessment import (
    KNOT as KNOT,
    KGMaxCurve as KGMaxCurve,
    ParametricRollAssessment as ParametricRollAssessment,
    assess_parametric_roll as assess_parametric_roll,
    kg_max_curve as kg_max_curve,
)
from ._c2 import (
    INITIAL_ROLL as INITIAL_ROLL,
    ROLL_ANGLE_LIMIT as ROLL_ANGLE_LIMIT,
    ROLL_ANGLE_LIMIT_DEG as ROLL_ANGLE_LIMIT_DEG,
    SIGNIFICANT_HEIGHT_FACTOR as SIGNIFICANT_HEIGHT_FACTOR,
    SPEED_FACTORS as SPEED_FACTORS,
    C2Result as C2Result,
    c2_cases as c2_cases,
    effective_wave_height as effective_wave_height,
    encounter_frequency_regular as encounter_frequency_regular,
    level2_c2 as level2_c2,
    regular_wave_max_roll as regular_wave_max_roll,
    roll_versus_speed as roll_versus_speed,
)
from ._parametric_roll import (
    BILGE_KEEL_RATIO_MAX as BILGE_KEEL_RATIO_MAX,
    C1_WAVE_CASES as C1_WAVE_CASES,
    DRAUGHT_LOW_FRACTION as DRAUGHT_LOW_FRACTION,
    POSITIONS_PER_WAVE as POSITIONS_PER_WAVE,
    R_PR1 as R_PR1,
    R_PR2 as R_PR2,
    R_PR_BASE as R_PR_BASE,
    R_PR_CM_LINEAR as R_PR_CM_LINEAR,
    R_PR_SHARP_BILGE as R_PR_SHARP_BILGE,
    R_PR_SLOPE_FINE as R_PR_SLOPE_FINE,
    R_PR_SLOPE_FULL as R_PR_SLOPE_FULL,
    REC34_HS as REC34_HS,
    REC34_SCATTER as REC34_SCATTER,
    REC34_TZ as REC34_TZ,
    RESERVE_RATIO_MIN as RESERVE_RATIO_MIN,
    T01_OVER_TZ as T01_OVER_TZ,
    WAVE_STEEPNESS_LEVEL1 as WAVE_STEEPNESS_LEVEL1,
    C1Result as C1Result,
    Level1Result as Level1Result,
    c1_from_gm as c1_from_gm,
    gm_in_waves as gm_in_waves,
    is_code_roll_period as is_code_roll_period,
    level1 as level1,
    level2_c1 as level2_c1,
    r_pr as r_pr,
    volume_to as volume_to,
    waterplane_area as waterplane_area,
    waterplane_inertia as waterplane_inertia,
)
