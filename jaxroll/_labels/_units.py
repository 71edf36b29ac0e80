"""Units and long names of labelled results, from the names jaxroll gives its fields (`_deg`, `_m`, `_s`, …)."""

from __future__ import annotations

import re

#: Name endings that state a unit (CONVENTIONS: every JSON field in degrees says `_deg`), longest first, as
#: UDUNITS strings (what CF-aware tools such as cf-xarray and pint-xarray parse).
SUFFIX_UNITS = (
    ("_rad2_s2", "rad2 s-2"),
    ("_deg_per_s", "degree s-1"),
    ("_per_degree", "degree-1"),
    ("_per_deg", "degree-1"),
    ("_per_rad2", "rad-2"),
    ("_per_rad", "rad-1"),
    ("_per_s", "s-1"),
    ("_kg_m3", "kg m-3"),
    ("_rad_s", "rad s-1"),
    ("_m2s", "m2 s rad-1"),
    ("_m_s", "m s-1"),
    ("_deg2", "degree2"),
    ("_deg", "degree"),
    ("_rad6", "rad6"),
    ("_rad4", "rad4"),
    ("_rad2", "rad2"),
    ("_rad", "rad"),
    ("_m2", "m2"),
    ("_m3", "m3"),
    ("_kg", "kg"),
    ("_kn", "knot"),
    ("_m", "m"),
    ("_s", "s"),
)

#: Names (or their last word) that are dimensionless [1].
_DIMENSIONLESS = re.compile(
    r"(^|_)(n|probability|probabilities|ratio|fraction|count|mass|coefficient|confidence|weight|froude|"
    r"stationary|converged|vulnerable|exists|change|z)$|^(n|num|per_record)_|^relative_|_probability_|"
    r"^r_pr$"
)

#: Units as results and estimates write them for people → UDUNITS (`"1/s"` → `"s-1"`).
_UDUNITS = {
    "": "1",
    "-": "1",
    "deg": "degree",
    "degrees": "degree",
    "°": "degree",
    "%": "percent",
    "s/rad²": "s rad-2",
}


def udunits(text: str) -> str:
    """A unit in UDUNITS form, the one style of every `units` attribute: `"1/s"` → `"s-1"`, `"m/s"` → `"m s-1"`,
    `"s/rad^2"` → `"s rad-2"`, `"deg"` → `"degree"`, `"-"` → `"1"`; UDUNITS text is returned as it is."""
    text = text.strip()
    if text in _UDUNITS:
        return _UDUNITS[text]
    if "/" not in text and "^" not in text and "*" not in text:
        return text
    num, _, den = text.partition("/")

    def factors(part: str, sign: int) -> list[str]:
        out = []
        for factor in re.split(r"[\s*·]+", part.strip()):
            if not factor or factor == "1":
                continue
            name, _, power = factor.partition("^")
            name = _UDUNITS.get(name, name)
            p = sign * float(power or 1)  # fractional powers too: a noise intensity in rad s-1.5
            p = int(p) if p.is_integer() else p
            out.append(name if p == 1 else f"{name}{p:g}")
        return out

    return " ".join(factors(num, 1) + factors(den, -1)) or "1"


def units_from_name(name: str) -> str | None:
    """The unit a field's name states (`mean_amplitude_deg` → "degree", `n_capsized` → "1"), or None.

    A trailing `_ci95`/`_ci`/`_ci95_deg` interval takes the unit of what it bounds."""
    if re.match(r"(n|num)_", name):  # counts: `num_s` is a number of cells, not seconds
        return "1"
    for suffix, unit in SUFFIX_UNITS:
        if name.endswith(suffix) and len(name) > len(suffix):
            return unit
    stripped = re.sub(r"(_ci95|_ci)$", "", name)
    if stripped != name:
        return units_from_name(stripped) if stripped else None
    if _DIMENSIONLESS.search(name):
        return "1"
    return None


