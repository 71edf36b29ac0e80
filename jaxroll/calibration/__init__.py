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

`calibrated_ship` (`_calibrated_ship`) puts the results into a ship; `_least_squares` holds the shared solver,
results and covariances; `_virtual_tank` writes synthetic records with known truth (`jaxroll tank`).

Uncertainties are Gauss–Newton: covariance = s² (JᵀJ)⁻¹ with s² = RSS/(n − p), or a sandwich where residuals
are correlated (captive: blocks of the records as clusters; roll: a bootstrap over realizations).
"""

from ._calibrated_ship import calibrated_ship as calibrated_ship
from ._captive import (
    CaptiveFit as CaptiveFit,
    CaptiveGroup as CaptiveGroup,
    effective_wave_from_probe as effective_wave_from_probe,
    fit_captive as fit_captive,
)
from ._decay import (
    DecayFit as DecayFit,
    Extremes as Extremes,
    damping_to_extinction as damping_to_extinction,
    decay_agreement as decay_agreement,
    decay_extremes as decay_extremes,
    decay_solution as decay_solution,
    extinction_to_damping as extinction_to_damping,
    fit_decay_ode as fit_decay_ode,
    fit_extinction as fit_extinction,
)
from ._inputs import PAPER_WINDOW_MODEL_S as PAPER_WINDOW_MODEL_S
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
from ._virtual_tank import (
    GivenExcitation as GivenExcitation,
    virtual_captive_record as virtual_captive_record,
    virtual_decay_record as virtual_decay_record,
    virtual_roll_record as virtual_roll_record,
    virtual_sea as virtual_sea,
)
