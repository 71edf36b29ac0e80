"""The layout of every labelled result: which JSON levels are dimensions, the arrays' dimensions, the units the
names do not state; one place for all outputs (docs/outputs.md lists what they give). Each layout covers one JSON
shape: a result's summary (`AMPLITUDES`: `AmplitudeStatistics.summary`, …) or a command's JSON file
(`OUTPUTS["pdf"]`: pdf.json, …), the latter built from the former.
"""

from __future__ import annotations

from ._layouts_risk import (
    _STAGE,
    FIRST_PASSAGE_LONG_NAMES,
    FIRST_PASSAGE_UNITS,
    SPLITTING_LONG_NAMES,
    SPLITTING_UNITS,
)
from ._tree import Layout

PERCENTILE = {"percentile": ("percent", "quantile level (the JSON keys 50, 90, 99: percent)")}

# --------------------------------------------------------------------------------------------------------------
# The ship's coefficients (ship_to_dict, the ship file's tables)
# --------------------------------------------------------------------------------------------------------------

# A ship file's `[wave_moment]` table (docs/ship_file.md), in every output that writes the ship
_WAVE_MOMENT = ("wave_moment_heading_rad", "wave_moment_omega_rad_s")
SHIP = Layout(
    arrays={
        "ship/wave_moment/omega_rad_s": _WAVE_MOMENT[1:],
        "ship/wave_moment/heading_rad": _WAVE_MOMENT[:1],
        "ship/wave_moment/moment_real_N": _WAVE_MOMENT,
        "ship/wave_moment/moment_imag_N": _WAVE_MOMENT,
        "ship/wave_moment/added_inertia_kg_m2": _WAVE_MOMENT[1:],
        "ship/wave_moment/radiation_damping_N_m_s": _WAVE_MOMENT[1:],
    },
    names={
        "ship/wave_moment/omega_rad_s": "wave_moment_omega_rad_s",
        "ship/wave_moment/heading_rad": "wave_moment_heading_rad",
    },
    units={
        "*moment_real_N": "N",
        "*moment_imag_N": "N",
        "*added_inertia_kg_m2": "kg m2",
        "*radiation_damping_N_m_s": "N m s rad-1",
        "*inertia_at_roll_frequency_kg_m2": "kg m2",
        "*roll_inertia_kg_m2": "kg m2",
        "*dry_inertia_kg_m2": "kg m2",
        "*damping_at_roll_frequency_N_m_s": "N m s rad-1",
        "*restoring_a3": "s-2 rad-2",
        "*restoring_a5": "s-2 rad-4",
        "*restoring_a7": "s-2 rad-6",
        "*restoring_a9": "s-2 rad-8",
        "*damping_b1": "s-1",
        "*damping_b2": "rad-1",
        "*damping_b3": "s rad-2",
        "*delta_gm_c0": "m",
        "*delta_gm_c1": "1",
        "*delta_gm_c2": "m-1",
        "*delta_gm_c3": "m-2",
        "*delta_gm_c4": "m-3",
        "*delta_gm_c5": "m-4",
        "*delta_gm_c6": "m-5",
        "*correction_gm_ratio": "1",
    },
    long_names={
        "wave_moment_omega_rad_s": "wave frequency ω of the wave-moment table",
        "wave_moment_heading_rad": "heading χ of the wave-moment table (0 following, π/2 beam, π head)",
        "*moment_real_N": "real part of the wave roll moment F(ω, χ) about G per m of wave amplitude",
        "*moment_imag_N": "imaginary part of the wave roll moment F(ω, χ) about G per m of wave amplitude",
        "*added_inertia_kg_m2": "added roll inertia A44(ω) about G",
        "*radiation_damping_N_m_s": "roll radiation damping B44(ω) about G",
        "*restoring_a3": "restoring coefficient a3 (a1 = ω0²)",
        "*damping_b1": "linear roll damping b1",
        "*damping_b2": "quadratic roll damping b2",
        "*damping_b3": "cubic roll damping b3",
        "*correction_gm_ratio": "GM-variation correction σ_obs/σ_thr",
    },
    # the GZ surface's table of coefficients (rows: φ³, φ⁵, …; columns: ζ¹, ζ², …) as JSON text: each has its unit
    text=("ship/restoring_surface/coefficients", "*/ship/restoring_surface/coefficients"),
)

# --------------------------------------------------------------------------------------------------------------
# Monte Carlo amplitude statistics (AmplitudeStatistics.summary: pdf.json's top level)
# --------------------------------------------------------------------------------------------------------------

STATIONARITY_UNITS = {"*change_in_standard_errors": "1", "*mass_beyond_grid": "1"}

