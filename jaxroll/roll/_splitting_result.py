"""What a multilevel splitting run estimates and how sure it is: the genealogy variance of the estimate (Lee and
Whiteley), its log-normal 95 % interval, and `SplittingResult` (the estimate, its stages, its cost)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


def genealogy_relative_variance(eves, num: int, num_stages: int) -> float:
    """Estimated relative variance Var(P̂)/P̂² of a fixed-effort splitting estimate from its genealogy (Lee &
    Whiteley 2018, for an indicator test function): 1 − (N/(N−1))^K (1 − Σ_e c_e²/S²), where c_e is
    the number of the last stage's successes descending from stage-0 run e, S = Σ c_e, N runs a stage and K stages
    (K − 1 multinomial resamplings). Unbiased for Var(P̂) once multiplied by P̂²; one stage gives the binomial
    (1 − p̂)/((N − 1) p̂). 0 when S = 0. [-]"""
    if np.size(eves) == 0:
        return 0.0
    return 1.0 - (num / (num - 1)) ** num_stages * (1.0 - _concentration(eves))


def effective_ancestors(eves) -> float:
    """The effective number of independent stage-0 ancestors of the last stage's successes, S²/Σ_e c_e² [-]
    (c_e as in `genealogy_relative_variance`; 0 when S = 0): the number of independent clusters the genealogy
    variance is in effect estimated from."""
    return 0.0 if np.size(eves) == 0 else 1.0 / _concentration(eves)


def _concentration(eves) -> float:
    """Σ_e c_e²/S² of a non-empty genealogy (`eves`: the stage-0 ancestor of each of the S successes)."""
    eves = np.asarray(eves)
    counts = np.bincount(eves).astype(float)
    return float(np.sum(counts**2)) / eves.size**2


def _interval(estimate: float, relative_variance: float, upper_if_zero: float, ancestors: float = math.inf):
    """95 % interval: log-normal, estimate · exp(±q σ), σ² = log(1 + v) (the estimate is a product of stage
    fractions, skewed to the right). The variance is in effect estimated from G = `ancestors` clusters (the
    families of the stage-0 ancestors), so, as a cluster-robust variance with few clusters: v = the relative
    variance × G/(G − 1) and q = Student's t quantile with G − 1 degrees of freedom (at least 1); G infinite: v the
    relative variance, q = 1.96. docs/rare_events.md, "Variance and interval". The upper end at most 1 (one or two
    effective ancestors make q large). [0, upper_if_zero] when the estimate is 0."""
    if estimate <= 0:
        return 0.0, upper_if_zero
    v, q = max(relative_variance, 0.0), 1.959963984540054
    if math.isfinite(ancestors):
        dof = max(ancestors - 1.0, 1.0)
        v, q = v * ancestors / dof, _t_quantile(dof)
    sigma = math.sqrt(math.log1p(v))
    return estimate * math.exp(-q * sigma), min(estimate * math.exp(q * sigma), 1.0)  # (a probability: ≤ 1)


def _t_quantile(dof: float) -> float:
    """Student's t 0.975 quantile for `dof` (real, ≥ 1) degrees of freedom."""
    from scipy.stats import t  # jax's own dependency; imported here, where an interval is asked for

    return float(t.ppf(0.975, dof))


