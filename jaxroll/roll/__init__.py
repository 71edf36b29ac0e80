"""The roll equation, its excitation, amplitude estimators, observers and the Monte Carlo."""

from ._amplitudes import (
    amplitude_samples as amplitude_samples,
    hilbert_envelope as hilbert_envelope,
    zero_crossing_amplitudes as zero_crossing_amplitudes,
)
from ._equation import (
    RealizationEnd as RealizationEnd,
    RollProblem as RollProblem,
    check_time_step as check_time_step,
    forcing_series as forcing_series,
    parametric_band as parametric_band,
    roll_acceleration as roll_acceleration,
    roll_time_series as roll_time_series,
    roll_vector_field as roll_vector_field,
    simulate as simulate,
)
from ._excitation import (
    AbstractExcitation as AbstractExcitation,
    FilterExcitation as FilterExcitation,
    SampledExcitation as SampledExcitation,
    SuperpositionExcitation as SuperpositionExcitation,
    WaveMomentExcitation as WaveMomentExcitation,
)
from ._monte_carlo import (
    default_duration as default_duration,
    monte_carlo as monte_carlo,
    monte_carlo_amplitudes as monte_carlo_amplitudes,
    monte_carlo_max_roll as monte_carlo_max_roll,
    monte_carlo_maxima as monte_carlo_maxima,
    simulate_chunk as simulate_chunk,
)
from ._observers import (
    AbstractObserver as AbstractObserver,
    AmplitudeHistogram as AmplitudeHistogram,
    FirstMaxima as FirstMaxima,
    MaxRoll as MaxRoll,
    envelope_record_every as envelope_record_every,
)
from ._sensitivity import (
    monte_carlo_sensitivity as monte_carlo_sensitivity,
    sensitivity_problem as sensitivity_problem,
)
from ._sensitivity_result import (
    DEFAULT_SENSITIVITY_STATISTICS as DEFAULT_SENSITIVITY_STATISTICS,
    SENSITIVITY_PARAMETERS as SENSITIVITY_PARAMETERS,
    SensitivityResult as SensitivityResult,
)
from ._sharding import (
    default_chunk_size as default_chunk_size,
    default_memory_budget as default_memory_budget,
    realization_mesh as realization_mesh,
)
from ._splitting import (
    DEFAULT_WAVE_WEIGHT as DEFAULT_WAVE_WEIGHT,
    SPLITTING_EXCITATIONS as SPLITTING_EXCITATIONS,
    monte_carlo_splitting as monte_carlo_splitting,
    monte_carlo_splitting_angles as monte_carlo_splitting_angles,
    splitting_pilot as splitting_pilot,
)
from ._splitting_result import SplittingPilot as SplittingPilot, SplittingResult as SplittingResult
from ._statistics import (
    AmplitudeStatistics as AmplitudeStatistics,
    CapsizeCounts as CapsizeCounts,
    MaximaStatistics as MaximaStatistics,
    MaxRollStatistics as MaxRollStatistics,
    SweepResult as SweepResult,
)
from ._sweep import sweep_sea_states as sweep_sea_states
from ._yaw import Yaw as Yaw