AMPLITUDES = Layout(
    labels={
        "n_amplitudes": "estimator",
        "mean_amplitude_deg": "estimator",
        "quantiles_deg": "estimator",
        "quantiles_deg/*": "percentile",
        "mass_beyond_grid": "estimator",
        "amplitude_sampling": "estimator",
    },
    arrays={
        "bins_deg": ("bins_deg",),
        "pdf_zero_crossing": ("amplitude_deg",),
        "pdf_envelope": ("amplitude_deg",),
    },
    centres={"amplitude_deg": "bins_deg"},
    units={
        "pdf_zero_crossing": "degree-1",
        "pdf_envelope": "degree-1",
        "roll_moments_E_phi2": "rad2",
        "roll_moments_E_phi4": "rad4",
        **STATIONARITY_UNITS,
    },
    long_names={"bins_deg": "bin edges of the amplitude PDFs"},
    coords={**PERCENTILE, "bins_deg": ("degree", "bin edges of the amplitude PDFs")},
)

# --------------------------------------------------------------------------------------------------------------
# Theories: law summaries with their details (AveragedAmplitudeLaw, MomentSolution, EnvelopeFPKLaw .details())
# --------------------------------------------------------------------------------------------------------------

THEORY_UNITS = {
    "*parameters_nu": "1",
    "*parameters_c2": "rad-1",
    "*parameters_c3": "rad-2",
    "*parameters_K": "s-1",
    "*parameters_K_at_top": "s-1",
    "*parameters_b1": "s-1",
    "*parameters_omega": "rad s-1",
    "*parameters_omega_at_top": "rad s-1",
    "*parameters_lyapunov_exponent": "s-1",
    "*parameters_mean_stiffness_shift": "s-2",
    "*parameters_S_P_at_2omega": "s-3",
    "*parameters_mass_beyond_vanishing_angle": "1",
    "*parameters_period_at_top": "s",
    "*parameters_mass_top_cell": "1",
    "*parameters_envelope_gamma": "s-1",
    "*parameters_envelope_shift": "rad s-1",
    "*parameters_envelope_variance": "1",
    "*parameters_sigma_zeta": "m",
    "*_nu": "1",
    "*fit_residual": "1",
    "*closure_order": "1",
    "*filter_order": "1",
    "*closure_fallback": "1",
    "*grid_rho_max": "1",
    "*grid_a_fine": "rad",
    "*grid_a_min": "rad",
    "*mass_beyond_grid": "1",
}
THEORY_LONG_NAMES = {
    "*parameters_K": "Roberts' excitation intensity K = (π/8) S_P(2ω)/ω²",
    "*parameters_nu": "exponent ν = 1 − b1/K",
    "*parameters_lyapunov_exponent": "growth rate of ln A at small amplitude",
    "*_nu": "fitted family's ν",
    "*parameters_S_P_at_2omega": "one-sided spectrum of the parametric term at 2ω",
    "*closure_order": "cumulant-closure order used",
    "*requested_closure_order": "cumulant-closure order asked for",
}

THEORY_SUMMARY = Layout(
    labels={"theory": "theory", "theory/*/quantiles_deg": "percentile"},
    arrays={"theory/*/pdf": ("amplitude_deg",)},
    units={"theory_pdf": "degree-1", **THEORY_UNITS},
    long_names={"theory_pdf": "the theory's envelope-amplitude PDF per degree", **THEORY_LONG_NAMES},
    coords=PERCENTILE,
    text=("theory_left_out",),
)

FILTER_FIT = Layout(
    arrays={"filter_fit/band_rad_s": ("band_edge",)},
    units={"filter_fit_order": "1", "filter_fit_band_error": "1"},
    long_names={
        "filter_fit_order": "order of the shaping filter (Method 2)",
        "filter_fit_band_rad_s": "encounter frequencies the roll responds to, where the order was chosen",
        "filter_fit_band_error": "largest error of the filter's spectrum against S_G on that band",
    },
    text=("filter_fit_order_chosen",),
)

PDF = AMPLITUDES + THEORY_SUMMARY + FILTER_FIT

THEORY = (
    Layout(
        arrays={"bins_deg": ("bins_deg",)},
        centres={"amplitude_deg": "bins_deg"},
        coords={"bins_deg": ("degree", "bin edges of the amplitude PDFs")},
    )
    + THEORY_SUMMARY
)

# --------------------------------------------------------------------------------------------------------------
# Maxima (MaximaStatistics.summary per N0, and maxima.json)
# --------------------------------------------------------------------------------------------------------------

