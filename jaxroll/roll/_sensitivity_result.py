"""The result of `monte_carlo_sensitivity`: what is differentiated (the statistics by default, the parameters of
`sensitivity_problem` and their units) and `SensitivityResult`, with its labelled form (`to_xarray`)."""

from __future__ import annotations

import equinox as eqx
import numpy as np

DEFAULT_SENSITIVITY_STATISTICS = ("E_phi2", "mean_envelope", "mean_zero_crossing", "P_exceed_20deg")
# the parameters of `sensitivity_problem` and their units
SENSITIVITY_PARAMETERS = {
    "gm0": "m", "b1": "1/s", "b2": "1/rad", "b3": "s/rad²", "gm_correction": "-",
    **{f"c{k}": f"m^{1 - k}" for k in range(7)}, "hs": "m", "t01": "s", "speed": "m/s",
}  # fmt: skip


class SensitivityResult(eqx.Module):
    """Monte Carlo statistics and their derivatives, with standard errors from per-realization contributions.

    - `value[stat]`, `value_std_error[stat]`: the statistic (radians: rad² for E_phi2, rad for amplitudes,
      probability for exceedances; exceedances are the *smoothed* ones) over the surviving realizations;
      `unsmoothed[stat]`: the plain estimate (for exceedances the indicator count; else equal to `value`).
    - `gradient[stat][param]`, `std_error[stat][param]`: d(statistic)/d(parameter) and its standard error.
    - `influence[stat][param]`: per-realization contributions whose mean is the gradient (paired comparisons).
    - `unsmoothed_gradient`, `unsmoothed_std_error`: with `method="finite_difference"`, the central difference of
      the unsmoothed statistics (the exceedance indicators themselves); empty for the windowed estimator.
    - `by_burn_in[seconds][stat][param]`: the windowed estimates before extrapolation, per burn-in.
    - `kept`: which realizations count (survivors; for finite differences, survivors of every shifted run).
    - `n_realizations`, `n_capsized`; `config`: how it was computed (method, window, burn-in, smoothing, …).
    """

    statistics: tuple[str, ...]
    parameters: tuple[str, ...]
    params: dict
    value: dict
    value_std_error: dict
    unsmoothed: dict
    gradient: dict
    std_error: dict
    influence: dict
    unsmoothed_gradient: dict
    unsmoothed_std_error: dict
    by_burn_in: dict
    kept: np.ndarray
    n_realizations: int
    n_capsized: int
    config: dict

    def summary(self) -> dict:
        """Plain numbers for JSON (radians; no per-realization arrays)."""
        return {
            "statistics": list(self.statistics),
            "parameters": {p: self.params[p] for p in self.parameters},
            "value": dict(self.value),
            "value_std_error": dict(self.value_std_error),
            "unsmoothed": dict(self.unsmoothed),
            "gradient": {s: dict(g) for s, g in self.gradient.items()},
            "std_error": {s: dict(g) for s, g in self.std_error.items()},
            "unsmoothed_gradient": {s: dict(g) for s, g in self.unsmoothed_gradient.items()},
            "unsmoothed_std_error": {s: dict(g) for s, g in self.unsmoothed_std_error.items()},
            "by_burn_in": {str(b): {s: dict(g) for s, g in d.items()} for b, d in self.by_burn_in.items()},
            "n_realizations": self.n_realizations,
            "n_capsized": self.n_capsized,
            "config": dict(self.config),
        }

    def to_xarray(self):
        """The result as an `xarray.Dataset` on (`statistic`, `parameter`) in the API's units (radians; each
        statistic's unit in the coordinate `statistic_unit`, each parameter's in `parameter_unit`): `value`,
        `value_std_error`, `unsmoothed`, `gradient`, `std_error`, `parameter_value`, per realization `influence`
        (the contributions whose mean is the gradient; NaN for the realizations left out) and `kept`, and with the
        windowed estimator `by_burn_in` (the estimates per burn-in before extrapolation)."""
        from .._labels import config_attrs, labelled_values

        st, pa = list(self.statistics), list(self.parameters)
        kept = np.asarray(self.kept, dtype=bool)
        influence = np.full((len(st), len(pa), kept.size), np.nan)
        for i, stat in enumerate(st):
            for j, p in enumerate(pa):
                influence[i, j, kept] = np.asarray(self.influence[stat][p])
        grid = lambda d: np.array([[d[s][p] for p in pa] for s in st], dtype=float)  # noqa: E731
        sp, r = ("statistic", "parameter"), ("realization",)
        mixed = "mixed: the statistic's unit (statistic_unit) per unit of the parameter (parameter_unit)"
        per_stat = "mixed: the statistic's unit (statistic_unit)"
        out = {
            "value": (
                ("statistic",),
                [self.value[s] for s in st],
                per_stat,
                "Monte Carlo value of the statistic over the surviving realizations (exceedances: smoothed)",
            ),
            "value_std_error": (
                ("statistic",),
                [self.value_std_error[s] for s in st],
                per_stat,
                "its standard error",
            ),
            "unsmoothed": (
                ("statistic",),
                [self.unsmoothed[s] for s in st],
                per_stat,
                "the plain estimate (exceedances: the indicator count)",
            ),
            "gradient": (sp, grid(self.gradient), mixed, "d(statistic)/d(parameter)"),
            "std_error": (sp, grid(self.std_error), mixed, "standard error of the gradient"),
            "influence": (
                (*sp, *r),
                influence,
                mixed,
                "per-realization contributions whose mean is the gradient",
            ),
            "kept": (r, kept, "1", "whether the realization counts (survived)"),
            "parameter_value": (
                ("parameter",),
                [float(self.params[p]) for p in pa],
                "mixed: the parameter's unit (parameter_unit)",
                "nominal value of the parameter",
            ),
            "n_realizations": ((), self.n_realizations, "1", "number of realizations run"),
            "n_capsized": ((), self.n_capsized, "1", "number of realizations that capsized"),
        }
        coords = {
            "statistic": (("statistic",), st, None, "statistic"), "parameter": (("parameter",), pa, None, "parameter"),
            "realization": (r, np.arange(kept.size), "1", "realization (trial) index, in the Monte Carlo's order"),
            "statistic_unit": (("statistic",), ["rad2" if x == "E_phi2" else "rad" if x.startswith("mean_") else "1"
                                                for x in st], None, "unit of the statistic"),
            "parameter_unit": (("parameter",), [SENSITIVITY_PARAMETERS.get(p, "?") for p in pa], None,
                               "unit of the parameter")}  # fmt: skip
        if self.by_burn_in:
            burns = sorted(self.by_burn_in)
            out["by_burn_in"] = (
                ("burn_in_s", *sp),
                np.stack([grid(self.by_burn_in[b]) for b in burns]),
                mixed,
                "windowed gradient estimate per burn-in, before extrapolation",
            )
            coords["burn_in_s"] = (
                ("burn_in_s",),
                np.asarray(burns, dtype=float),
                "s",
                "burn-in of the tangent",
            )
        return labelled_values(out, coords=coords, attrs=config_attrs(self.config))
