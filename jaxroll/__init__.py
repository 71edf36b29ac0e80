"""jaxroll: parametric roll of ships in long-crested irregular waves, in JAX.

Pipeline: sea spectrum → Grim's effective wave (superposition or a shaping filter) → ΔGM(ζ_mid) → roll equation
→ Monte Carlo → amplitudes → PDFs, theory, maxima, calibration.

`import jaxroll` changes no global setting of JAX or XLA. Call `jaxroll.configure()` once, first thing after the
imports: it turns on float64 (which jaxroll's statistics, moment equations and tail probabilities need: without it
they raise an error that names this call), asks XLA:CPU for platform-independent math (without which a
realization's float32 arithmetic depends on the batch it is compiled in) and to compile small loops whole (the
time loops of the Monte Carlo, the ODE solvers and the Kalman filter run faster, with the same results), and on a
CPU makes every core a JAX device, so that the Monte Carlo's realizations run on all cores (docs/architecture.md,
"Process-wide settings"). The `jaxroll` command does the same for its own process.
"""

import importlib as _importlib
import sys as _sys
import types as _types
import typing as _typing

from ._config import configure as configure, single_threaded_blas as single_threaded_blas
from ._version import __version__ as __version__

# `import jaxroll` imports JAX and `configure` only: the other names are imported when first used
# (`jaxroll.monte_carlo`, `from jaxroll import ITTC`), so that a command or a script that needs the hull
# hydrostatics does not pay for the Monte Carlo, the theories, the calibration and the libraries under them
# (docs/architecture.md, "Imports on demand"). `_NAMES` is the list; the same imports written out below are for type
# checkers and the documentation (tests/test_architecture.py checks that the two agree). `__all__` is every public
# name; the modules this file uses are imported under private names, so `dir(jaxroll)` lists only those.
if _typing.TYPE_CHECKING:
    from . import criteria as criteria, theory as theory
    from ._compiled import enable_compilation_cache as enable_compilation_cache
    from .calibration import (
        CaptiveFit as CaptiveFit,
        CaptiveGroup as CaptiveGroup,
        DecayFit as DecayFit,
        Estimate as Estimate,
        LeastSquaresInfo as LeastSquaresInfo,
        RollFit as RollFit,
        SeaStateComparison as SeaStateComparison,
        TimeDomainFit as TimeDomainFit,
        calibrated_ship as calibrated_ship,
        decay_agreement as decay_agreement,
        fit_captive as fit_captive,
        fit_decay_ode as fit_decay_ode,
        fit_extinction as fit_extinction,
        fit_roll_kalman as fit_roll_kalman,
        fit_roll_pdf as fit_roll_pdf,
        fit_roll_time_domain as fit_roll_time_domain,
        virtual_captive_record as virtual_captive_record,
        virtual_decay_record as virtual_decay_record,
        virtual_roll_record as virtual_roll_record,
        virtual_sea as virtual_sea,
    )
    from .extremes import (
        EmpiricalMaxima as EmpiricalMaxima,
        ExposureRisk as ExposureRisk,
        count_exceedances as count_exceedances,
        empirical_maxima as empirical_maxima,
        exceedance_probability as exceedance_probability,
        expected_maximum as expected_maximum,
        exposure_risk as exposure_risk,
        max_cdf as max_cdf,
        max_logcdf as max_logcdf,
        max_logpdf as max_logpdf,
        max_pdf as max_pdf,
        max_pdf_asymptotic as max_pdf_asymptotic,
        max_quantile as max_quantile,
        max_sf as max_sf,
        maxima_of_first as maxima_of_first,
        most_probable_maximum as most_probable_maximum,
        wilson_interval as wilson_interval,
    )
    from .io import (
        Record as Record,
        RecordError as RecordError,
        group_by_sea_state as group_by_sea_state,
        load_hull as load_hull,
        load_record as load_record,
        load_records as load_records,
        load_ship as load_ship,
        make_record as make_record,
        record_to_text as record_to_text,
        save_record as save_record,
        ship_from_dict as ship_from_dict,
        ship_to_dict as ship_to_dict,
        ship_to_toml as ship_to_toml,
    )
    from .laws import (
        AbstractAmplitudeLaw as AbstractAmplitudeLaw,
        RayleighLaw as RayleighLaw,
        RobertsLaw as RobertsLaw,
        TabulatedAmplitudeLaw as TabulatedAmplitudeLaw,
        roberts_logpdf as roberts_logpdf,
    )
    from .longterm import (  # the stage's names; `jaxroll.longterm` is the function
        ScatterDiagram as ScatterDiagram,
        ScatterError as ScatterError,
        longterm as longterm,
        longterm_summary as longterm_summary,
        merge_longterm as merge_longterm,
        read_scatter as read_scatter,
        rec34_scatter as rec34_scatter,
    )
    from .notebook import explore as explore  # Jupyter: sliders over the sea state (the `notebook` extra)
    from .roll import (
        DEFAULT_SENSITIVITY_STATISTICS as DEFAULT_SENSITIVITY_STATISTICS,
        SENSITIVITY_PARAMETERS as SENSITIVITY_PARAMETERS,
        AbstractExcitation as AbstractExcitation,
        AbstractObserver as AbstractObserver,
        AmplitudeHistogram as AmplitudeHistogram,
        AmplitudeStatistics as AmplitudeStatistics,
        CapsizeCounts as CapsizeCounts,
        FilterExcitation as FilterExcitation,
        FirstMaxima as FirstMaxima,
        MaximaStatistics as MaximaStatistics,
        MaxRoll as MaxRoll,
        MaxRollStatistics as MaxRollStatistics,
        RealizationEnd as RealizationEnd,
        RollProblem as RollProblem,
        SampledExcitation as SampledExcitation,
        SensitivityResult as SensitivityResult,
        SplittingPilot as SplittingPilot,
        SplittingResult as SplittingResult,
        SuperpositionExcitation as SuperpositionExcitation,
        SweepResult as SweepResult,
        WaveMomentExcitation as WaveMomentExcitation,
        Yaw as Yaw,
        amplitude_samples as amplitude_samples,
        check_time_step as check_time_step,
        default_chunk_size as default_chunk_size,
        default_duration as default_duration,
        default_memory_budget as default_memory_budget,
        envelope_record_every as envelope_record_every,
        hilbert_envelope as hilbert_envelope,
        monte_carlo as monte_carlo,
        monte_carlo_amplitudes as monte_carlo_amplitudes,
        monte_carlo_max_roll as monte_carlo_max_roll,
        monte_carlo_maxima as monte_carlo_maxima,
        monte_carlo_sensitivity as monte_carlo_sensitivity,
        monte_carlo_splitting as monte_carlo_splitting,
        monte_carlo_splitting_angles as monte_carlo_splitting_angles,
        parametric_band as parametric_band,
        realization_mesh as realization_mesh,
        roll_acceleration as roll_acceleration,
        roll_time_series as roll_time_series,
        roll_vector_field as roll_vector_field,
        sensitivity_problem as sensitivity_problem,
        simulate as simulate,
        simulate_chunk as simulate_chunk,
        splitting_pilot as splitting_pilot,
        sweep_sea_states as sweep_sea_states,
        zero_crossing_amplitudes as zero_crossing_amplitudes,
    )
    from .sea import (
        ITTC as ITTC,
        JONSWAP as JONSWAP,
        AbstractWaveSpectrum as AbstractWaveSpectrum,
        EffectiveWave as EffectiveWave,
        FilterFit as FilterFit,
        ShapingFilter as ShapingFilter,
        Spreading as Spreading,
        breaking_steepness as breaking_steepness,
        encounter_frequency as encounter_frequency,
        encounter_spectrum as encounter_spectrum,
        fit_filter as fit_filter,
        fit_filter_in_band as fit_filter_in_band,
        grim_transfer as grim_transfer,
        sea_steepness as sea_steepness,
        spectral_moment as spectral_moment,
        superpose as superpose,
    )
    from .ship import (
        Hull as Hull,
        Ship as Ship,
        WaveMoment as WaveMoment,
        box_hull as box_hull,
        c11_hull as c11_hull,
        c11_hull_ship as c11_hull_ship,
        c11_representative as c11_representative,
        delta_gm as delta_gm,
        equilibrium as equilibrium,
        froude_krylov_roll_moment as froude_krylov_roll_moment,
        gz_curve as gz_curve,
        hull_hydrostatics as hull_hydrostatics,
        hydrostatic_particulars as hydrostatic_particulars,
        loading_condition as loading_condition,
        metacentric_height as metacentric_height,
        parametric_excitation as parametric_excitation,
        restoring_moment as restoring_moment,
        restoring_potential as restoring_potential,
        righting_lever as righting_lever,
        ship_from_hull as ship_from_hull,
        vanishing_angle as vanishing_angle,
        wave_moment as wave_moment,
        wigley_hull as wigley_hull,
    )

