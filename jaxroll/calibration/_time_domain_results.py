"""Results of the time-domain calibration (`fit_roll_time_domain`, `fit_roll_kalman`): estimates with Student-t
intervals, per-record diagnostics, the identifiability report (formulas: docs/calibration.md, "Time-domain
calibration")."""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..ship._ship import Ship
from ._least_squares import Estimate


def t_quantile_975(dof: float) -> float:
    """0.975 quantile of Student's t with `dof` degrees of freedom (Cornish–Fisher series in 1/ν, error < 1e-4
    for ν ≥ 3; 1.959964 for ν = ∞)."""
    z = 1.959963984540054
    if not math.isfinite(dof):
        return z
    v = max(float(dof), 1.0)
    return (
        z
        + (z**3 + z) / (4 * v)
        + (5 * z**5 + 16 * z**3 + 3 * z) / (96 * v**2)
        + (3 * z**7 + 19 * z**5 + 17 * z**3 - 15 * z) / (384 * v**3)
        + (79 * z**9 + 776 * z**7 + 1482 * z**5 - 1920 * z**3 - 945 * z) / (92160 * v**4)
    )


@dataclasses.dataclass(frozen=True)
class ParameterEstimate(Estimate):
    """`Estimate` whose 95 % interval uses Student's t with `dof` degrees of freedom (the number of clusters
    − 1 for a cluster-robust SE; ∞: normal)."""

    dof: float = math.inf

    @property
    def ci95(self) -> tuple[float, float]:
        """The 95 % interval (Student-t with the clusters' degrees of freedom where given; the value's unit)."""
        t = t_quantile_975(self.dof)
        return (self.value - t * self.std_error, self.value + t * self.std_error)

    def to_dict(self) -> dict[str, Any]:
        """The estimate as JSON-ready values."""
        return {**super().to_dict(), "dof": self.dof}


@dataclasses.dataclass(frozen=True)
class RecordDiagnostics:
    """Fit diagnostics of one record. `residual_rms_deg / sensor_noise_deg` ≈ 1 says the model explains the
    record down to the sensor noise; well above 1 (> 1.2) points at model error (use `fit_roll_kalman`)."""

    source: str
    span_model_s: tuple[float, float]
    n_samples: int
    n_windows: int  # shooting windows (multiple shooting) or covariance blocks (Kalman)
    residual_rms_deg: float  # measured − simulated (shooting) or innovation (Kalman) rms [deg]
    sensor_noise_deg: float  # white noise estimated from the record (6th difference) [deg]
    extra: Mapping[str, float] = dataclasses.field(default_factory=dict)

    @property
    def residual_to_noise(self) -> float:
        """Residual rms over the record's sensor noise [-] (about 1 when the model explains the record)."""
        return self.residual_rms_deg / self.sensor_noise_deg if self.sensor_noise_deg > 0 else math.inf

    def to_dict(self) -> dict[str, Any]:
        """The diagnostics as JSON-ready values."""
        return {**dataclasses.asdict(self), "residual_to_noise": self.residual_to_noise}


@dataclasses.dataclass(frozen=True)
class Identifiability:
    """How well the records determine the parameters (from the covariance and the Jacobian/information)."""

    names: tuple[str, ...]
    correlation: np.ndarray
    condition_number: (
        float  # of the column-equilibrated Jacobian (shooting) or √ of the information's (Kalman)
    )
    variance_inflation: dict[str, float]  # 1/(1 − R²) of each parameter on the others
    relative_se: dict[str, float]  # SE / max(|value|, natural size)
    not_identified: tuple[str, ...]
    message: str

    def to_dict(self) -> dict[str, Any]:
        """The checks as JSON-ready values."""
        d = dataclasses.asdict(self)
        d["correlation"] = np.asarray(self.correlation).tolist()
        return d


