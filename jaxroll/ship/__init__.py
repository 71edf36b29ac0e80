"""The ship: roll-model parameters, restoring and ΔGM, hull geometry and hydrostatics.

Ship and hull files (TOML) are read and written by `jaxroll.io`.
"""

from ._fits import (
    c11_hull_ship as c11_hull_ship,
    hull_hydrostatics as hull_hydrostatics,
    ship_from_hull as ship_from_hull,
)
from ._hull import (
    Hull as Hull,
    box_hull as box_hull,
    c11_hull as c11_hull,
    wigley_hull as wigley_hull,
)
from ._hydrostatics import (
    equilibrium as equilibrium,
    gz_curve as gz_curve,
    hydrostatic_particulars as hydrostatic_particulars,
    loading_condition as loading_condition,
    metacentric_height as metacentric_height,
)
from ._restoring import (
    delta_gm as delta_gm,
    parametric_excitation as parametric_excitation,
    restoring_moment as restoring_moment,
    righting_lever as righting_lever,
    vanishing_angle as vanishing_angle,
)
from ._ship import (
    Ship as Ship,
    c11_representative as c11_representative,
)