_NAMES = {  # subpackage (or private module) -> the names `jaxroll` takes from it
    "_compiled": "enable_compilation_cache",
    "calibration": (
        "CaptiveFit CaptiveGroup DecayFit Estimate LeastSquaresInfo RollFit SeaStateComparison TimeDomainFit "
        "calibrated_ship decay_agreement fit_captive fit_decay_ode fit_extinction fit_roll_kalman "
        "fit_roll_pdf fit_roll_time_domain virtual_captive_record virtual_decay_record virtual_roll_record "
        "virtual_sea"
    ),
    "extremes": (
        "EmpiricalMaxima ExposureRisk count_exceedances empirical_maxima exceedance_probability "
        "expected_maximum exposure_risk max_cdf max_logcdf max_logpdf max_pdf max_pdf_asymptotic max_quantile "
        "max_sf maxima_of_first most_probable_maximum wilson_interval"
    ),
    "io": (
        "Record RecordError group_by_sea_state load_hull load_record load_records load_ship make_record "
        "record_to_text save_record ship_from_dict ship_to_dict ship_to_toml"
    ),
    "laws": "AbstractAmplitudeLaw RayleighLaw RobertsLaw TabulatedAmplitudeLaw roberts_logpdf",
    "longterm": "ScatterDiagram ScatterError longterm longterm_summary merge_longterm read_scatter rec34_scatter",
    "notebook": "explore",
    "roll": (
        "DEFAULT_SENSITIVITY_STATISTICS SENSITIVITY_PARAMETERS AbstractExcitation AbstractObserver "
        "AmplitudeHistogram AmplitudeStatistics CapsizeCounts FilterExcitation FirstMaxima MaximaStatistics "
        "MaxRoll MaxRollStatistics RealizationEnd RollProblem SampledExcitation SensitivityResult "
        "SplittingPilot SplittingResult SuperpositionExcitation SweepResult WaveMomentExcitation amplitude_samples check_time_step "
        "default_chunk_size default_duration default_memory_budget envelope_record_every hilbert_envelope "
        "monte_carlo monte_carlo_amplitudes monte_carlo_max_roll monte_carlo_maxima monte_carlo_sensitivity "
        "monte_carlo_splitting monte_carlo_splitting_angles parametric_band realization_mesh roll_acceleration roll_time_series "
        "roll_vector_field sensitivity_problem simulate simulate_chunk splitting_pilot sweep_sea_states "
        "zero_crossing_amplitudes "
        "Yaw"
    ),
    "sea": (
        "ITTC JONSWAP AbstractWaveSpectrum EffectiveWave FilterFit ShapingFilter Spreading breaking_steepness "
        "encounter_frequency encounter_spectrum fit_filter fit_filter_in_band grim_transfer sea_steepness spectral_moment "
        "superpose"
    ),
    "ship": (
        "Hull Ship WaveMoment box_hull c11_hull c11_hull_ship c11_representative delta_gm equilibrium "
        "froude_krylov_roll_moment gz_curve hull_hydrostatics hydrostatic_particulars loading_condition "
        "metacentric_height parametric_excitation restoring_moment restoring_potential righting_lever "
        "ship_from_hull vanishing_angle wave_moment wigley_hull"
    ),
}
_LAZY = {name: module for module, names in _NAMES.items() for name in names.split()}
_SUBPACKAGES = ("calibration", "criteria", "extremes", "io", "laws", "longterm", "notebook", "plotting", "roll",
                "sea", "ship", "theory")  # fmt: skip


def __getattr__(name: str):
    """A name of `_NAMES` or a subpackage, imported on first use (a module's `__getattr__`, PEP 562)."""
    if name in _LAZY:
        value = getattr(_importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    elif name in _SUBPACKAGES:
        value = _importlib.import_module(f"{__name__}.{name}")
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


__all__ = sorted({"configure", "single_threaded_blas", *_LAZY, *_SUBPACKAGES})


def __dir__() -> list[str]:
    return [*__all__, "__version__"]


class _Package(_types.ModuleType):
    """`jaxroll` itself: `jaxroll.longterm` stays the function when the subpackage of that name is imported (the
    import system sets a subpackage as its parent's attribute once it has run)."""

    def __setattr__(self, name: str, value) -> None:
        if name == "longterm" and isinstance(value, _types.ModuleType):
            value = value.longterm
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package
