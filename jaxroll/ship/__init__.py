"""The ship: roll-model parameters, restoring and ΔGM, hull geometry and hydrostatics.

Ship and hull files (TOML) are read and written by `jaxroll.io`.
"""

from ._bem import (
    BEM_EXTRA as BEM_EXTRA,
    BemNotInstalledError as BemNotInstalledError,
    BemRollCoefficients as BemRollCoefficients,
    bem_frequencies as bem_frequencies,
    bem_roll_coefficients as bem_roll_coefficients,
    bem_roll_period as bem_roll_period,
    bem_wave_moment as bem_wave_moment,
    capytaine_missing as capytaine_missing,
)
from ._bem_mesh import (
    BemMesh as BemMesh,
    MeshNotFitError as MeshNotFitError,
    bem_mesh as bem_mesh,
)
from ._equilibrium import (
    Equilibrium as Equilibrium,
    Particulars as Particulars,
    equilibrium as equilibrium,
    gz_curve as gz_curve,
    hydrostatic_particulars as hydrostatic_particulars,
    metacentric_height as metacentric_height,
)
from ._fits import (
    HydrostaticsSolution as HydrostaticsSolution,
    c11_hull_ship as c11_hull_ship,
    default_heel_grid as default_heel_grid,
    default_zeta_grid as default_zeta_grid,
    hull_hydrostatics as hull_hydrostatics,
    roll_period_from_gyradius as roll_period_from_gyradius,
    ship_from_hull as ship_from_hull,
    ship_from_hydrostatics as ship_from_hydrostatics,
)
from ._hull import (
    C11_HULL_NOTE as C11_HULL_NOTE,
    Hull as Hull,
    box_hull as box_hull,
    c11_hull as c11_hull,
    c11_hull_path as c11_hull_path,
    scale_hull as scale_hull,
    wigley_hull as wigley_hull,
)
from ._hydrostatics import (
    Loading as Loading,
    c11_hull_loading as c11_hull_loading,
    loading_condition as loading_condition,
)
from ._ikeda import (
    IKEDA_SOURCE as IKEDA_SOURCE,
    IkedaDamping as IkedaDamping,
    IkedaRangeError as IkedaRangeError,
    ikeda_damping as ikeda_damping,
    simplified_ikeda as simplified_ikeda,
)
from ._restoring import (
    angle_of_maximum_gz as angle_of_maximum_gz,
    backbone_frequency as backbone_frequency,
    delta_gm as delta_gm,
    parametric_excitation as parametric_excitation,
    restoring_moment as restoring_moment,
    restoring_potential as restoring_potential,
    righting_lever as righting_lever,
    vanishing_angle as vanishing_angle,
)
from ._restoring_surface import (
    RestoringSurface as RestoringSurface,
    fit_restoring_surface as fit_restoring_surface,
    gz_in_waves as gz_in_waves,
    in_surface_range as in_surface_range,
)
from ._ship import (
    DEFAULT_SHIP_NOTE as DEFAULT_SHIP_NOTE,
    PLAUSIBLE as PLAUSIBLE,
    Ship as Ship,
    c11_representative as c11_representative,
    max_possible_gm as max_possible_gm,
    restoring_fields_from_gz as restoring_fields_from_gz,
    validate_ship as validate_ship,
)
from ._validity import (
    AVERAGING_LIMIT as AVERAGING_LIMIT,
    excitation_validity as excitation_validity,
    validity_warnings as validity_warnings,
)
from ._wave_moment import (
    WaveMoment as WaveMoment,
    froude_krylov_roll_moment as froude_krylov_roll_moment,
    moment_table as moment_table,
    roll_inertia as roll_inertia,
    ship_file_frequencies as ship_file_frequencies,
    wave_moment as wave_moment,
)
