"""The units and long names of risk.json's first-passage and splitting fields (`_layouts.RISK`)."""

_STAGE = ("splitting_stage",)
FIRST_PASSAGE_UNITS = {
    "first_passage_capsize_probability": "1",
    "first_passage_clusters_per_hour": "h-1",
    "first_passage_amplitudes_per_cluster": "1",
    "first_passage_extremal_index": "1",
    "first_passage_start_exceedance": "1",
    "first_passage_independent_probability": "1",
    "first_passage_lyapunov_exponent_per_s": "s-1",
    "first_passage_exists": "1",
    "first_passage_model_allowance_*": "1",
}
FIRST_PASSAGE_LONG_NAMES = {
    "first_passage_probability": "P(max |φ| > angle within the exposure): the envelope FPK model followed through "
    "the exposure (large rolls in groups)",
    "first_passage_capsize_probability": "P(capsize within the exposure) of the envelope FPK model",
    "first_passage_clusters_per_hour": "groups of large rolls (first passages once the start is forgotten) per hour",
    "first_passage_amplitudes_per_cluster": "mean number of amplitudes above the angle per group (1/θ)",
    "first_passage_extremal_index": "extremal index θ = cluster rate / (amplitude rate × F̄)",
    "first_passage_mean_passage_time_s": "mean time to the first peak above the angle",
    "first_passage_start_exceedance": "probability of being above the angle when the exposure starts",
    "first_passage_independent_probability": "the same model's amplitudes taken as independent",
    "first_passage_lyapunov_exponent_per_s": "Lyapunov exponent of the linearised roll (growth rate of ln A)",
    "first_passage_exists": "sustained parametric roll (Lyapunov exponent > 0; 1: yes)",
    "first_passage_model_allowance_probability_range": "where the exact-spectrum value lies, by the theory's "
    "allowance measured in this sea state's region (docs/validation.md)",
    "first_passage_model_allowance_f_below": "measured factor below: P_exact >= P / f_below",
    "first_passage_model_allowance_f_above": "measured factor above: P_exact <= f_above P",
    "first_passage_model_allowance_outside_validated_map": "the sea state is outside the validated map (1: yes)",
}
SPLITTING_UNITS = {
    "splitting_standard_error": "1",
    "splitting_capsize_standard_error": "1",
    "splitting_relative_error": "1",
    "splitting_relative_variance_independent": "1",
    "splitting_effective_ancestors": "1",
    "splitting_conditional_probabilities": "1",
    "splitting_simulated_seconds": "s",
    "splitting_pilot_simulated_seconds": "s",
    "splitting_lane_seconds": "s",
    "splitting_total_simulated_seconds": "s",
    "splitting_stage_simulated_seconds": "s",
    "splitting_continuation_simulated_seconds": "s",
}
SPLITTING_LONG_NAMES = {
    "splitting_probability": "P(max |φ| > angle within the exposure, or a capsize): multilevel splitting",
    "splitting_standard_error": "standard error of the splitting estimate (genealogy estimator)",
    "splitting_levels_deg": "splitting levels of the score (the last is the angle itself)",
    "splitting_conditional_probabilities": "fraction of each stage's runs that reached the next level",
    "splitting_n_successes": "runs of each stage that reached the next level",
    "splitting_effective_ancestors": "effective number of independent stage-0 ancestors of the successes "
    "(S²/Σ c_e²): the degrees of freedom of the interval, plus 1",
    "splitting_simulated_seconds": "simulated realization-seconds of the estimate",
    "splitting_total_simulated_seconds": "simulated realization-seconds, the pilot included",
    "splitting_continuation_simulated_seconds": "realization-seconds of the runs continued after the last stage",
}