MAXIMA_SUMMARY = Layout(
    labels={"per_n0": "(n0)", "per_n0/*/quantiles_deg": "percentile", "per_n0/*/p_exceed": "threshold_deg"},
    arrays={"bins_deg": ("bins_deg",), "per_n0/*/histogram_pdf_per_deg": ("maximum_deg",)},
    centres={"maximum_deg": "bins_deg"},
    units={
        "mean_deg_given_no_capsize": "degree",
        "beyond_bins": "1",
        "n_trials": "1",
        "histogram_mass": "1",
        "p_exceed": "1",
    },
    long_names={
        "mean_deg": "mean of the maximum of the first N0 amplitudes (NaN: infinite, trials capsized)",
        "mean_deg_given_no_capsize": "mean of the maximum over the trials that did not capsize before N0",
        "histogram_pdf_per_deg": "PDF of the maximum of the first N0 amplitudes per degree (defective: integrates "
        "to 1 − capsize_probability)",
        "p_exceed": "Monte Carlo P(maximum of the first N0 amplitudes > threshold, or a capsize before them)",
        "n_trials": "number of trials run for this N0",
        "n_known": "trials whose maximum is known (or capsized)",
        "n_valid": "trials with a finite maximum",
        "n_capsized_before": "trials that capsized before N0 amplitudes",
        "n_incomplete": "trials that neither capsized nor reached N0 amplitudes",
        "beyond_bins": "maxima beyond the last bin edge",
        "histogram_mass": "integral of the histogram PDF",
    },
    coords={**PERCENTILE, "threshold_deg": ("degree", "exceedance threshold"), "n0": ("1", "N0")},
)

MAXIMA = MAXIMA_SUMMARY + Layout(
    labels={
        "per_n0/*/curves": "source",
        "per_n0/*/p_star": "source",
        "per_n0/*/p_star/*/p_exceed": "threshold_deg",
        "theory_details": "theory",
    },
    arrays={
        "grid_deg": ("grid_deg",),
        "per_n0/*/curves/*/exact": ("grid_deg",),
        "per_n0/*/curves/*/asymptotic": ("grid_deg",),
    },
    units={
        "curves_exact": "degree-1",
        "curves_asymptotic": "degree-1",
        "p_star_mass_on_grid": "1",
        "p_star_p_exceed": "1",
        **STATIONARITY_UNITS,
        **THEORY_UNITS,
    },
    long_names={
        "curves_exact": "P*(A_M): PDF of the maximum of N0 independent amplitudes, per degree",
        "curves_asymptotic": "asymptotic P*(A_M) per degree",
        "p_star_mode_deg": "mode of P*(A_M)",
        "p_star_mean_deg": "mean of P*(A_M) (NaN: mass beyond the grid)",
        "p_star_p_exceed": "P*(A_M > threshold)",
        **THEORY_LONG_NAMES,
    },
    coords={
        "grid_deg": ("degree", "amplitude grid of the P* curves"),
        "source": (
            None,
            "amplitude law behind P* (mcs_amplitudes: the Monte Carlo's zero-crossing histogram)",
        ),
    },
    text=("runs", "theory_amplitude_laws"),
)

# --------------------------------------------------------------------------------------------------------------
# Risk (ExposureRisk, MaxRollStatistics; risk.json)
# --------------------------------------------------------------------------------------------------------------

EXPOSURE_UNITS = {
    "*exceedance_per_cycle": "1",
    "*exceedance_per_cycle_ci95": "1",
    "*probability_poisson": "1",
    "*n_cycles": "1",
    "*confidence": "1",
}
EXPOSURE_LONG_NAMES = {
    "*n_cycles": "number of amplitudes in the exposure (rate × duration)",
    "*exceedance_per_cycle": "probability that one amplitude exceeds the angle",
    **{
        f"{source}_probability": "P(at least one amplitude beyond the angle within the exposure): independent "
        f"amplitudes of the {'Monte Carlo' if source == 'monte_carlo' else source + ' law'}"
        for source in ("monte_carlo", "roberts", "esam", "moment", "envelope_fpk")
    },
    "direct_probability": "P(max |φ| > angle within the exposure, or a capsize): trials of the exposure's length",
    "*probability_poisson": "Poisson approximation of that probability",
    "*most_probable_largest_deg": "mode of the largest amplitude in the exposure",
    "*characteristic_largest_deg": "characteristic largest amplitude (F̄ = 1 − e^(−1/n))",
    "*expected_largest_deg": "expected largest amplitude in the exposure",
}

MAX_ROLL = Layout(
    labels={"largest_roll_quantiles_deg": "percentile"},
    coords=PERCENTILE,
    long_names={
        "probability": "P(max |φ| > angle within the duration, or a capsize) per trial",
        "largest_roll_quantiles_deg": "quantiles of the largest |φ| per trial (NaN: among capsizes)",
    },
)

