"""What a decay fit returns (`DecayFit`) and the quantity that is robust: the equivalent linear damping.

Over the narrow amplitude range of one decay test, b1, b2 and b3 trade off against each other (their correlation
is reported), but the equivalent linear damping they give at an amplitude the record covers does not:

    B_e(A) = b1 + 8/(3π) ω A b2 + ¾ ω² A² b3   [1/s],      ζ_eq(A) = B_e(A) / (2ω)

(energy balance over a cycle of φ = A cos ωt; docs/calibration.md §1). Its standard error is the gradient's
quadratic form with the covariance of (b1, b2, b3); amplitudes outside the record's are flagged as extrapolated.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

import numpy as np

from ._least_squares import Estimate, LeastSquaresInfo

#: The damping models of a decay fit: name → the coefficients fitted (the others are 0).
DAMPING_MODELS: dict[str, tuple[str, ...]] = {
    "linear": ("b1",),
    "linear+quadratic": ("b1", "b2"),
    "linear+cubic": ("b1", "b3"),
    "linear+quadratic+cubic": ("b1", "b2", "b3"),
}
_B = ("b1", "b2", "b3")


def check_damping_model(name: str) -> tuple[str, ...]:
    """The coefficients of the damping model `name` (`DAMPING_MODELS`); `ValueError` naming the choices."""
    if name not in DAMPING_MODELS:
        raise ValueError(f"damping model {name!r} is not one of {', '.join(DAMPING_MODELS)}.")
    return DAMPING_MODELS[name]


def equivalent_damping_gradient(amplitude, omega) -> np.ndarray:
    """∂B_e/∂(b1, b2, b3) at amplitudes A [rad] and frequency ω [rad/s]: shape (len(A), 3)."""
    a = np.atleast_1d(np.asarray(amplitude, dtype=float))
    return np.stack([np.ones_like(a), 8 / (3 * math.pi) * omega * a, 0.75 * omega**2 * a**2], axis=-1)


def amplitude_grid(lo: float, hi: float, n: int = 7) -> np.ndarray:
    """The amplitudes [deg] at which ζ_eq is reported: `n` from the smallest to the largest amplitude the records
    cover, rounded to 0.01°."""
    return np.round(np.linspace(lo, hi, n), 2)


@dataclasses.dataclass(frozen=True)
class DecayFit:
    """Damping from free-decay records by one method ("extinction" or "ode").

    `damping`: Estimates of b1 [1/s], b2 [1/rad], b3 [s/rad²] (a coefficient the damping model leaves out is 0
    with standard error 0); `damping_covariance` (3×3, SI); `extinction`: a [-], b [1/rad], c [1/rad²];
    `roll_period`: Tφ [s] (fitted by the ODE method; the observed one for the extinction method); `info`: solver
    diagnostics; `curves`: data for the figures; `damping_model`: a key of `DAMPING_MODELS`; `amplitude_range`:
    the smallest and largest roll amplitude the records cover [rad] (the range where ζ_eq is not extrapolated);
    `records`: per record, its release and start [s, model scale], fitted roll offset [rad] and observed period
    [s, full scale].
    """

    method: str
    damping: dict[str, Estimate]
    damping_covariance: np.ndarray
    extinction: dict[str, Estimate]
    roll_period: Estimate
    omega0: float
    info: LeastSquaresInfo
    curves: dict[str, Any]
    config: dict[str, Any]
    damping_model: str = "linear+quadratic+cubic"
    amplitude_range: tuple[float, float] = (math.nan, math.nan)
    records: tuple[dict[str, Any], ...] = ()

    @property
    def b(self) -> np.ndarray:
        """(b1 [1/s], b2 [1/rad], b3 [s/rad²]) as an array."""
        return np.array([self.damping[k].value for k in _B])

    @property
    def fitted_parameters(self) -> tuple[str, ...]:
        """The damping coefficients this fit estimated (its damping model's)."""
        return DAMPING_MODELS[self.damping_model]

    def damping_correlation(self) -> np.ndarray:
        """Correlation matrix of (b1, b2, b3) (NaN for a coefficient the damping model leaves out)."""
        cov = np.asarray(self.damping_covariance, dtype=float)
        se = np.sqrt(np.clip(np.diag(cov), 0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(se, se)
        out = np.full((3, 3), np.nan)
        idx = [_B.index(n) for n in self.fitted_parameters]
        out[np.ix_(idx, idx)] = corr[np.ix_(idx, idx)]
        return out

    def information_criteria(self) -> dict[str, float]:
        """AIC = n ln(RSS/n) + 2p and BIC = n ln(RSS/n) + p ln n of the fit (Gaussian residuals; n residuals,
        p fitted parameters, all of them: damping, period, initial states, offsets). Smaller is better; compare
        only fits of the same records by the same method."""
        n, p = self.info.n_obs, self.info.n_params
        base = n * math.log(max(self.info.rss, 1e-300) / n)
        return {"n_obs": n, "n_params": p, "aic": base + 2 * p, "bic": base + p * math.log(n)}

    def equivalent_damping(self, amplitude_deg, *, warn: bool = True) -> dict[str, np.ndarray]:
        """The equivalent linear damping at roll amplitudes `amplitude_deg` [deg]: `b_e_per_s` B_e(A) [1/s] and
        `zeta` ζ_eq(A) = B_e/(2ω) [-] with their standard errors, and `extrapolated` (True outside the
        amplitudes the records cover; a `UserWarning` says so when `warn`). ω: the fit's roll frequency."""
        a_deg = np.atleast_1d(np.asarray(amplitude_deg, dtype=float))
        g = equivalent_damping_gradient(np.radians(a_deg), self.omega0)
        be = g @ self.b
        var = np.einsum("ij,jk,ik->i", g, np.asarray(self.damping_covariance, dtype=float), g)
        se = np.sqrt(np.clip(var, 0, None))
        lo, hi = np.degrees(self.amplitude_range)
        tol = 1e-6 + 0.005 * hi if np.isfinite(hi) else 0.0
        extrapolated = (
            ~((a_deg >= lo - tol) & (a_deg <= hi + tol)) if np.isfinite(hi) else np.ones(a_deg.shape, bool)
        )
        if warn and extrapolated.any():
            warnings.warn(
                f"equivalent damping at {', '.join(f'{a:g}°' for a in a_deg[extrapolated])}: outside the amplitudes "
                f"the records cover ({lo:.2f}–{hi:.2f}°), an extrapolation of the {self.damping_model} model.",
                stacklevel=2,
            )
        w2 = 2 * self.omega0
        return {
            "amplitude_deg": a_deg,
            "b_e_per_s": be,
            "b_e_std_error_per_s": se,
            "zeta": be / w2,
            "zeta_std_error": se / w2,
            "extrapolated": extrapolated,
        }

    def equivalent_damping_table(self) -> dict[str, list]:
        """ζ_eq and B_e on `amplitude_grid` over the records' amplitudes (JSON-ready lists)."""
        lo, hi = np.degrees(self.amplitude_range)
        if not (np.isfinite(lo) and np.isfinite(hi)):
            return {}
        out = self.equivalent_damping(amplitude_grid(lo, hi), warn=False)
        return {k: np.asarray(v).tolist() for k, v in out.items()}

    def _repr_html_(self) -> str:
        """Jupyter's view: the damping and roll period with their standard errors and intervals."""
        from .._display import estimates_table

        rows = {
            **{k: v for k, v in self.damping.items() if k in self.fitted_parameters},
            "Tφ": self.roll_period,
            **{f"extinction {k}": v for k, v in self.extinction.items()},
        }
        eq = self.equivalent_damping_table()
        for a, z, s in zip(eq.get("amplitude_deg", []), eq.get("zeta", []), eq.get("zeta_std_error", [])):
            rows[f"ζ_eq({a:g}°)"] = Estimate(z, s, "-")
        return estimates_table(
            f"Decay fit ({self.method}, {self.damping_model})",
            rows,
            note="Tφ: fitted" if self.method == "ode" else "Tφ: observed (mean time between extremes)",
        )

    def to_dict(self) -> dict[str, Any]:
        """The fit as JSON-ready values (the CLI's calibration.json)."""
        ic = self.information_criteria()
        return {
            "method": self.method,
            "damping_model": self.damping_model,
            "fitted_parameters": list(self.fitted_parameters),
            "damping": {k: v.to_dict() for k, v in self.damping.items()},
            "damping_covariance": self.damping_covariance.tolist(),
            "damping_correlation": self.damping_correlation().tolist(),
            "information_criteria": {"aic": ic["aic"], "bic": ic["bic"]},
            "equivalent_damping": self.equivalent_damping_table(),
            "amplitude_range_deg": list(np.degrees(self.amplitude_range)),
            "extinction_coefficients_rad": {k: v.to_dict() for k, v in self.extinction.items()},
            "roll_period": self.roll_period.to_dict(),
            "omega0_rad_s": self.omega0,
            "records": [dict(r) for r in self.records],
            "diagnostics": self.info.to_dict(),
            "config": self.config,
        }

    def to_xarray(self):
        """The fit as an `xarray.Dataset` on `parameter` (b1, b2, b3; `estimates_dataset`): estimates, standard
        errors, 95 % intervals, covariance and correlation, the solver's diagnostics, the extinction coefficients
        a, b, c (`extinction_*`), the roll period Tφ and ω0, and ζ_eq, B_e on `amplitude_deg`; `method`,
        `damping_model` and the configuration as attributes."""
        from .._labels import config_attrs, labelled_values, merge
        from ._least_squares import estimates_dataset

        extra = {
            "roll_period_s": ((), self.roll_period.value, "s", "roll period Tφ"),
            "roll_period_std_error_s": ((), self.roll_period.std_error, "s", "standard error of Tφ"),
            "omega0_rad_s": ((), self.omega0, "rad s-1", "natural roll frequency ω0"),
            "correlation": (
                ("parameter", "parameter_2"),
                self.damping_correlation(),
                "1",
                "correlation of the estimates (NaN: not fitted)",
            ),
        }
        for k, e in self.extinction.items():
            unit = {"-": "1", "1/rad": "rad-1", "1/rad^2": "rad-2"}.get(e.unit, e.unit)
            extra[f"extinction_{k}"] = (
                (),
                e.value,
                unit,
                f"extinction coefficient {k} (decrement per half cycle)",
            )
            extra[f"extinction_{k}_std_error"] = ((), e.std_error, unit, f"standard error of {k}")
        ds = estimates_dataset(
            self.damping,
            self.damping_covariance,
            info=self.info,
            residual_unit="rad",
            extra=extra,
            attrs={"method": self.method, "damping_model": self.damping_model, **config_attrs(self.config)},
        )
        eq = self.equivalent_damping_table()
        if not eq:
            return ds
        a = ("amplitude_deg",)
        part = labelled_values(
            {
                "zeta_eq": (a, eq["zeta"], "1", "equivalent linear damping ratio ζ_eq(A)"),
                "zeta_eq_std_error": (a, eq["zeta_std_error"], "1", "standard error of ζ_eq(A)"),
                "b_e": (a, eq["b_e_per_s"], "s-1", "equivalent linear damping B_e(A) per unit inertia"),
                "b_e_std_error": (a, eq["b_e_std_error_per_s"], "s-1", "standard error of B_e(A)"),
                "extrapolated": (
                    a,
                    np.asarray(eq["extrapolated"]),
                    "1",
                    "outside the records' amplitudes (1: yes)",
                ),
            },
            coords={"amplitude_deg": (a, eq["amplitude_deg"], "degree", "roll amplitude A")},
        )
        return merge(ds, part)