@dataclasses.dataclass(frozen=True)
class TimeDomainFit:
    """Result of `fit_roll_time_domain` (multiple shooting) or `fit_roll_kalman` (state-space likelihood).

    - `estimates`: name → `ParameterEstimate` (value, std_error, unit, `.ci95`; SI units), in `names` order.
    - `covariance` (the reported one; `covariance_kind` says which), `covariance_model_based` (the other one).
    - `correlation`, `condition_number`, `identifiability`, `warnings` (identifiability and solver messages;
      also issued as `UserWarning` unless `warn=False`).
    - `n_windows`, `window_s`: clusters of the robust covariance (shooting windows or Kalman blocks).
    - `residual_rms_deg` (all records), `records` (per-record `RecordDiagnostics`).
    - `ship`: the input ship with the fitted values; `curves`: per window (shooting) or per record (Kalman)
      `time` [s, full scale], `measured` and `fitted` roll [rad] (shooting: the simulated roll; Kalman: the
      one-step prediction) and `record` (index), for the figures; `info`, `config`.
    """

    method: str
    estimates: dict[str, ParameterEstimate]
    names: tuple[str, ...]
    covariance: np.ndarray
    covariance_model_based: np.ndarray
    covariance_kind: str
    correlation: np.ndarray
    condition_number: float
    identifiability: Identifiability
    n_windows: int
    window_s: float
    residual_rms_deg: float
    records: list[RecordDiagnostics]
    ship: Ship
    warnings: tuple[str, ...]
    curves: dict[str, list]
    info: Any
    config: dict[str, Any]

    def _repr_html_(self) -> str:
        """Jupyter's view: the fitted parameters with their standard errors and intervals, and the diagnostics."""
        from .._display import estimates_table

        note = (
            f"{self.method}: {self.n_windows} windows of {self.window_s:.4g} s, residual rms "
            f"{self.residual_rms_deg:.4f}°, condition number {self.condition_number:.3g}, {self.covariance_kind} "
            "covariance" + "".join(f"; {w}" for w in self.warnings)
        )
        return estimates_table("Time-domain roll fit", self.estimates, note=note)

    def to_dict(self) -> dict[str, Any]:
        """Everything but the ship and the curves, as JSON-ready values (the CLI's calibration.json)."""
        info = self.info.to_dict() if hasattr(self.info, "to_dict") else dict(self.info)
        return {
            "method": self.method,
            "estimates": {k: e.to_dict() for k, e in self.estimates.items()},
            "correlation": {"names": list(self.names), "matrix": np.asarray(self.correlation).tolist()},
            "condition_number": self.condition_number,
            "covariance": {"names": list(self.names), "matrix": np.asarray(self.covariance).tolist()},
            "covariance_kind": self.covariance_kind,
            "covariance_model_based": np.asarray(self.covariance_model_based).tolist(),
            "identifiability": self.identifiability.to_dict(),
            "warnings": list(self.warnings),
            "windows": self.n_windows,
            "window_s": self.window_s,
            "residual_rms_deg": self.residual_rms_deg,
            "records": [r.to_dict() for r in self.records],
            "info": info,
            "config": self.config,
        }

    def to_xarray(self):
        """The fit as an `xarray.Dataset` on `parameter` (`estimates_dataset`: estimates, standard errors, 95 %
        intervals with `dof`, the reported `covariance` and `covariance_model_based`, `correlation`, variance
        inflation and relative SE), and per record on `record`: samples, windows, residual and sensor-noise rms
        [deg] and their ratio; `method`, `covariance_kind`, the identifiability message and the warnings as
        attributes."""
        import json

        from .._labels import config_attrs
        from ._least_squares import estimates_dataset

        p, pp, r = ("parameter",), ("parameter", "parameter_2"), ("record",)
        ident = self.identifiability
        col = lambda f: [f(x) for x in self.records]  # noqa: E731
        extra = {
            "dof": (
                p,
                [e.dof for e in self.estimates.values()],
                "1",
                "degrees of freedom of the 95 % interval",
            ),
            "covariance_model_based": (
                pp,
                np.asarray(self.covariance_model_based, dtype=float),
                "mixed: the product of the two parameters' units (unit)",
                "the other covariance (model-based)",
            ),
            "correlation": (
                pp,
                np.asarray(self.correlation, dtype=float),
                "1",
                "correlation of the estimates",
            ),
            "variance_inflation": (
                p,
                [ident.variance_inflation[n] for n in self.names],
                "1",
                "variance inflation 1/(1 − R²) on the other parameters",
            ),
            "relative_se": (
                p,
                [ident.relative_se[n] for n in self.names],
                "1",
                "SE / max(|value|, natural size)",
            ),
            "condition_number": ((), self.condition_number, "1", "condition number"),
            "n_windows": (
                (),
                self.n_windows,
                "1",
                "shooting windows or Kalman blocks (robust-covariance clusters)",
            ),
            "window_s": ((), self.window_s, "s", "window (block) length, full scale"),
            "residual_rms_deg": ((), self.residual_rms_deg, "degree", "residual rms over all records"),
            "record_n_samples": (r, col(lambda x: x.n_samples), "1", "samples of the record"),
            "record_n_windows": (r, col(lambda x: x.n_windows), "1", "windows (blocks) of the record"),
            "record_residual_rms_deg": (
                r,
                col(lambda x: x.residual_rms_deg),
                "degree",
                "residual rms of the record",
            ),
            "record_sensor_noise_deg": (
                r,
                col(lambda x: x.sensor_noise_deg),
                "degree",
                "white sensor noise estimated from the record",
            ),
            "record_residual_to_noise": (
                r,
                col(lambda x: x.residual_to_noise),
                "1",
                "residual rms / sensor noise",
            ),
        }
        ds = estimates_dataset(
            self.estimates,
            self.covariance,
            extra=extra,
            attrs={
                "method": self.method,
                "covariance_kind": self.covariance_kind,
                "identifiability": ident.message,
                "not_identified": json.dumps(list(ident.not_identified)),
                "warnings": json.dumps(list(self.warnings)),
                **config_attrs(self.config),
            },
        )
        return ds.assign_coords(record_source=(r, col(lambda x: x.source), {"long_name": "record file"}))