#: Long names of fields that appear in several outputs (the leaf name; layouts add their own).
GLOSSARY = {
    "n_realizations": "number of realizations (trials) run",
    "n_capsized": "number of realizations that capsized (|φ| beyond the angle of vanishing stability)",
    "n_survivors": "number of realizations that did not capsize",
    "n_exceeded": "number of trials whose largest |φ| exceeded the angle, or that capsized",
    "n_amplitudes": "number of amplitudes counted",
    "capsize_probability": "probability of capsize per trial",
    "capsize_probability_ci95": "95 % Wilson interval of the capsize probability",
    "mean_amplitude_deg": "mean roll amplitude",
    "quantiles_deg": "quantiles of the roll amplitude",
    "mass_beyond_grid": "fraction of the amplitudes beyond the last bin edge",
    "bins_deg": "bin edges of the amplitude PDFs",
    "pdf_zero_crossing": "PDF of the zero-crossing amplitudes (per half cycle) per degree",
    "pdf_envelope": "PDF of the envelope amplitudes (per time sample) per degree",
    "pdf": "PDF of the amplitude per degree",
    "run_time_s": "wall time of the run",
    "time_s": "wall time",
    "value": "estimate",
    "std_error": "standard error",
    "ci95": "95 % interval",
    "probability": "probability",
    "probability_ci95": "95 % interval of the probability",
    "conditional_on_no_capsize": "whether the amplitude statistics are conditional on no capsize (1: yes)",
    "exists": "whether the law exists (1: yes)",
    "converged": "whether the solver converged (1: yes)",
    "vulnerable": "whether the ship is vulnerable (1: yes)",
    "stationary": "whether the roll is stationary over the run (1: yes; NaN: cannot tell)",
    "relative_change": "relative change of the mean envelope amplitude between the halves of the run",
    "change_in_standard_errors": "that change in standard errors of the per-realization differences",
    "mean_envelope_first_half_deg": "mean envelope amplitude over the first half of the kept window",
    "mean_envelope_second_half_deg": "mean envelope amplitude over the second half of the kept window",
    "E_phi2": "time-sampled mean of φ² over the surviving realizations",
    "E_phi4": "time-sampled mean of φ⁴ over the surviving realizations",
    "envelope_sample_interval_s": "interval at which φ is recorded for the Hilbert envelope",
    "support_max_deg": "upper end of the law's support",
    "n0": "number of zero-crossing amplitudes N0 whose maximum is taken",
    "percentile": "quantile level",
    "estimator": "amplitude estimator (zero_crossing: per half cycle; envelope: per time sample)",
    "theory": "theoretical method",
    "bound": "interval bound",
    "realization": "realization (trial) index, in the Monte Carlo's order",
    # risk
    "angle_deg": "threshold roll angle",
    "rate_per_s": "zero-crossing amplitudes per second of roll",
    "n_exceed": "amplitudes above the angle",
    "duration_s": "duration",
    # the filter fit (Method 2)
    "relative_l2_error": "relative L2 error of the filter's spectrum",
    "variance_target_m2": "target variance",
    "variance_filter_m2": "the filter's variance",
    "match_frequency_rad_s": "frequency where the spectra are matched",
    "spectrum_target_at_match_m2s": "target spectrum there",
    "spectrum_filter_at_match_m2s": "the filter's spectrum there",
    # IMO criteria
    "r_pr": "standard R_PR",
    "reserve_ratio": "reserve ratio",
    "draught_high": "higher draught of Level 1",
    "draught_low": "lower draught of Level 1",
    "delta_gm1": "ΔGM1 (Level 1)",
    "ratio": "ΔGM/GM",
    "delta_gm1_waterplane": "ΔGM1 from the waterplane",
    "delta_gm1_waves": "ΔGM1 from the GM on waves",
    "c1": "C1 (weighted share of wave cases that fail)",
    "c2": "C2 (mean share of sea states with roll > 25°)",
    "standard": "the check's standard",
    "weight": "weight of the wave case",
    "wavelength_m": "wavelength",
    "height_m": "wave height",
    "gm_mean_m": "mean GM on the wave",
    "delta_gm_m": "half the range of GM on the wave",
    "v_pr_m_s": "speed of principal parametric resonance",
    "stable": "whether GM stays positive (1: yes)",
    "c": "the case's contribution (0 or 1)",
    "fit_rms": "rms residual of the damping fit",
    "zeta_eq": "equivalent damping ratio",
    "b_hat": "non-dimensional damping B̂44",
    "froude": "Froude number",
    "speed_factor": "speed factor K",
    "encounter_frequency_rad_s": "encounter frequency",
    "effective_wave_height_m": "effective wave height h_eff",
    "max_roll_deg": "largest roll",
    # fits and diagnostics
    "gm0_m": "calm-water GM0",
    "gz_fit_rms_m": "rms residual of the GZ fit",
    "delta_gm_fit_rms_m": "rms residual of the ΔGM fit",
    "dof": "degrees of freedom of the 95 % interval",
    "n_obs": "number of residuals",
    "n_params": "number of fitted parameters",
    "rss": "sum of squared residuals",
    "sigma": "residual standard deviation",
    "num_steps": "solver steps",
    "condition_number": "condition number",
    "omega0_rad_s": "natural roll frequency ω0",
    "agreement_z": "difference between the fits in combined SEs",
}


def long_name_from_path(parts: tuple[str, ...]) -> str:
    """A readable long name from a field's path: its last name from the glossary when there is one, else the
    words of the path ("theory parameters K")."""
    leaf = parts[-1] if parts else ""
    if leaf in GLOSSARY:
        head = " ".join(p.replace("_", " ") for p in parts[:-1])
        return f"{head}: {GLOSSARY[leaf]}" if head else GLOSSARY[leaf]
    words = []
    for p in parts:
        for suffix, _ in SUFFIX_UNITS:
            if p.endswith(suffix) and len(p) > len(suffix):
                p = p[: -len(suffix)]
                break
        words.append(p.replace("_", " "))
    return " ".join(words)