EXPOSURE = Layout(units=EXPOSURE_UNITS, long_names=EXPOSURE_LONG_NAMES)

RISK = Layout(
    labels={"direct/largest_roll_quantiles_deg": "percentile"},
    arrays={
        "curve/*": ("curve_angle_deg",),
        "splitting/levels_deg": _STAGE,
        "splitting/conditional_probabilities": _STAGE,
        "splitting/n_successes": _STAGE,
        "splitting/stage_simulated_seconds": _STAGE,
        "splitting/stage_wall_time_s": _STAGE,
        "first_passage/model_allowance/probability_range": ("bound",),
    },
    names={"curve/angle_deg": "curve_angle_deg"},
    units={
        "curve_*": "1",
        **STATIONARITY_UNITS,
        **EXPOSURE_UNITS,
        **THEORY_UNITS,
        **FIRST_PASSAGE_UNITS,
        **SPLITTING_UNITS,
    },
    long_names={
        "curve_angle_deg": "roll angle x of the risk curve",
        "curve_direct": "P(max |φ| > x within the exposure): trials of the exposure's length",
        "curve_monte_carlo": "P(max |φ| > x within the exposure): independent Monte Carlo amplitudes",
        "direct_largest_roll_quantiles_deg": "quantiles of the largest |φ| per trial (NaN: among capsizes)",
        "curve_first_passage": "P(max |φ| > x within the exposure): the envelope FPK model followed through "
        "the exposure",
        **EXPOSURE_LONG_NAMES,
        **THEORY_LONG_NAMES,
        **FIRST_PASSAGE_LONG_NAMES,
        **SPLITTING_LONG_NAMES,
    },
    coords={
        **PERCENTILE,
        "curve_angle_deg": ("degree", "roll angle x of the risk curve"),
        "splitting_stage": (None, "stage of the splitting estimate"),
    },
    text=("first_passage/grid", "splitting/config"),
)

# --------------------------------------------------------------------------------------------------------------
# Sweeps (SweepResult; sweep.json)
# --------------------------------------------------------------------------------------------------------------

GRID = ("heading", "speed_m_s", "hs_m", "t01_s")
SWEEP = Layout(
    arrays={
        "grid/heading": ("heading",),
        "grid/speed_m_s": ("speed_m_s",),
        "grid/hs_m": ("hs_m",),
        "grid/t01_s": ("t01_s",),
        "heading_deg": ("heading",),
        "n_capsized": GRID,
        "n_exceeded": GRID,
        "capsize_probability": GRID,
        "exceedance_probability": GRID,
        "capsize_ci": (*GRID, "bound"),
        "exceedance_ci": (*GRID, "bound"),
    },
    names={
        "grid/heading": "heading",
        "grid/speed_m_s": "speed_m_s",
        "grid/hs_m": "hs_m",
        "grid/t01_s": "t01_s",
    },
    units={"exceedance_probability": "1", "exceedance_ci": "1", "capsize_ci": "1"},
    long_names={
        "heading_deg": "heading χ (0 following, 90 beam, 180 head)",
        "speed_m_s": "ship speed",
        "hs_m": "significant wave height H1/3",
        "t01_s": "mean wave period T01",
        "exceedance_probability": "P(max |φ| > angle within the duration, or a capsize) per trial",
        "exceedance_ci": "Wilson interval of the exceedance probability",
        "capsize_ci": "Wilson interval of the capsize probability",
    },
    coords={"heading": (None, "heading (label)")},
    text=("grid/axes",),
    skip=("points",),
)

# --------------------------------------------------------------------------------------------------------------
# Long-term risk (longterm.json; longterm.nc adds the cells' dataset, `jaxroll.longterm`'s, under the same names)
# --------------------------------------------------------------------------------------------------------------

