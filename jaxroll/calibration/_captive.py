"""Captive tests → the GM correction σ_obs/σ_thr (docs/calibration.md §2).

ΔGM measured at fixed heel against ΔGM from Grim's effective wave of the measured wave
(`effective_wave_from_probe`) through the ship's non-memory polynomial: the paper's σ_obs/σ_thr, a
least-squares scale factor, and optionally the polynomial itself, with cluster-robust confidence intervals
(blocks of the records as clusters)."""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Sequence
from typing import Any

import jax.numpy as jnp
import numpy as np

from .._config import require_float64
from ..io._records import Record
from ..sea._grim import grim_transfer
from ..sea._spectra import GRAVITY, wave_frequencies_from_encounter
from ..ship._restoring import delta_gm
from ..ship._ship import Ship
from ._inputs import PAPER_WINDOW_MODEL_S, _as_list, _check_kind, check_wave_heights, lab_records
from ._least_squares import Estimate, LeastSquaresInfo, _estimates, _least_squares, _sandwich


def effective_wave_from_probe(
    wave, dt: float, *, length: float, probe_x: float, speed: float = 0.0, pad_factor: int = 2
):
    """Grim's effective wave ζ_G(t) [m] reconstructed from one wave probe in long-crested head seas.

    The probe record η(t) [m] at x = `probe_x` [m] (relative to amidships, positive towards the bow, fixed to
    the ship) is decomposed by FFT into components Re[A_j e^{iω_j t}] at encounter frequencies ω_j; each
    has the wave number k_j = ω_j²/g of its absolute frequency (head seas at speed U: ω_e = ω + ω²U/g), so the
    component at amidships is A_j e^{−ik_j x} and its effective wave F(k_j)A_j e^{−ik_j x} (Grim's transfer,
    crest amidships positive). The mean is removed first; the record is zero-padded to `pad_factor`× its
    length, so the reconstruction is reliable away from the ends (keep ≳ |x|/c_g + a few wave periods at each
    end: the paper's window 70–340 s of a 0–360 s record is ample).

    **Arguments:** `wave` [m], `dt` [s] (full scale, uniform); `length`: L [m]; `probe_x` [m]; `speed` [m/s].

    **Returns:** ζ_G [m], same length as `wave`.
    """
    from ..sea._grim import _fft_length

    wave = jnp.asarray(wave, dtype=float)
    n = wave.shape[-1]
    m = _fft_length(pad_factor * n)
    spec = jnp.fft.rfft(wave - jnp.mean(wave), n=m)
    omega_e = jnp.arange(m // 2 + 1, dtype=float) * (2 * jnp.pi / (m * dt))
    omega = wave_frequencies_from_encounter(omega_e, speed, "head")[0][:, 0]
    k = omega**2 / GRAVITY
    transfer = grim_transfer(k, length).astype(complex) * jnp.exp(-1j * k.astype(complex) * probe_x)
    return jnp.fft.irfft(spec * transfer, n=m)[:n]


@dataclasses.dataclass(frozen=True)
class CaptiveGroup:
    """Captive results for one (H1/3, T01, heel) group of records."""

    wave_height: float
    wave_period: float
    heel_deg: float
    n_records: int
    std_observed: float  # pooled std of the measured ΔGM [m]
    std_theory: float  # pooled std of Grim + polynomial ΔGM [m]
    std_ratio: Estimate  # σ_obs/σ_thr, the paper's correction
    ls_scale: Estimate  # least-squares scale factor r in ΔGM_obs ≈ r·ΔGM_thr
    per_record_ratio: np.ndarray

    def to_dict(self) -> dict[str, Any]:
        """The group as JSON-ready values."""
        return {
            "wave_height_m": self.wave_height,
            "wave_period_s": self.wave_period,
            "heel_deg": self.heel_deg,
            "n_records": self.n_records,
            "std_observed_m": self.std_observed,
            "std_theory_m": self.std_theory,
            "std_ratio": self.std_ratio.to_dict(),
            "ls_scale": self.ls_scale.to_dict(),
            "per_record_ratio": self.per_record_ratio.tolist(),
        }


@dataclasses.dataclass(frozen=True)
class CaptiveFit:
    """σ_obs/σ_thr and the least-squares scale from captive records (pooled, and per sea state and heel)."""

    std_ratio: Estimate
    ls_scale: Estimate
    groups: list[CaptiveGroup]
    polynomial: dict[str, Estimate] | None
    polynomial_covariance: np.ndarray | None
    info: LeastSquaresInfo
    series: list[dict[str, np.ndarray]]
    config: dict[str, Any]

    def _repr_html_(self) -> str:
        """Jupyter's view: σ_obs/σ_thr and the least-squares scale (and the ΔGM polynomial when fitted)."""
        from .._display import estimates_table

        rows = {
            "σobs/σthr (paper)": self.std_ratio,
            "least-squares scale": self.ls_scale,
            **(self.polynomial or {}),
        }
        return estimates_table(
            "Captive fit: GM correction",
            rows,
            note=f"{sum(g.n_records for g in self.groups)} records in {len(self.groups)} sea-state "
            "and heel groups.",
        )

    def correction(self, estimator: str = "std_ratio") -> Estimate:
        """The GM correction to put in the ship: "std_ratio" (the paper's σ_obs/σ_thr) or "ls" (the LS
        scale)."""
        if estimator == "std_ratio":
            return self.std_ratio
        if estimator == "ls":
            return self.ls_scale
        raise ValueError(f"`estimator` must be 'std_ratio' or 'ls'; got {estimator!r}.")

    def to_dict(self) -> dict[str, Any]:
        """The fit as JSON-ready values (the CLI's calibration.json)."""
        out = {
            "std_ratio": self.std_ratio.to_dict(),
            "ls_scale": self.ls_scale.to_dict(),
            "groups": [g.to_dict() for g in self.groups],
            "diagnostics": self.info.to_dict(),
            "config": self.config,
        }
        if self.polynomial is not None:
            out["polynomial"] = {k: v.to_dict() for k, v in self.polynomial.items()}
            out["polynomial_covariance"] = self.polynomial_covariance.tolist()
        return out

    def to_xarray(self):
        """The fit as an `xarray.Dataset` on `parameter` (std_ratio, ls_scale; `estimates_dataset`) with the
        solver's diagnostics, and per (H1/3, T01, heel) group on `group`: `wave_height_m`, `wave_period_s`,
        `heel_deg`, `n_records`, `std_observed_m`, `std_theory_m`, `group_std_ratio`, `group_ls_scale` (and their
        standard errors), `per_record_ratio` on (`group`, `group_record`; NaN beyond a group's records)."""
        from .._labels import config_attrs
        from ._least_squares import estimates_dataset

        g, gr = ("group",), ("group", "group_record")
        width = max((len(x.per_record_ratio) for x in self.groups), default=0)
        ratios = np.full((len(self.groups), width), np.nan)
        for i, x in enumerate(self.groups):
            ratios[i, : len(x.per_record_ratio)] = x.per_record_ratio
        col = lambda f: [f(x) for x in self.groups]  # noqa: E731
        extra = {
            "wave_height_m": (
                g,
                col(lambda x: x.wave_height),
                "m",
                "significant wave height H1/3 (full scale)",
            ),
            "wave_period_s": (g, col(lambda x: x.wave_period), "s", "mean wave period T01 (full scale)"),
            "heel_deg": (g, col(lambda x: x.heel_deg), "degree", "fixed heel of the captive test"),
            "n_records": (g, col(lambda x: x.n_records), "1", "records in the group"),
            "std_observed_m": (
                g,
                col(lambda x: x.std_observed),
                "m",
                "pooled standard deviation of the measured ΔGM",
            ),
            "std_theory_m": (
                g,
                col(lambda x: x.std_theory),
                "m",
                "pooled standard deviation of the theory's ΔGM",
            ),
            "group_std_ratio": (g, col(lambda x: x.std_ratio.value), "1", "σ_obs/σ_thr of the group"),
            "group_std_ratio_std_error": (g, col(lambda x: x.std_ratio.std_error), "1", "its standard error"),
            "group_ls_scale": (g, col(lambda x: x.ls_scale.value), "1", "least-squares scale of the group"),
            "group_ls_scale_std_error": (g, col(lambda x: x.ls_scale.std_error), "1", "its standard error"),
            "per_record_ratio": (gr, ratios, "1", "σ_obs/σ_thr per record"),
        }
        estimates = {"std_ratio": self.std_ratio, "ls_scale": self.ls_scale}
        return estimates_dataset(
            estimates, None, info=self.info, residual_unit="m", extra=extra, attrs=config_attrs(self.config)
        )


def _scale_residual(theta, args):
    x, y = args
    return theta[0] * x - y


def _poly_residual(theta, args):
    z, y = args
    return jnp.polyval(theta[::-1], z) - y


def _ratio_estimate(sy, sx, clusters) -> Estimate:
    """σ_y/σ_x from per-sample squares, SE by the delta method with clusters (ratio of sums)."""
    ids, inv = np.unique(clusters, return_inverse=True)
    yc = np.bincount(inv, sy)
    xc = np.bincount(inv, sx)
    r2 = yc.sum() / xc.sum()
    g = ids.size
    var_r2 = np.sum((yc - r2 * xc) ** 2) / xc.sum() ** 2 * g / max(g - 1, 1)
    r = math.sqrt(r2)
    return Estimate(r, math.sqrt(var_r2) / (2 * r), "-")


def _check_delta_gm_unit(ratio: float, records: Sequence[Record]) -> None:
    """Warn when σ_obs/σ_thr is beyond 5 either way (the paper's is 0.8): a ΔGM column's unit slip, named when
    its factor fits (mm or cm labelled m, m labelled mm, full-scale values in a model-scale file)."""
    if 0.2 <= ratio <= 5.0:
        return
    lam = records[0].scale
    slips = ((1e3, "ΔGM in mm labelled m"), (1e2, "ΔGM in cm labelled m"), (1e-3, "ΔGM in m labelled mm"))
    slips += ((lam, f"full-scale ΔGM in a model-scale file (λ = {lam:g})"),) if lam != 1 else ()
    likely = next((w for f, w in slips if abs(math.log(ratio / f)) < math.log(1.5)), None)
    warnings.warn(
        f"{records[0].source} (and the other captive records): σ_obs/σ_thr = {ratio:.3g}: the measured ΔGM is "
        f"{ratio:.3g} × the theory's (tanks find 0.5–1.5)"
        + (f"; likely {likely}" if likely else "")
        + ": check the delta_gm column's unit (CLI --units delta_gm=mm) and the ship's ΔGM coefficients.",
        stacklevel=3,
    )


def fit_captive(
    records: Record | Sequence[Record],
    ship: Ship,
    *,
    window_model_s: tuple[float, float] = PAPER_WINDOW_MODEL_S,
    fit_polynomial: bool = False,
    polynomial_degree: int | None = None,
    block_model_s: float = 10.0,
) -> CaptiveFit:
    """The GM correction σ_obs/σ_thr from captive tests (records of ΔGM at fixed heel with a wave probe).

    For each record, within `window_model_s` [s, model scale]: ζ_G from the probe
    (`effective_wave_from_probe`),
    ζ_mid = −ζ_G, ΔGM_thr = Σ C_k ζ_mid^k with the ship's coefficients (no correction), and the measured
    ΔGM_obs. Both are taken about their record means (the heel's own GM shift is not part of the correction).

    - `std_ratio`: the paper's σ_obs/σ_thr = √(Σ(ΔGM_obs − mean)² / Σ(ΔGM_thr − mean)²), pooled over records
      (and per group (H1/3, T01, heel) in `groups`).
    - `ls_scale`: least-squares r in ΔGM_obs ≈ r·ΔGM_thr (optimistix). It is unbiased by noise on ΔGM_obs,
      which inflates the std ratio by √(1 + σ_noise²/σ_obs²); noise on the probe attenuates it instead.
    - `polynomial` (with `fit_polynomial`): the observed polynomial ΔGM_obs ≈ Σ_k C_k ζ_mid^k, k ≤
      `polynomial_degree` (default: the ship's highest non-zero power, at least 3), not centred.

    Residuals are correlated in time, so standard errors are cluster-robust, with blocks of `block_model_s`
    [s, model scale] of each record as clusters (the sandwich for the LS fits, the delta method for the
    ratio).
    """
    require_float64("jaxroll.fit_captive")
    records = _as_list(records)
    _check_kind(records, "captive")
    wave_heights = check_wave_heights(records, window_model_s)
    records = lab_records(records, window_model_s)  # the rest before the waves said
    series, clusters = [], []
    cid = 0
    for r in records:
        zg_full = effective_wave_from_probe(
            r.wave, r.dt, length=float(ship.lpp), probe_x=r.probe_x, speed=r.speed
        )
        keep = r.window(*window_model_s)
        idx = np.searchsorted(r.time, keep.time)
        zeta_mid = -np.asarray(zg_full)[idx]
        thr = np.asarray(delta_gm(ship, zeta_mid))
        obs = keep.delta_gm
        block = np.floor((keep.model_time - keep.model_time[0]) / block_model_s).astype(int)
        series.append(
            {"time": keep.time, "zeta_mid": zeta_mid, "theory": thr, "observed": obs, "source": r.source}
        )
        clusters.append(cid + block)
        cid += int(block.max()) + 1
    clusters = np.concatenate(clusters)
    x = np.concatenate([s["theory"] - s["theory"].mean() for s in series])
    y = np.concatenate([s["observed"] - s["observed"].mean() for s in series])
    theta, j, res, info = _least_squares(_scale_residual, jnp.ones(1), (jnp.asarray(x), jnp.asarray(y)))
    ls = Estimate(float(theta[0]), float(np.sqrt(_sandwich(j, res, clusters)[0, 0])), "-")
    ratio = _ratio_estimate(y**2, x**2, clusters)
    _check_delta_gm_unit(ratio.value, records)
    # groups
    groups = []
    keys = [(r.wave_height, r.wave_period, float(r.meta["heel_deg"])) for r in records]
    offsets = np.cumsum([0] + [s["time"].size for s in series])
    for key in dict.fromkeys(keys):
        members = [i for i, k in enumerate(keys) if k == key]
        sel = np.concatenate([np.arange(offsets[i], offsets[i + 1]) for i in members])
        xs, ys, cs = x[sel], y[sel], clusters[sel]
        bread = 1 / np.sum(xs**2)
        r_g = float(np.sum(xs * ys) * bread)
        e = ys - r_g * xs
        ids, inv = np.unique(cs, return_inverse=True)
        score = np.bincount(inv, xs * e)
        var = bread**2 * np.sum(score**2) * ids.size / max(ids.size - 1, 1)
        per = np.array([np.std(series[i]["observed"]) / np.std(series[i]["theory"]) for i in members])
        groups.append(
            CaptiveGroup(
                key[0],
                key[1],
                key[2],
                len(members),
                float(np.sqrt(np.mean(ys**2))),
                float(np.sqrt(np.mean(xs**2))),
                _ratio_estimate(ys**2, xs**2, cs),
                Estimate(r_g, math.sqrt(var), "-"),
                per,
            )
        )
    poly = poly_cov = None
    if fit_polynomial:
        c = np.asarray(ship.delta_gm)
        deg = (
            polynomial_degree
            if polynomial_degree is not None
            else max(3, int(np.max(np.nonzero(c)[0], initial=0)))
        )
        z = np.concatenate([s["zeta_mid"] for s in series])
        yy = np.concatenate([s["observed"] for s in series])
        theta_p, jp, rp, _ = _least_squares(
            _poly_residual, jnp.asarray(c[: deg + 1]), (jnp.asarray(z), jnp.asarray(yy))
        )
        poly_cov = _sandwich(jp, rp, clusters)
        poly = _estimates(
            [f"c{k}" for k in range(deg + 1)], theta_p, poly_cov, [f"m^{1 - k}" for k in range(deg + 1)]
        )
    return CaptiveFit(
        ratio,
        ls,
        groups,
        poly,
        poly_cov,
        info,
        series,
        {
            "window_model_s": list(window_model_s),
            "block_model_s": block_model_s,
            "records": [r.source for r in records],
            "fit_polynomial": fit_polynomial,
            "theory": "Grim effective wave from the probe (FFT, dispersion) + ship ΔGM polynomial",
            "wave_height_check": wave_heights,
        },
    )
