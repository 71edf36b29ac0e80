"""The sea: wave spectra, directional spreading, Grim's effective wave, the shaping filter (Method 2)."""

from ._filters import (
    BAND_TOLERANCE as BAND_TOLERANCE,
    MAX_FILTER_ORDER as MAX_FILTER_ORDER,
    FilterFit as FilterFit,
    ShapingFilter as ShapingFilter,
    band_error as band_error,
    check_filter_fit as check_filter_fit,
    fit_filter as fit_filter,
    fit_filter_in_band as fit_filter_in_band,
)
from ._grim import (
    EffectiveWave as EffectiveWave,
    grim_transfer as grim_transfer,
    superpose as superpose,
)
from ._spectra import (
    ITTC as ITTC,
    JONSWAP as JONSWAP,
    AbstractWaveSpectrum as AbstractWaveSpectrum,
    breaking_steepness as breaking_steepness,
    encounter_frequency as encounter_frequency,
    encounter_spectrum as encounter_spectrum,
    sea_steepness as sea_steepness,
    spectral_moment as spectral_moment,
)
from ._spreading import (
    Spreading as Spreading,
    parse_spreading as parse_spreading,
)