_DOMINATING = "longterm_dominating_cells"
LONGTERM = Layout(
    labels={
        "longterm": "angle_deg",
        "longterm/*/dominating_cells": "rank",
        "cells": "cell_method",
        "monte_carlo_estimators": "mc_estimator",
    },
    arrays={
        "ci_against_effort/trials": ("effort",),
        "ci_against_effort/sampling_half_width": ("effort", "angle_deg"),
        "ci_against_effort/splitting_half_width": ("angle_deg",),
    },
    units={
        "exposure_hours": "h",
        "exposures_per_year": "year-1",
        "longterm_per_year_rate": "year-1",
        "longterm_per_year_rate_ci95": "year-1",
        "left_out_weight": "1",
        "cells": "1",
        "monte_carlo_estimators": "1",
        "ci_against_effort_trials": "1",
        "ci_against_effort_sampling_half_width": "1",
        "ci_against_effort_splitting_cells": "1",
        "ci_against_effort_splitting_half_width": "1",
        **{
            f"{_DOMINATING}_{k}": "1"
            for k in (
                "weight",
                "probability",
                "probability_ci95",
                "contribution",
                "share",
                "theory_probability",
                "realizations",
                "seed",
            )
        },
        **{
            f"longterm_{k}": "1"
            for k in (
                "probability",
                "probability_ci95",
                "sampling_sd",
                "model_below",
                "model_above",
                "per_year_probability",
                "per_year_probability_ci95",
                "capsize_probability",
                "capsize_probability_ci95",
                "capsize_per_year",
                "parametric_probability",
                "parametric_probability_ci95",
                "parametric_share",
            )
        },
    },
    long_names={
        "exposure_hours": "exposure of every cell",
        "exposures_per_year": "exposures per year N_y",
        "longterm_probability": "P(max |roll| > angle within one exposure), the cells' weighted mean",
        "longterm_probability_ci95": "95 % interval of the long-term probability (sampling and model allowance)",
        "longterm_sampling_sd": "(Σ w² Var P)^1/2",
        "longterm_model_below": "model allowance below",
        "longterm_model_above": "model allowance above",
        "longterm_per_year_probability": "P(at least one exceedance in a year) = 1 − exp(−N_y P_LT)",
        "longterm_per_year_probability_ci95": "95 % interval of the per-year probability",
        "longterm_per_year_rate": "expected exposures with an exceedance per year, N_y P_LT",
        "longterm_per_year_rate_ci95": "95 % interval of the per-year rate",
        "longterm_capsize_probability": "P(capsize within one exposure), the cells' weighted mean",
        "longterm_capsize_probability_ci95": "95 % interval of the long-term capsize probability",
        "longterm_capsize_per_year": "P(at least one capsize in a year)",
        "longterm_parametric_probability": "the long-term probability with the direct wave moment off: the "
        "parametric-only roll",
        "longterm_parametric_probability_ci95": "95 % interval of the parametric-only long-term probability",
        "longterm_parametric_share": "parametric-only over total long-term probability",
        "left_out_weight": "weight of the cells left out (a bound on their contribution)",
        "cells": "number of cells by method",
        "monte_carlo_estimators": "number of Monte Carlo cells by estimator",
        "ci_against_effort_trials": "Monte Carlo trials at each effort (splitting cells: their cost in trials)",
        "ci_against_effort_sampling_half_width": "half width of the sampling interval at each effort",
        "ci_against_effort_splitting_cells": "Monte Carlo cells by splitting (whole runs at every effort)",
        "ci_against_effort_splitting_half_width": "the splitting cells' part of the half width",
        f"{_DOMINATING}_*": "the cells with the largest contributions w·P, largest first (rank 0)",
    },
    coords={
        "angle_deg": ("degree", "roll angle"),
        "rank": ("1", "rank of the cell by contribution"),
        "cell_method": (None, "how a cell's probability was obtained"),
        "mc_estimator": (None, "the estimator of a Monte Carlo cell"),
    },
)

# --------------------------------------------------------------------------------------------------------------
# Sensitivities (sensitivity.json)
# --------------------------------------------------------------------------------------------------------------

_MIXED_STAT = "mixed: each statistic in its own unit (degree2, degree or 1, the statistic's name says)"
_MIXED_GRAD = "mixed: the statistic's unit (its name says) per unit of the parameter (parameters_unit)"
SENSITIVITY = Layout(
    labels={
        "parameters": "parameter",
        "values": "statistic",
        "values/*/theory": "theory",
        "gradients": "statistic",
        "gradients/*": "parameter",
        "gradients/*/*/theory": "theory",
        "theory_details": "theory",
        "estimator/fd_step": "parameter",
    },
    arrays={"estimator/burn_in_s": ("burn_in",)},
    names={"units": "units_note"},
    units={
        "parameters_value": "mixed: the parameter's own unit (parameters_unit)",
        "parameters_step": "mixed: the parameter's own unit (parameters_unit)",
        "values_*": _MIXED_STAT,
        "gradients_*": _MIXED_GRAD,
        "estimator_memory_ratio": "1",
        "estimator_extrapolation_factor": "1",
        "estimator_extrapolated": "1",
        "theory_time_s": "s",
        "estimator_fd_step": "mixed: the parameter's own unit (parameters_unit)",
    },
    long_names={
        "values_monte_carlo_value": "Monte Carlo value of the statistic",
        "values_monte_carlo_std_error": "its standard error",
        "values_theory": "the theory's value of the statistic",
        "gradients_monte_carlo_value": "Monte Carlo derivative d(statistic)/d(parameter)",
        "gradients_monte_carlo_std_error": "its standard error",
        "gradients_theory": "the theory's derivative d(statistic)/d(parameter)",
        "parameters_value": "nominal value of the parameter",
        "parameters_step": "step of the bar chart",
    },
    coords={"statistic": (None, "statistic (its unit in its name)"), "parameter": (None, "parameter")},
)

