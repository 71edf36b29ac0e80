"""jaxroll: parametric roll of ships in long-crested irregular waves, in JAX.

Pipeline: sea spectrum → Grim's effective wave (superposition or a shaping filter) → ΔGM(ζ_mid) → roll equation
→ Monte Carlo → amplitudes → PDFs, theory, maxima, calibration.

jaxroll enables float64 in JAX on import: its statistics, moment equations and tail probabilities need it.
"""

import importlib.metadata

import jax

jax.config.update("jax_enable_x64", True)

from . import theory as theory
from .roll._amplitudes import (
    hilbert_envelope as hilbert_envelope,
    zero_crossing_amplitudes as zero_crossing_amplitudes,
)
from .calibration._calibration import (
    calibrated_ship as calibrated_ship,
    fit_captive as fit_captive,
    fit_decay_ode as fit_decay_ode,
    fit_extinction as fit_extinction,
    fit_roll_pdf as fit_roll_pdf,
)
from .roll._equation import (
    FilterExcitation as FilterExcitation,
    RollProblem as RollProblem,
    SampledExcitation as SampledExcitation,
    SuperpositionExcitation as SuperpositionExcitation,
    roll_acceleration as roll_acceleration,
    roll_time_series as roll_time_series,
    roll_vector_field as roll_vector_field,
)
from .extremes._maxima import (
    AmplitudeDistribution as AmplitudeDistribution,
    ExposureRisk as ExposureRisk,
    RayleighAmplitudes as RayleighAmplitudes,
    RobertsAmplitudes as RobertsAmplitudes,
    empirical_maxima as empirical_maxima,
    expected_maximum as expected_maximum,
    exposure_risk as exposure_risk,
    max_cdf as max_cdf,
    max_pdf as max_pdf,
    max_pdf_asymptotic as max_pdf_asymptotic,
    max_quantile as max_quantile,
    most_probable_maximum as most_probable_maximum,
)
from .sea._filters import FilterFit as FilterFit, ShapingFilter as ShapingFilter, fit_filter as fit_filter
from .sea._grim import EffectiveWave as EffectiveWave, grim_transfer as grim_transfer, superpose as superpose
from .ship._hydrostatics import (
    Hull as Hull,
    box_hull as box_hull,
    c11_hull as c11_hull,
    c11_hull_ship as c11_hull_ship,
    equilibrium as equilibrium,
    gz_curve as gz_curve,
    hull_hydrostatics as hull_hydrostatics,
    hydrostatic_particulars as hydrostatic_particulars,
    load_hull as load_hull,
    loading_condition as loading_condition,
    metacentric_height as metacentric_height,
    ship_from_hull as ship_from_hull,
    wigley_hull as wigley_hull,
)
from .roll._maxima import MaximaStatistics as MaximaStatistics, monte_carlo_maxima as monte_carlo_maxima
from .roll._monte_carlo import (
    AmplitudeStatistics as AmplitudeStatistics,
    check_time_step as check_time_step,
    make_problem as make_problem,
    monte_carlo_amplitudes as monte_carlo_amplitudes,
)
from .io._records import (
    Record as Record,
    RecordError as RecordError,
    load_record as load_record,
    load_records as load_records,
    save_record as save_record,
)
from .ship._restoring import (
    delta_gm as delta_gm,
    parametric_excitation as parametric_excitation,
    restoring_moment as restoring_moment,
    righting_lever as righting_lever,
    vanishing_angle as vanishing_angle,
)
from .ship._ship import (
    Ship as Ship,
    c11_representative as c11_representative,
    load_ship as load_ship,
    ship_from_dict as ship_from_dict,
    ship_to_dict as ship_to_dict,
    ship_to_toml as ship_to_toml,
)
from .sea._spectra import (
    ITTC as ITTC,
    JONSWAP as JONSWAP,
    AbstractWaveSpectrum as AbstractWaveSpectrum,
    encounter_frequency as encounter_frequency,
    encounter_spectrum as encounter_spectrum,
    spectral_moment as spectral_moment,
)
from .roll._sweep import monte_carlo_max_roll as monte_carlo_max_roll, sweep_sea_states as sweep_sea_states

try:
    __version__ = importlib.metadata.version("jaxroll")
except importlib.metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"