def identifiability(
    names,
    values,
    cov,
    natural,
    *,
    condition_number: float,
    max_vif: float = 100.0,
    max_rel_se: float = 0.5,
    check: Sequence[str] | None = None,
) -> Identifiability:
    """Correlations, variance-inflation factors and relative SEs; a parameter is *not identified* when its
    VIF > `max_vif` (multiple correlation with the others > 0.995) or its SE exceeds `max_rel_se` × its size
    max(|value|, natural size). Only the parameters in `check` (default: all) are flagged (nuisance noise
    intensities are reported only)."""
    names = tuple(names)
    cov = np.asarray(cov, dtype=float)
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se, se)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    np.fill_diagonal(corr, 1.0)
    try:
        vif_arr = np.diag(np.linalg.inv(corr))
    except np.linalg.LinAlgError:
        vif_arr = np.full(len(names), np.inf)
    vif = {n: float(v) for n, v in zip(names, vif_arr)}
    rel = {n: float(s / max(abs(v), nat)) for n, s, v, nat in zip(names, se, values, natural)}
    check = names if check is None else tuple(check)
    bad = tuple(n for n in check if not (vif[n] <= max_vif) or not (rel[n] <= max_rel_se))
    pairs = [
        f"{names[i]}–{names[j]} {corr[i, j]:+.3f}"
        for i in range(len(names))
        for j in range(i + 1, len(names))
        if abs(corr[i, j]) > 0.95
    ]
    msg = ""
    if bad:
        msg = (
            f"parameter(s) {', '.join(bad)} not identified by these records (variance inflation "
            + ", ".join(f"{n} {vif[n]:.3g}" for n in bad)
            + "; SE/size "
            + ", ".join(f"{n} {rel[n]:.3g}" for n in bad)
            + (f"; strong correlations {', '.join(pairs)}" if pairs else "")
            + "). Fix one of them from another test (decay: damping; captive: GM correction), or add records "
            "with larger roll."
        )
    return Identifiability(names, corr, float(condition_number), vif, rel, bad, msg)


def _issue(messages: Sequence[str], warn: bool) -> tuple[str, ...]:
    """The fit's warning messages, each issued as a UserWarning when `warn`."""
    if warn:
        for m in messages:
            warnings.warn("This warning appears because " + m, category=UserWarning, stacklevel=3)
    return tuple(messages)