# --------------------------------------------------------------------------------------------------------------
# Hydrostatics (HydrostaticsSolution, Particulars; hydrostatics.json)
# --------------------------------------------------------------------------------------------------------------

_PARTICULARS = {
    "displacement_kg": "displacement Δ",
    "volume_m3": "displaced volume ∇",
    "draught_m": "draught amidships",
    "draught_ap_m": "draught at the AP",
    "draught_fp_m": "draught at the FP",
    "trim_m": "trim d_FP − d_AP",
    "lcb_m": "longitudinal centre of buoyancy from the AP",
    "lcg_m": "longitudinal centre of gravity from the AP",
    "kb_m": "KB",
    "bm_m": "transverse BM",
    "km_m": "transverse KM",
    "kg_m": "KG",
    "gm_m": "transverse metacentric height GM",
    "bm_longitudinal_m": "longitudinal BM",
    "gm_longitudinal_m": "longitudinal GM",
    "waterplane_area_m2": "waterplane area",
    "lcf_m": "longitudinal centre of flotation from the AP",
    "waterline_breadth_m": "waterline breadth B_WL",
    "block_coefficient": "block coefficient ∇/(Lpp B_WL d)",
    "midship_coefficient": "midship coefficient",
    "prismatic_coefficient": "prismatic coefficient",
    "waterplane_coefficient": "waterplane coefficient",
}
# Particulars.as_dict()'s names, alone (Particulars.to_xarray) and as hydrostatics.json's and sgisc.json's `calm_water`
PARTICULARS_LONG_NAMES = {**_PARTICULARS, **{f"calm_water_{k}": v for k, v in _PARTICULARS.items()}}
PARTICULARS = Layout(long_names=PARTICULARS_LONG_NAMES)

HYDRO = ("zeta_mid_m", "heel_deg")
HYDROSTATICS = (
    SHIP
    + PARTICULARS
    + Layout(
        arrays={
            "tables/zeta_mid_m": ("zeta_mid_m",),
            "tables/heel_deg": ("heel_deg",),
            "tables/gz_m": HYDRO,
            "tables/sinkage_m": HYDRO,
            "tables/trim_m": HYDRO,
            "tables/gz_calm_m": ("heel_deg",),
            "tables/gm_m": ("zeta_mid_m",),
            "tables/delta_gm_m": ("zeta_mid_m",),
            "gz_curves_figure/heel_deg": ("figure_heel_deg",),
            "gz_curves_figure/zeta_mid_m": ("figure_zeta_mid_m",),
            "gz_curves_figure/gz_m": ("figure_zeta_mid_m", "figure_heel_deg"),
        },
        names={
            "tables/zeta_mid_m": "zeta_mid_m",
            "tables/heel_deg": "heel_deg",
            "gz_curves_figure/heel_deg": "figure_heel_deg",
            "gz_curves_figure/zeta_mid_m": "figure_zeta_mid_m",
        },
        units={
            "fits_gz_coefficients_m_g3": "m rad-3",
            "fits_gz_coefficients_m_g5": "m rad-5",
            "fits_gz_coefficients_m_g7": "m rad-7",
            "fits_gz_coefficients_m_g9": "m rad-9",
            "balance_check_max_relative_volume_error": "1",
            "balance_check_all_converged": "1",
            "fits_restoring_a3": "s-2 rad-2",
            "fits_restoring_a5": "s-2 rad-4",
            "fits_restoring_a7": "s-2 rad-6",
            "fits_restoring_a9": "s-2 rad-8",
            "fits_delta_gm_coefficients_c0": "m",
            "fits_delta_gm_coefficients_c1": "1",
            "fits_delta_gm_coefficients_c2": "m-1",
            "fits_delta_gm_coefficients_c3": "m-2",
            "fits_delta_gm_coefficients_c4": "m-3",
            "fits_delta_gm_coefficients_c5": "m-4",
            "fits_delta_gm_coefficients_c6": "m-5",
            "hull_n_stations": "1",
            "hull_n_waterlines": "1",
        },
        long_names={
            "zeta_mid_m": "wave amplitude at amidships ζ_mid (> 0: trough amidships)",
            "heel_deg": "heel φ",
            "tables_gz_m": "GZ in waves of length λ at free sinkage and trim",
            "tables_sinkage_m": "sinkage",
            "tables_trim_m": "trim",
            "tables_gz_calm_m": "GZ in calm water",
            "tables_gm_m": "upright GM in the wave",
            "tables_delta_gm_m": "ΔGM(ζ_mid) = GM(ζ_mid) − GM(calm)",
            "gz_curves_figure_gz_m": "GZ of the figure's curves (calm, crest and trough amidships)",
            "figure_heel_deg": "heel of the figure's GZ curves",
            "figure_zeta_mid_m": "ζ_mid of the figure's GZ curves",
        },
        coords={
            "zeta_mid_m": ("m", "wave amplitude at amidships ζ_mid (> 0: trough amidships)"),
            "heel_deg": ("degree", "heel φ"),
            "figure_heel_deg": ("degree", "heel of the figure's GZ curves"),
            "figure_zeta_mid_m": ("m", "ζ_mid of the figure's GZ curves"),
        },
    )
)

