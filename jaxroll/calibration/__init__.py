"""Calibration of the roll model straight from tank records, by least squares with optimistix (formulas:
docs/calibration.md).

1. **Decay** (`_decay`: free-roll decay records → b1, b2, b3): `fit_extinction` (the extinction curve, converted
   by energy balance) and `fit_decay_ode` (the roll equation integrated with diffrax and fitted to the whole
   time series).
2. **Captive** (`_captive`: `fit_captive`): ΔGM measured at fixed heel against ΔGM from Grim's effective wave of
   the measured wave (`effective_wave_from_probe`): the paper's σ_obs/σ_thr, a least-squares scale factor,
   and optionally the polynomial itself.
3. **Free-running roll** (`_roll_pdf`: `fit_roll_pdf`): damping and/or the GM correction such that the model's
   amplitude distributions match the experimental zero-crossing and envelope distributions.
4. **Free-running roll in the time domain** (`_time_domain`: `fit_roll_time_domain`, multiple shooting through
   the project's integrator driven by the probe's effective wave; `_kalman`: `fit_roll_kalman`, the
   extended-Kalman-filter likelihood with fitted process noise, for records with model error); results in
   `_time_domain_results` (`TimeDomainFit`, identifiability).

`calibrated_ship` (`_calibrated_ship`) puts the results into a ship; `_least_squares` holds the shared solver,
results and covariances; `_virtual_tank` writes synthetic records with known truth (`jaxroll tank`).

Uncertainties are Gauss–Newton: covariance = s² (JᵀJ)⁻¹ with s² = RSS/(n − p), or a sandwich where residuals
are correlated (captive: blocks of the records as clusters; roll: a bootstrap over realizations).
"""

from ._calibrated_ship import (
    calibrated_ship as calibrated_ship,
    nonnegative_damping as nonnegative_damping,
)
from ._captive import (
    CaptiveFit as CaptiveFit,
    CaptiveGroup as CaptiveGroup,
    effective_wave_from_probe as effective_wave_from_probe,
    fit_captive as fit_captive,
)
from ._decay import (
    Extremes as Extremes,
    damping_to_extinction as damping_to_extinction,
    decay_agreement as decay_agreement,
    decay_extremes as decay_extremes,
    decay_solution as decay_solution,
    extinction_to_damping as extinction_to_damping,
    fit_decay_ode as fit_decay_ode,
    fit_extinction as fit_extinction,
)
from ._decay_inputs import (
    DecaySegment as DecaySegment,
    decay_segment as decay_segment,
    find_release as find_release,
)
from ._decay_results import (
    DAMPING_MODELS as DAMPING_MODELS,
    DecayFit as DecayFit,
)
from ._inputs import (
    PAPER_WINDOW_MODEL_S as PAPER_WINDOW_MODEL_S,
    check_wave_heights as check_wave_heights,
)
from ._kalman import fit_roll_kalman as fit_roll_kalman
from ._least_squares import (
    Estimate as Estimate,
    LeastSquaresInfo as LeastSquaresInfo,
)
from ._roll_pdf import (
    DEFAULT_BANDS as DEFAULT_BANDS,
    ESTIMATORS as ESTIMATORS,
    RollFit as RollFit,
    SeaStateComparison as SeaStateComparison,
    band_means as band_means,
    fit_roll_pdf as fit_roll_pdf,
)
from ._time_domain import (
    TIME_DOMAIN_PARAMETERS as TIME_DOMAIN_PARAMETERS,
    check_time_domain_inputs as check_time_domain_inputs,
    check_time_domain_params as check_time_domain_params,
    default_window as default_window,
    effective_wave_on_grid as effective_wave_on_grid,
    fit_roll_time_domain as fit_roll_time_domain,
)
from ._time_domain_results import (
    Identifiability as Identifiability,
    ParameterEstimate as ParameterEstimate,
    RecordDiagnostics as RecordDiagnostics,
    TimeDomainFit as TimeDomainFit,
)
from ._virtual_tank import (
    virtual_captive_record as virtual_captive_record,
    virtual_decay_record as virtual_decay_record,
    virtual_roll_record as virtual_roll_record,
    virtual_sea as virtual_sea,
    write_lab_file as write_lab_file,
)
