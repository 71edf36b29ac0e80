"""Maximum-value distributions of per-half-cycle amplitudes, exposure-time risk, and empirical maxima."""

from ._empirical import (
    EmpiricalMaxima as EmpiricalMaxima,
    empirical_maxima as empirical_maxima,
    maxima_of_first as maxima_of_first,
)
from ._maxima import (
    expected_maximum as expected_maximum,
    max_cdf as max_cdf,
    max_logcdf as max_logcdf,
    max_logpdf as max_logpdf,
    max_pdf as max_pdf,
    max_pdf_asymptotic as max_pdf_asymptotic,
    max_quantile as max_quantile,
    max_sf as max_sf,
    most_probable_maximum as most_probable_maximum,
)
from ._risk import (
    ExposureRisk as ExposureRisk,
    count_exceedances as count_exceedances,
    exceedance_probability as exceedance_probability,
    exposure_risk as exposure_risk,
    wilson_interval as wilson_interval,
)