# --------------------------------------------------------------------------------------------------------------
# IMO second-generation criteria (ParametricRollAssessment; sgisc.json)
# --------------------------------------------------------------------------------------------------------------

SGISC = (
    SHIP
    + PARTICULARS
    + Layout(
        labels={"level2_c1/cases": "c1_case", "level2_c2/per_case": "c2_case"},
        arrays={
            "level1/gm_waves": ("crest_position",),
            "damping/amplitudes_deg": ("damping_amplitude",),
            "damping/b_eq": ("damping_amplitude",),
            "damping/zeta_eq": ("damping_amplitude",),
            "damping/b_hat": ("damping_amplitude",),
            "level2_c2/hs_m": ("c2_hs",),
            "level2_c2/tz_s": ("c2_tz",),
            "level2_c2/effective_wave_height_m": ("c2_hs", "c2_tz"),
            "level2_c2/max_roll_deg": ("c2_case", "c2_hs", "c2_tz"),
            "level2_c2/roll_versus_speed/*": ("roll_versus_speed",),
            "kg_max/*": ("kg_max_draught",),
        },
        names={"level2_c2/hs_m": "c2_hs_m", "level2_c2/tz_s": "c2_tz_s"},
        units={
            "level1_gm": "m",
            "level1_draught": "m",
            "level1_draught_high": "m",
            "level1_draught_low": "m",
            "level1_reserve_ratio": "1",
            "level1_delta_gm1_waterplane": "m",
            "level1_delta_gm1_waves": "m",
            "level1_gm_waves": "m",
            "level1_delta_gm1": "m",
            "level2_c1_c1": "1",
            "level2_c1_standard": "1",
            "level2_c1_roll_period": "s",
            "level2_c1_service_speed": "m s-1",
            "level2_c1_cases_c": "1",
            "level2_c1_cases_stable": "1",
            "level2_c1_cases_resonance_above_service_speed": "1",
            "damping_b1": "s-1",
            "damping_b2": "rad-1",
            "damping_b3": "s rad-2",
            "damping_fit_rms": "s-1",
            "damping_b_eq": "s-1",
            "damping_zeta_eq": "1",
            "damping_b_hat": "1",
            "damping_components_at_max_*": "1",
            "level2_c2_c2": "1",
            "level2_c2_standard": "1",
            "level2_c2_per_case_speed_factor": "1",
            "level2_c2_per_case_c": "1",
            "kg_max_r_pr": "1",
        },
        long_names={
            "level1_gm_waves": "GM on the wave crest positions (Level 1)",
            "level2_c2_max_roll_deg": "largest roll per C2 case and sea state (H_s, T_z)",
            "damping_b_eq": "equivalent linear damping b_eq at each amplitude (simplified Ikeda)",
        },
        coords={
            "c2_hs_m": ("m", "H_s class centre of the scatter table"),
            "c2_tz_s": ("s", "T_z class centre of the scatter table"),
        },
        text=("summary",),
    )
)

# --------------------------------------------------------------------------------------------------------------
# Calibration (DecayFit, CaptiveFit, RollFit, TimeDomainFit; calibration.json)
# --------------------------------------------------------------------------------------------------------------

