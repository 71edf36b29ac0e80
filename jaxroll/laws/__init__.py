"""Amplitude laws: the one abstraction every roll-amplitude distribution in jaxroll implements."""

from ._abstract import (
    ESTIMATORS as ESTIMATORS,
    AbstractAmplitudeLaw as AbstractAmplitudeLaw,
    check_estimator as check_estimator,
    require_zero_crossing as require_zero_crossing,
)
from ._closed_form import (
    RayleighLaw as RayleighLaw,
    RobertsLaw as RobertsLaw,
    roberts_logpdf as roberts_logpdf,
)
from ._tabulated import (
    TabulatedAmplitudeLaw as TabulatedAmplitudeLaw,
    law_from_histogram as law_from_histogram,
)