@dataclass
class SplittingResult:
    """A rare exceedance probability by multilevel splitting (`monte_carlo_splitting`); host values.

    - `probability`: P̂(max |φ| > `angle_deg` within the exposure after the discard, or capsize) [-];
      `standard_error` [-] (Lee–Whiteley genealogy estimator); `probability_ci95` [-] (log-normal, Student's t with
      `effective_ancestors` − 1 degrees of freedom; docs/rare_events.md).
    - `levels_deg`: the stages' levels [deg], the scores ℓ_1 < … < ℓ_{K−1} (â + κ·ê, so they may pass the
      angle) and `angle_deg` last (the last stage's target is the event itself);
      `conditional_probabilities` p̂_k and `n_successes` per stage (NaN and 0 for stages never run: a stage in which
      no run reached its level ends the estimate at 0).
    - `capsize_probability`, `capsize_standard_error` [-]: P̂(capsize within the duration), from the same runs:
      the last stage's successful runs continued to the end of the exposure with their own noise (as if they had
      not stopped at the event); `n_capsized`: those that capsized; `n_exceeded`: the runs of the angle's event
      stage that reached it; `n_ancestors`: the distinct stage-0 runs these descend from; `effective_ancestors`:
      S²/Σ c_e², their effective number (`effective_ancestors`).
    - `relative_variance_independent`: Σ (1 − p̂_k)/(N p̂_k), what the stages would give were they independent
      (the genealogy's variance divided by this measures the clones' correlation).
    - Cost: `simulated_seconds` [s] realization-seconds simulated by the estimate's stages (`stage_simulated_seconds`
      per stage) and the continuation of the last stage's successful runs for the capsizes
      (`continuation_simulated_seconds`), `pilot_simulated_seconds` by the pilot run; `lane_seconds` what the lanes of the compiled
      pools ran, idle ones included; `wall_time_s`, `stage_wall_time_s`, `pilot_wall_time_s` [s].
    - `config`: the run's settings.
    """

    probability: float
    standard_error: float
    probability_ci95: tuple[float, float]
    angle_deg: float
    levels_deg: np.ndarray
    conditional_probabilities: np.ndarray
    n_successes: np.ndarray
    num_trials: int
    capsize_probability: float
    capsize_standard_error: float
    n_capsized: int
    n_exceeded: int
    n_ancestors: int
    effective_ancestors: float
    relative_variance_independent: float
    simulated_seconds: float
    pilot_simulated_seconds: float
    lane_seconds: float
    stage_simulated_seconds: np.ndarray
    stage_wall_time_s: np.ndarray
    pilot_wall_time_s: float
    wall_time_s: float
    continuation_simulated_seconds: float = 0.0
    config: dict = field(default_factory=dict)

    @property
    def relative_error(self) -> float:
        """standard_error / probability [-] (inf when the estimate is 0)."""
        return self.standard_error / self.probability if self.probability > 0 else math.inf

    @property
    def total_simulated_seconds(self) -> float:
        """Realization-seconds of the estimate and its pilot together [s]: the cost to compare with brute force."""
        return self.simulated_seconds + self.pilot_simulated_seconds

    def to_dict(self) -> dict:
        """JSON-ready summary (lists and floats)."""
        out = {}
        for name in self.__dataclass_fields__:
            v = getattr(self, name)
            out[name] = v.tolist() if isinstance(v, np.ndarray) else list(v) if isinstance(v, tuple) else v
        out["relative_error"] = self.relative_error
        out["total_simulated_seconds"] = self.total_simulated_seconds
        return out


@dataclass
class SplittingPilot:
    """The pilot run of a splitting estimate (`splitting_pilot`): the levels it set and what it cost; host values.

    - `angles_deg` [deg]; `levels_deg`: per angle, the score levels [deg] climbed before its event (as the run
      compares them: rounded to its floating type);
    - `probability` [-]: per angle, the pilot's own product of stage fractions — a rough estimate, biased by the
      levels it chose from the same runs: to screen with, not to report;
    - `pilot_trials`: runs a stage; `capped`: `max_levels` stopped it before a stage reached an event;
      `num_runs`: the stage runs it made;
    - cost: `simulated_seconds` [s] (realization-seconds), `lane_seconds` [s], `wall_time_s` [s]; `config`.
    """

    angles_deg: np.ndarray
    levels_deg: tuple[tuple[float, ...], ...]
    probability: np.ndarray
    pilot_trials: int
    capped: bool
    simulated_seconds: float
    lane_seconds: float
    num_runs: int
    wall_time_s: float
    config: dict = field(default_factory=dict)