_DIAGNOSTICS = {
    "*diagnostics_condition_number": "1",
    "*diagnostics_sigma": "rad",
    "*diagnostics_rss": "rad2",
}
CALIBRATE_DECAY = SHIP + Layout(
    labels={"estimates": "method", "estimates/*/records": "record", "model_comparison": "damping_model"},
    arrays={
        **{f"estimates/*/damping_{m}": ("parameter", "parameter_2") for m in ("covariance", "correlation")},
        "estimates/*/equivalent_damping/*": ("amplitude",),
        "estimates/*/amplitude_range_deg": ("range_bound",),
    },
    units={
        "estimates_damping_covariance": "mixed: products of the parameters' units (b1 s-1, b2 rad-1, b3 s rad-2)",
        **dict.fromkeys(("estimates_damping_correlation", "estimates_information_criteria_*"), "1"),
        **dict.fromkeys(("estimates_equivalent_damping_zeta*", "model_comparison_*", "agreement_z_*"), "1"),
        "estimates_equivalent_damping_b_e*": "s-1",
        **{f"written_constrained_b{i}_*": u for i, u in ((1, "s-1"), (2, "rad-1"), (3, "s rad-2"))},
        **_DIAGNOSTICS,
    },
    long_names={"estimates_damping_covariance": "covariance of (b1, b2, b3)"},
    coords={"method": (None, "fit (extinction curve or ODE)"), "damping_model": (None, "damping model")},
    index=dict.fromkeys(("parameter", "parameter_2"), ("b1", "b2", "b3")),
    text=("estimates/*/config", "estimates/*/fitted_parameters"),
)

CALIBRATE_CAPTIVE = Layout(
    labels={"estimates/groups": "group"},
    arrays={
        "estimates/groups/*/per_record_ratio": ("group_record",),
        "estimates/polynomial_covariance": ("polynomial_parameter", "polynomial_parameter_2"),
    },
    units={
        "estimates_diagnostics_condition_number": "1",
        "estimates_diagnostics_sigma": "m",
        "estimates_diagnostics_rss": "m2",
        "estimates_groups_per_record_ratio": "1",
        "estimates_polynomial_covariance": "mixed: products of the coefficients' units",
        "written_gm_correction": "1",
    },
    text=("estimates/config",),
)

CALIBRATE_ROLL_PDF = SHIP + Layout(
    labels={"estimates/sea_states": "sea_state"},
    arrays={
        "estimates/covariance": ("parameter", "parameter_2"),
        "estimates/sea_states/*/bands": ("band_edge",),
        "estimates/sea_states/*/*_deg": ("estimator_band",),
    },
    units={
        "estimates_covariance": "mixed: products of the parameters' units",
        "estimates_initial_*": "mixed: the parameter's SI unit (estimates_*_unit)",
        "estimates_sea_states_bands": "1",
        "estimates_diagnostics_rss": "1",
        "estimates_diagnostics_sigma": "1",
        "estimates_diagnostics_condition_number": "1",
        "estimates_sea_states_model_capsized_*": "1",
    },
    long_names={"estimates_diagnostics_rss": "sum of squared residuals, each in its own standard errors"},
    text=("estimates/config",),
)

CALIBRATE_ROLL_TIME_DOMAIN = SHIP + Layout(
    labels={"records": "record"},
    arrays={
        "correlation/names": ("parameter",),
        "correlation/matrix": ("parameter", "parameter_2"),
        "covariance/names": ("parameter_2",),
        "covariance/matrix": ("parameter", "parameter_2"),
        "covariance_model_based": ("parameter", "parameter_2"),
        "identifiability/names": ("parameter",),
        "identifiability/correlation": ("parameter", "parameter_2"),
        "records/*/span_model_s": ("span",),
    },
    names={
        "correlation/names": "parameter",
        "covariance/names": "parameter_2",
        "identifiability/names": "identifiability_names",
    },
    units={
        "correlation_matrix": "1",
        "covariance_matrix": "mixed: products of the parameters' units (estimates_*_unit)",
        "covariance_model_based": "mixed: products of the parameters' units (estimates_*_unit)",
        "identifiability_correlation": "1",
        "identifiability_variance_inflation_*": "1",
        "identifiability_relative_se_*": "1",
        "*condition_number": "1",
        "windows": "1",
        "records_extra_nll": "1",
        "records_extra_normalised_innovation_rms": "1",
        "records_residual_to_noise": "1",
        "info_nll": "1",
        "info_normalised_innovation_rms": "1",
        "info_rss": "1",
        "info_sigma": "1",
        "estimates_*_dof": "1",
    },
    skip=("identifiability/names",),
)

#: Each command's JSON file → its layout (`jaxroll.io.output_dataset`). Calibration by kind (and estimator).
OUTPUTS = {
    "pdf": PDF,
    "theory": THEORY,
    "maxima": MAXIMA,
    "risk": RISK,
    "sweep": SWEEP,
    "longterm": LONGTERM,
    "sensitivity": SENSITIVITY,
    "hydrostatics": HYDROSTATICS,
    "sgisc": SGISC,
    "calibrate-decay": CALIBRATE_DECAY,
    "calibrate-captive": CALIBRATE_CAPTIVE,
    "calibrate-roll-pdf": CALIBRATE_ROLL_PDF,
    "calibrate-roll-time-domain": CALIBRATE_ROLL_TIME_DOMAIN,
}
