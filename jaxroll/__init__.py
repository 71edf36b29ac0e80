"""jaxroll: parametric roll of ships in long-crested irregular waves, in JAX.

Pipeline: sea spectrum → Grim's effective wave (superposition or a shaping filter) → ΔGM(ζ_mid) → roll equation
→ Monte Carlo → amplitudes → PDFs, theory, maxima, calibration.

jaxroll enables float64 in JAX on import: its statistics, moment equations and tail probabilities need it.
"""

import importlib.metadata

import jax

jax.config.update("jax_enable_x64", True)

from . import theory as theory
from ._amplitudes import (
    hilbert_envelope as hilbert_envelope,
)
from ._amplitudes import (
    zero_crossing_amplitudes as zero_crossing_amplitudes,
)
from ._calibration import (
    calibrated_ship as calibrated_ship,
)
from ._calibration import (
    fit_captive as fit_captive,
)
from ._calibration import (
    fit_decay_ode as fit_decay_ode,
)
from ._calibration import (
    fit_extinction as fit_extinction,
)
from ._calibration import (
    fit_roll_pdf as fit_roll_pdf,
)
from ._dynamics import (
    FilterExcitation as FilterExcitation,
)
from ._dynamics import (
    RollProblem as RollProblem,
)
from ._dynamics import (
    SampledExcitation as SampledExcitation,
)
from ._dynamics import (
    SuperpositionExcitation as SuperpositionExcitation,
)
from ._dynamics import (
    roll_acceleration as roll_acceleration,
)
from ._dynamics import (
    roll_time_series as roll_time_series,
)
from ._dynamics import (
    roll_vector_field as roll_vector_field,
)
from ._extremes import (
    AmplitudeDistribution as AmplitudeDistribution,
)
from ._extremes import (
    ExposureRisk as ExposureRisk,
)
from ._extremes import (
    RayleighAmplitudes as RayleighAmplitudes,
)
from ._extremes import (
    RobertsAmplitudes as RobertsAmplitudes,
)
from ._extremes import (
    empirical_maxima as empirical_maxima,
)
from ._extremes import (
    expected_maximum as expected_maximum,
)
from ._extremes import (
    exposure_risk as exposure_risk,
)
from ._extremes import (
    max_cdf as max_cdf,
)
from ._extremes import (
    max_pdf as max_pdf,
)
from ._extremes import (
    max_pdf_asymptotic as max_pdf_asymptotic,
)
from ._extremes import (
    max_quantile as max_quantile,
)
from ._extremes import (
    most_probable_maximum as most_probable_maximum,
)
from ._filters import FilterFit as FilterFit
from ._filters import ShapingFilter as ShapingFilter
from ._filters import fit_filter as fit_filter
from ._grim import EffectiveWave as EffectiveWave
from ._grim import grim_transfer as grim_transfer
from ._grim import superpose as superpose
from ._hydrostatics import (
    Hull as Hull,
)
from ._hydrostatics import (
    box_hull as box_hull,
)
from ._hydrostatics import (
    c11_hull as c11_hull,
)
from ._hydrostatics import (
    c11_hull_ship as c11_hull_ship,
)
from ._hydrostatics import (
    equilibrium as equilibrium,
)
from ._hydrostatics import (
    gz_curve as gz_curve,
)
from ._hydrostatics import (
    hull_hydrostatics as hull_hydrostatics,
)
from ._hydrostatics import (
    hydrostatic_particulars as hydrostatic_particulars,
)
from ._hydrostatics import (
    load_hull as load_hull,
)
from ._hydrostatics import (
    loading_condition as loading_condition,
)
from ._hydrostatics import (
    metacentric_height as metacentric_height,
)
from ._hydrostatics import (
    ship_from_hull as ship_from_hull,
)
from ._hydrostatics import (
    wigley_hull as wigley_hull,
)
from ._maxima import MaximaStatistics as MaximaStatistics
from ._maxima import monte_carlo_maxima as monte_carlo_maxima
from ._monte_carlo import (
    AmplitudeStatistics as AmplitudeStatistics,
)
from ._monte_carlo import (
    check_time_step as check_time_step,
)
from ._monte_carlo import (
    make_problem as make_problem,
)
from ._monte_carlo import (
    monte_carlo_amplitudes as monte_carlo_amplitudes,
)
from ._records import (
    Record as Record,
)
from ._records import (
    RecordError as RecordError,
)
from ._records import (
    load_record as load_record,
)
from ._records import (
    load_records as load_records,
)
from ._records import (
    save_record as save_record,
)
from ._restoring import (
    delta_gm as delta_gm,
)
from ._restoring import (
    parametric_excitation as parametric_excitation,
)
from ._restoring import (
    restoring_moment as restoring_moment,
)
from ._restoring import (
    righting_lever as righting_lever,
)
from ._restoring import (
    vanishing_angle as vanishing_angle,
)
from ._ship import (
    Ship as Ship,
)
from ._ship import (
    c11_representative as c11_representative,
)
from ._ship import (
    load_ship as load_ship,
)
from ._ship import (
    ship_from_dict as ship_from_dict,
)
from ._ship import (
    ship_to_dict as ship_to_dict,
)
from ._ship import (
    ship_to_toml as ship_to_toml,
)
from ._spectra import (
    ITTC as ITTC,
)
from ._spectra import (
    JONSWAP as JONSWAP,
)
from ._spectra import (
    AbstractWaveSpectrum as AbstractWaveSpectrum,
)
from ._spectra import (
    encounter_frequency as encounter_frequency,
)
from ._spectra import (
    encounter_spectrum as encounter_spectrum,
)
from ._spectra import (
    spectral_moment as spectral_moment,
)
from ._sweep import monte_carlo_max_roll as monte_carlo_max_roll
from ._sweep import sweep_sea_states as sweep_sea_states

try:
    __version__ = importlib.metadata.version("jaxroll")
except importlib.metadata.PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"
