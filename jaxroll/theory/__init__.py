"""Theories of the stationary roll-amplitude distribution: stochastic averaging and moment equations.

Every theory returns an amplitude law (`jaxroll.AbstractAmplitudeLaw`, radians) of the estimator asked for:
stochastic averaging (Roberts' SAM, energy-based ESAM) in `_averaging.py` with the parametric-excitation spectrum
in `_excitation.py`; the moment method in `_moments.py`.
Coloured-noise averaging (the envelope Fokker–Planck method) in `_envelope_fpk.py`, and the exposure risk from the
first passage of its amplitude (large rolls come in groups) in `_envelope_fpk_passage.py`. `theory_law` and
`theory_summary` (`_named.py`) call any of them by name, each as one compiled program kept between runs.
"""

# --- excitation spectrum S_P and stochastic averaging (Roberts' SAM, ESAM) ---
from ._averaged_law import AveragedAmplitudeLaw as AveragedAmplitudeLaw
from ._averaging import (
    Orbits as Orbits,
    RobertsCoefficients as RobertsCoefficients,
    additive_energy_diffusion as additive_energy_diffusion,
    energy_averaged_pdf as energy_averaged_pdf,
    esam_additive_pdf as esam_additive_pdf,
    esam_pdf as esam_pdf,
    moment_energy_diffusion as moment_energy_diffusion,
    parametric_energy_diffusion as parametric_energy_diffusion,
    roberts_coefficients as roberts_coefficients,
    roberts_log_normaliser as roberts_log_normaliser,
    roberts_pdf as roberts_pdf,
    undamped_orbits as undamped_orbits,
)
from ._envelope_fpk import (  # coloured-noise averaging: the envelope Fokker–Planck method
    envelope_fpk_pdf as envelope_fpk_pdf,
    envelope_lyapunov_exponent as envelope_lyapunov_exponent,
    fit_envelope as fit_envelope,
)
from ._envelope_fpk_law import (
    EnvelopeExcitation as EnvelopeExcitation,
    EnvelopeFPKLaw as EnvelopeFPKLaw,
)
from ._envelope_fpk_passage import (  # exposure risk: first passage of the envelope FPK model's amplitude
    PassageRisk as PassageRisk,
    passage_risk as passage_risk,
    passage_risk_batch as passage_risk_batch,
)
from ._excitation import (
    ParametricSpectrum as ParametricSpectrum,
    hermite_coefficients as hermite_coefficients,
    hermite_covariance as hermite_covariance,
    parametric_spectrum as parametric_spectrum,
    welch_parametric_spectrum as welch_parametric_spectrum,
)
from ._linear import (
    linear_roll_variance as linear_roll_variance,  # the direct wave moment's exact linear roll
    yaw_refusal as yaw_refusal,  # the theories' reason under yaw (jaxroll.Yaw)
)
from ._moment_branch import MomentBranch as MomentBranch, moment_branch as moment_branch

# --- moment equations ---
from ._moment_equations import (
    MomentEquations as MomentEquations,
    PolynomialSDE as PolynomialSDE,
    moment_equations as moment_equations,
    roll_sde as roll_sde,
)
from ._moment_solver import (
    RESULTS as RESULTS,
    StationaryMoments as StationaryMoments,
    stationary_moments as stationary_moments,
)
from ._moments import (
    MomentSolution as MomentSolution,
    envelope_moments as envelope_moments,
    moment_pdf as moment_pdf,
    moment_pdf_first_stable as moment_pdf_first_stable,
    roll_moments as roll_moments,
    sustained_roll_exponent as sustained_roll_exponent,
)
from ._named import (  # the theories by name, each in one compiled program (the command line's entry)
    THEORIES as THEORIES,
    iter_theory_summaries as iter_theory_summaries,
    theory_law as theory_law,
    theory_summary as theory_summary,
)
from ._sensitivity import (  # the theories' design sensitivities (jax.jacfwd), beside the Monte Carlo's
    SENSITIVITY_THEORIES as SENSITIVITY_THEORIES,
    theory_sensitivities as theory_sensitivities,
)
