"""Free-running roll → damping and/or the GM correction from the amplitude PDFs (docs/calibration.md §3).

`fit_roll_pdf` fits the parameters such that the model's amplitude distributions (Monte Carlo with common
random numbers through the project's integrator, or a theory PDF) match the experimental zero-crossing and
envelope distributions (band means of the distributions); the uncertainty is a sandwich with a bootstrap over
realizations."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from .._compiled import filter_jit
from .._config import require_float64
from ..io._records import Record, RecordError, group_by_sea_state
from ..roll._amplitudes import amplitude_samples
from ..roll._monte_carlo import simulate_chunk
from ..roll._observers import AbstractObserver
from ..sea._spectra import ITTC
from ..ship._ship import Ship
from ._inputs import (
    PAPER_WINDOW_MODEL_S,
    _as_list,
    _check_kind,
    _noise_std,
    check_wave_heights,
    lab_records,
)
from ._least_squares import (
    _PARAMS,
    Estimate,
    LeastSquaresInfo,
    _estimates,
    _get_param,
    _least_squares,
    _set_params,
)

#: Quantile levels bounding the bands whose means `fit_roll_pdf` matches (both estimators).
DEFAULT_BANDS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99)
ESTIMATORS = ("zero_crossing", "envelope")


def band_means(values, mask, edges):
    """Means of `values[mask]` between successive quantile bands `edges` (e.g. 0, 0.1, …, 0.99): the empirical
    quantile function Q(u) (= the i-th order statistic on [i/n, (i+1)/n)) averaged over each band,
    ∫_{q_j}^{q_{j+1}} Q(u) du / (q_{j+1} − q_j). Continuous and differentiable in `values`; its pathwise
    derivative averages the derivatives of every sample in the band, so it has far less Monte Carlo noise than
    a single quantile (one order statistic).
    """
    values = jnp.ravel(values)
    mask = jnp.ravel(mask)
    top = jnp.max(jnp.where(mask, values, -jnp.inf))
    s = jnp.sort(jnp.where(mask, values, top + 1e3))
    count = jnp.sum(mask)
    n = count.astype(float)
    cum = jnp.concatenate([jnp.zeros(1), jnp.cumsum(s)])
    edges = jnp.asarray(edges, dtype=float)
    x = edges * n
    i = jnp.clip(jnp.floor(x).astype(int), 0, count - 1)
    g = (cum[i] + (x - i.astype(x.dtype)) * s[i]) / n  # ∫_0^q Q(u) du
    return jnp.diff(g) / jnp.diff(edges)


def _np_band_means(x: np.ndarray, edges) -> np.ndarray:
    s = np.sort(x)
    n = s.size
    cum = np.concatenate([[0.0], np.cumsum(s)])
    e = np.asarray(edges, dtype=float)
    i = np.clip(np.floor(e * n).astype(int), 0, n - 1)
    g = (cum[i] + (e * n - i) * s[i]) / n
    return np.diff(g) / np.diff(e)


_amplitude_samples_jit = filter_jit(amplitude_samples)


class BandMeans(AbstractObserver):
    """Observer of the roll-PDF calibration: the model's roll sampled like the records (every `sub`-th step from
    t = 0, the first `start` samples left out), with the records' sensor noise `noise` [rad] added (keyed by the
    realization, so common random numbers hold), then the band means of the zero-crossing (with `hysteresis`
    [rad]) and envelope amplitudes over all surviving realizations of the chunk.

    Band means are not additive over chunks: evaluate it in one chunk with `simulate_chunk` (as the calibration
    objective does), not through `monte_carlo`.
    """

    sub: int
    start: int
    bands: tuple
    estimators: tuple
    noise: Any
    hysteresis: Any

    def init(self, problem, key):
        return jr.fold_in(key, 0x5E45)

    def observe(self, problem, state, k, y, alive):
        return state, y[0]

    def reduce(self, problem, states, outputs, end, valid):
        phi0 = jnp.broadcast_to(problem.phi0, outputs[:, :1].shape)
        phi = jnp.concatenate([phi0, outputs], axis=1)[:, :: self.sub][:, self.start :]
        phi = phi + self.noise * jax.vmap(lambda k: jr.normal(k, phi.shape[1:]))(states)
        zc, zc_mask, env = amplitude_samples(phi, self.hysteresis)
        alive = (valid & ~end.capsized)[:, None]
        out = []
        for est in self.estimators:
            if est == "zero_crossing":
                out.append(band_means(zc, zc_mask & alive, self.bands))
            else:
                out.append(band_means(env, jnp.broadcast_to(alive, env.shape), self.bands))
        return {"band_means": jnp.concatenate(out)}, {"phi": phi, "capsized": end.capsized & valid}

    def result(self, summed, per, config):
        return summed["band_means"], per["phi"], per["capsized"]


def _model_band_means(ship, problem, key, num_realizations, num_steps, observer):
    """Model band means of the amplitude estimators from `num_realizations` realizations keyed
    `fold_in(key, i)` (common random numbers), through the one Monte Carlo body (`simulate_chunk`)."""
    problem = eqx.tree_at(lambda p: p.ship, problem, ship)
    indices = jnp.arange(num_realizations)
    summed, per = simulate_chunk(
        problem, key, indices, jnp.ones(num_realizations, bool), observer, num_steps, remat=True
    )
    return summed["band_means"], per["phi"], per["capsized"]


def _theory_band_means(theory, ship, sea, grid, bands):
    """Band means (as `band_means`) of the amplitude distribution with PDF `theory(ship, sea, grid)`."""
    pdf = jnp.maximum(jnp.asarray(theory(ship, sea, grid), dtype=float), 0.0)
    trap = lambda f: jnp.concatenate([jnp.zeros(1), jnp.cumsum((f[1:] + f[:-1]) / 2 * jnp.diff(grid))])
    cdf = trap(pdf)
    first = trap(grid * pdf) / cdf[-1]
    cdf = cdf / cdf[-1]
    m = jnp.interp(jnp.asarray(bands, dtype=float), cdf, first)
    return jnp.diff(m) / jnp.diff(jnp.asarray(bands, dtype=float))


class _RollObjective(eqx.Module):
    """θ → whitened band-mean residuals over all sea states (a module, so optimistix reuses the
    compilation)."""

    ship: Ship
    problems: tuple
    seas: tuple
    key: Any
    observer: BandMeans
    targets: tuple
    weights: tuple
    scales: Any
    names: tuple = eqx.field(static=True)
    num_realizations: int = eqx.field(static=True)
    num_steps: int = eqx.field(static=True)
    bands: tuple = eqx.field(static=True)
    theory: Any = eqx.field(static=True)
    grid: Any
    derivative: str = eqx.field(static=True)
    fd_step: float = eqx.field(static=True)

    def ship_at(self, theta) -> Ship:
        return _set_params(self.ship, self.names, theta * self.scales)

    def band_means(self, theta):
        ship = self.ship_at(theta)
        out = []
        for prob, sea in zip(self.problems, self.seas):
            if self.theory is not None:
                out.append(_theory_band_means(self.theory, ship, sea, self.grid, self.bands))
            else:
                out.append(
                    _model_band_means(
                        ship, prob, self.key, self.num_realizations, self.num_steps, self.observer
                    )[0]
                )
        return out

    def residual(self, theta):
        q = self.band_means(theta)
        return jnp.concatenate([(qm - t) * w for qm, t, w in zip(q, self.targets, self.weights)])

    def __call__(self, theta, args):
        if self.derivative == "fd" and self.theory is None:
            return _fd_residual(theta, objective=self)
        return self.residual(theta)


@eqx.filter_custom_jvp
def _fd_residual(theta, *, objective):
    return objective.residual(theta)


@_fd_residual.def_jvp
def _fd_residual_jvp(primals, tangents, *, objective):
    """Directional derivative by central differences with common random numbers (see `fit_roll_pdf`)."""
    (theta,), (t_theta,) = primals, tangents
    y = objective.residual(theta)
    if t_theta is None:
        return y, jnp.zeros_like(y)
    h = objective.fd_step
    eye = jnp.eye(theta.size)
    cols = [(objective.residual(theta + h * e) - objective.residual(theta - h * e)) / (2 * h) for e in eye]
    return y, jnp.stack(cols, axis=1) @ t_theta


@dataclasses.dataclass(frozen=True)
class SeaStateComparison:
    """Experiment and model for one sea state: band means [rad] (estimators × bands, flattened), the
    experiment's covariance, the capsizes in the model, and the amplitude samples [rad] for the figures."""

    wave_height: float
    wave_period: float
    n_records: int
    bands: tuple[float, ...]
    estimators: tuple[str, ...]
    experiment_band_means: np.ndarray  # [rad], estimators × bands, flattened
    experiment_covariance: np.ndarray
    model_band_means_before: np.ndarray
    model_band_means_after: np.ndarray
    samples: dict[
        str, Any
    ]  # "experiment"/"before"/"after" → {"zero_crossing": [...], "envelope": [...]} [rad]
    capsized_before: int
    capsized_after: int

    def to_dict(self) -> dict[str, Any]:
        """The comparison as JSON-ready values."""
        return {
            "wave_height_m": self.wave_height,
            "wave_period_s": self.wave_period,
            "n_records": self.n_records,
            "estimators": list(self.estimators),
            "bands": list(self.bands),
            "experiment_band_means_deg": np.degrees(self.experiment_band_means).tolist(),
            "experiment_std_error_deg": np.degrees(np.sqrt(np.diag(self.experiment_covariance))).tolist(),
            "model_band_means_before_deg": np.degrees(self.model_band_means_before).tolist(),
            "model_band_means_after_deg": np.degrees(self.model_band_means_after).tolist(),
            "model_capsized_before": self.capsized_before,
            "model_capsized_after": self.capsized_after,
        }


@dataclasses.dataclass(frozen=True)
class RollFit:
    """Damping and/or GM correction fitted to free-running amplitude distributions."""

    estimates: dict[str, Estimate]
    covariance: np.ndarray
    initial: dict[str, float]
    ship: Ship
    comparisons: list[SeaStateComparison]
    info: LeastSquaresInfo  # rss: sum of squared residuals, each in its own standard errors
    config: dict[str, Any]

    def _repr_html_(self) -> str:
        """Jupyter's view: the fitted parameters with their standard errors and intervals."""
        from .._display import estimates_table

        return estimates_table(
            "Roll fit (amplitude PDFs)",
            self.estimates,
            note=f"{len(self.comparisons)} sea states; started from "
            + ", ".join(f"{k} = {v:.5g}" for k, v in self.initial.items()),
        )

    def to_dict(self) -> dict[str, Any]:
        """The fit as JSON-ready values (the CLI's calibration.json)."""
        return {
            "estimates": {k: v.to_dict() for k, v in self.estimates.items()},
            "covariance": self.covariance.tolist(),
            "initial": self.initial,
            "sea_states": [c.to_dict() for c in self.comparisons],
            "diagnostics": self.info.to_dict(),
            "config": self.config,
        }

    def to_xarray(self):
        """The fit as an `xarray.Dataset` on `parameter` (`estimates_dataset`; residuals in their standard errors)
        with `initial` values, and per sea state on `sea_state`: `wave_height_m`, `wave_period_s`, `n_records`,
        the experiment's and the model's band means [deg] on (`sea_state`, `estimator_band`: the estimators' bands
        one after the other, as in calibration.json) and the model's capsizes before and after the fit."""
        from .._labels import config_attrs
        from ._least_squares import estimates_dataset

        c, cb = ("sea_state",), ("sea_state", "estimator_band")
        col = lambda f: np.asarray([f(x) for x in self.comparisons])  # noqa: E731
        deg = lambda f: np.degrees(col(f))  # noqa: E731
        extra = {
            "initial": (
                ("parameter",),
                [self.initial[k] for k in self.estimates],
                "mixed: the parameter's unit (unit)",
                "value the fit started from",
            ),
            "wave_height_m": (
                c,
                col(lambda x: x.wave_height),
                "m",
                "significant wave height H1/3 (full scale)",
            ),
            "wave_period_s": (c, col(lambda x: x.wave_period), "s", "mean wave period T01 (full scale)"),
            "n_records": (c, col(lambda x: x.n_records), "1", "records of the sea state"),
            "experiment_band_means_deg": (
                cb,
                deg(lambda x: x.experiment_band_means),
                "degree",
                "the records' mean amplitude per probability band",
            ),
            "experiment_std_error_deg": (
                cb,
                deg(lambda x: np.sqrt(np.diag(x.experiment_covariance))),
                "degree",
                "its standard error (bootstrap over records)",
            ),
            "model_band_means_before_deg": (
                cb,
                deg(lambda x: x.model_band_means_before),
                "degree",
                "the model's band means before the fit",
            ),
            "model_band_means_after_deg": (
                cb,
                deg(lambda x: x.model_band_means_after),
                "degree",
                "the model's band means after the fit",
            ),
            "model_capsized_before": (
                c,
                col(lambda x: x.capsized_before),
                "1",
                "model trials capsized before",
            ),
            "model_capsized_after": (c, col(lambda x: x.capsized_after), "1", "model trials capsized after"),
        }
        return estimates_dataset(
            self.estimates,
            self.covariance,
            info=self.info,
            residual_unit="1",  # each residual in its standard errors
            extra=extra,
            attrs=config_attrs(self.config),
        )


def _experiment_samples(records: Sequence[Record], window, hysteresis):
    zcs, envs = [], []
    for r in records:
        w = r.window(*window)
        zc, m, env = _amplitude_samples_jit(jnp.asarray(w.roll)[None], hysteresis)
        zcs.append(np.asarray(zc[0])[np.asarray(m[0])])
        envs.append(np.asarray(env[0]))
    return zcs, envs


def _np_band_means_all(samples_by_est, bands):
    return np.concatenate([_np_band_means(np.concatenate(s), bands) for s in samples_by_est])


def _bootstrap_covariance(samples_by_est, bands, n_boot, rng):
    """Covariance of the pooled band means by resampling whole realizations (records) with replacement."""
    n = len(samples_by_est[0])
    qs = []
    for _ in range(n_boot):
        pick = rng.integers(0, n, n)
        qs.append(_np_band_means_all([[s[i] for i in pick] for s in samples_by_est], bands))
    return np.cov(np.array(qs).T)


_NATURAL_SCALE = {"gm_correction": 1.0, "b1": 0.01, "b2": 0.1, "b3": 1.0}
_ROLL_FTOL = 0.5


def fit_roll_pdf(
    records: Record | Sequence[Record],
    ship: Ship,
    *,
    params: Sequence[str] = ("gm_correction",),
    key=None,
    num_realizations: int = 96,
    method: str = "superposition",
    dt: float | None = None,
    window_model_s: tuple[float, float] = PAPER_WINDOW_MODEL_S,
    bands: Sequence[float] = DEFAULT_BANDS,
    estimators: Sequence[str] = ESTIMATORS,
    theory: Callable | None = None,
    sensor_noise_deg: float | None = None,
    hysteresis_deg: float | None = None,
    derivative: str = "fd",
    fd_step: float = 0.02,
    num_bootstrap: int = 200,
    max_steps: int = 30,
    tol: float = 5e-3,
    seed: int = 0,
) -> RollFit:
    """Fit `params` (any of gm_correction, b1, b2, b3) so that the model's roll-amplitude distributions match
    free-running records (zero-crossing and envelope estimators, the paper's Figs. 10–11).

    **Objective.** For each sea state (records grouped by H1/3, T01) and estimator, the *band means* of the
    amplitude distribution (`band_means`: the quantile function averaged between the quantile levels `bands`,
    default 0, 0.1, …, 0.9, 0.95, 0.99) of the model minus the experiment's (pooled over the records, within
    `window_model_s`), each divided by its standard error; minimised by Levenberg–Marquardt (optimistix). The
    model side is a Monte Carlo through the project's integrator (`RollProblem.from_sea(...,
    excitation=method)` and `roll_time_series`; same start φ(0) as the records, same window, sampling, sensor
    noise and estimators) with **common random numbers**: realization i always uses `fold_in(key, i)`, so the
    objective is a deterministic, continuous function of the parameters. Capsized model realizations are
    excluded. The records' sensor noise (`sensor_noise_deg`, default: estimated from the records) is added to
    the model's roll with fixed keys, and zero crossings use a hysteresis (`hysteresis_deg`, default 3× the
    noise) on both sides, so that noise does not split swings into spurious small amplitudes.

    **Derivatives.** `derivative="fd"` (default): central differences of the common-random-number objective at
    a step of `fd_step` × the parameter's size, supplied to optimistix as the JVP (`eqx.filter_custom_jvp`).
    `derivative="pathwise"`: forward-mode autodiff through the simulation. The pathwise derivative of these
    long-horizon statistics is *not* the derivative of the statistic: the roll phase relative to a fixed wave
    path is neutrally stable, so the sampled statistic is rough on small parameter scales, and the pathwise
    slopes measured on the default ship had the wrong sign for the lower bands (docs/calibration.md). Near the
    optimum the roughness makes Levenberg–Marquardt reject every proposal; the solve stops after three
    rejections in a row, or when the parameters move by less than `tol` relative.

    **Theory instead of Monte Carlo.** `theory(ship, sea, a)` → PDF [1/rad] of the amplitude at the grid `a`
    [rad] (any normalisation; JAX-differentiable in `ship`), for the single estimator in `estimators`; its
    band means replace the Monte Carlo and are differentiated by autodiff.

    **Uncertainty.** The covariance Σ_e of the experimental band means comes from a bootstrap over records
    (whole realizations), the model's Σ_m from a bootstrap over its realizations; the parameter covariance is
    the sandwich (JᵀWJ)⁻¹JᵀW(Σ_e + Σ_m)WJ(JᵀWJ)⁻¹ with W = diag(1/(σ_e² + σ_m²)).

    !!! note
        The amplitude distribution mostly depends on the excitation-to-damping ratio (in Roberts' theory only
        on b_i/K with K ∝ r²): fitting the GM correction together with linear damping is nearly degenerate.
        Fit one of them, with the other from decay or captive tests; the covariance shows the degeneracy if
        you don't.

    **Returns:** `RollFit`.
    """
    require_float64("jaxroll.fit_roll_pdf")
    from ..roll._equation import RollProblem

    records = _as_list(records)
    _check_kind(records, "roll")
    params = tuple(params)
    for p in params:
        if p not in _PARAMS:
            raise ValueError(f"unknown parameter {p!r}; choose from {sorted(_PARAMS)}.")
    estimators = tuple(estimators)
    for e in estimators:
        if e not in ESTIMATORS:
            raise ValueError(f"unknown estimator {e!r}; choose from {ESTIMATORS}.")
    if derivative not in ("fd", "pathwise"):
        raise ValueError(f"`derivative` must be 'fd' or 'pathwise'; got {derivative!r}.")
    if theory is not None and len(estimators) != 1:
        raise ValueError(
            "with `theory`, name the one estimator its PDF describes: estimators=('envelope',) or "
            "('zero_crossing',)."
        )
    bands = tuple(float(q) for q in bands)
    check_wave_heights(records, window_model_s)
    records = lab_records(records, window_model_s)  # the rest said, the roll offset removed
    groups = group_by_sea_state(records)
    for (hs, t01), recs in groups.items():
        if len(recs) < 3:
            raise ValueError(
                f"sea state H1/3 = {hs} m, T01 = {t01} s has {len(recs)} record(s); the roll-PDF fit "
                "needs at least 3 per sea state (the experimental error is a bootstrap over records)."
            )
    rec_dt = records[0].dt
    for r in records:
        if abs(r.dt - rec_dt) > 1e-9 * rec_dt:
            raise RecordError(
                f"{r.source}: sampling interval {r.dt} s differs from {records[0].source} ({rec_dt} s)."
            )
    sub = max(1, math.ceil(rec_dt / 0.25 - 1e-9)) if dt is None else int(round(rec_dt / dt))
    dt_model = rec_dt / sub
    lam = records[0].scale
    start = int(round(window_model_s[0] * math.sqrt(lam) / rec_dt))
    stop = int(round(window_model_s[1] * math.sqrt(lam) / rec_dt))
    num_steps = stop * sub
    if sensor_noise_deg is None:
        noise = float(np.median([_noise_std(r.window(*window_model_s).roll) for r in records]))
    else:
        noise = math.radians(sensor_noise_deg)
    hyst = 3 * noise if hysteresis_deg is None else math.radians(hysteresis_deg)
    key = jr.key(seed) if key is None else key
    rng = np.random.default_rng(seed)

    problems, seas, targets, cov_e, exp_samples = [], [], [], [], []
    for (hs, t01), recs in groups.items():
        sea = ITTC(hs, t01)
        phi0 = float(recs[0].meta.get("initial_roll_deg", 5.0))
        prob = RollProblem.from_sea(
            ship, sea, speed=recs[0].speed, excitation=method, dt=dt_model, phi0=math.radians(phi0)
        )
        zcs, envs = _experiment_samples(recs, window_model_s, hyst)
        by_est = [zcs if e == "zero_crossing" else envs for e in estimators]
        problems.append(prob)
        seas.append(sea)
        targets.append(_np_band_means_all(by_est, bands))
        cov_e.append(_bootstrap_covariance(by_est, bands, num_bootstrap, rng))
        exp_samples.append({"zero_crossing": zcs, "envelope": envs})

    # θ = value / scale, with the scale such that a change of `tol`·(natural size) of a parameter is one unit
    # of
    # the solver's absolute tolerance _ROLL_FTOL, which also bounds the change of every whitened residual (in
    # standard errors): Levenberg–Marquardt then stops once the parameters move by less than `tol` relative,
    # whatever the small-scale roughness of a finite Monte Carlo.
    scales = (
        np.array([max(abs(float(_get_param(ship, p))), _NATURAL_SCALE[p]) for p in params]) * tol / _ROLL_FTOL
    )
    theta0 = np.array([float(_get_param(ship, p)) for p in params]) / scales
    grid = jnp.linspace(0.0, math.radians(90.0), 4001)

    observer = BandMeans(sub, start, bands, estimators, jnp.asarray(noise), jnp.asarray(hyst))

    def model_run(s: Ship):
        out = []
        for prob in problems:
            q, phi, cap = _model_band_means_jit(s, prob, key, num_realizations, num_steps, observer)
            out.append((np.asarray(q), np.asarray(phi), np.asarray(cap)))
        return out

    if theory is None:
        before = model_run(ship)
        cov_m = []
        for q, phi, cap in before:
            zc, m, env = (np.asarray(a) for a in _amplitude_samples_jit(jnp.asarray(phi), hyst))
            alive = ~cap
            by_est = [
                [zc[i][m[i]] for i in np.nonzero(alive)[0]]
                if e == "zero_crossing"
                else [env[i] for i in np.nonzero(alive)[0]]
                for e in estimators
            ]
            cov_m.append(_bootstrap_covariance(by_est, bands, num_bootstrap, rng))
    else:
        before = [
            (np.asarray(_theory_band_means(theory, ship, sea, grid, bands)), None, None) for sea in seas
        ]
        cov_m = [np.zeros_like(c) for c in cov_e]
    weights = [1 / np.sqrt(np.diag(ce) + np.diag(cm)) for ce, cm in zip(cov_e, cov_m)]
    objective = _RollObjective(
        ship,
        tuple(problems),
        tuple(seas),
        key,
        observer,
        tuple(jnp.asarray(t) for t in targets),
        tuple(jnp.asarray(w) for w in weights),
        jnp.asarray(scales),
        params,
        num_realizations,
        num_steps,
        bands,
        theory,
        grid,
        derivative,
        fd_step * _ROLL_FTOL / tol,
    )
    theta, j, res, info = _least_squares(
        objective, jnp.asarray(theta0), None, max_steps=max_steps, rtol=0.0, atol=_ROLL_FTOL, stall_steps=3
    )
    values = theta * scales
    fitted = _set_params(ship, params, values)
    # sandwich covariance with the full band-mean covariance
    w_all = np.concatenate(weights)
    sigma = np.zeros((w_all.size, w_all.size))
    o = 0
    for ce, cm in zip(cov_e, cov_m):
        k = ce.shape[0]
        sigma[o : o + k, o : o + k] = ce + cm
        o += k
    jw = j  # Jacobian of the whitened residuals (W^½ J)
    bread = np.linalg.pinv(jw.T @ jw)
    meat = jw.T @ (w_all[:, None] * sigma * w_all[None, :]) @ jw
    cov_theta = bread @ meat @ bread
    cov = np.diag(scales) @ cov_theta @ np.diag(scales)
    after = (
        model_run(fitted)
        if theory is None
        else [(np.asarray(_theory_band_means(theory, fitted, sea, grid, bands)), None, None) for sea in seas]
    )

    def model_samples(run):
        if run[1] is None:
            return None
        zc, m, env = (np.asarray(a) for a in _amplitude_samples_jit(jnp.asarray(run[1]), hyst))
        alive = np.nonzero(~run[2])[0]
        return {"zero_crossing": [zc[i][m[i]] for i in alive], "envelope": [env[i] for i in alive]}

    comparisons = []
    for g, ((hs, t01), recs) in enumerate(groups.items()):
        comparisons.append(
            SeaStateComparison(
                hs,
                t01,
                len(recs),
                bands,
                estimators,
                targets[g],
                cov_e[g],
                before[g][0],
                after[g][0],
                {
                    "experiment": exp_samples[g],
                    "before": model_samples(before[g]),
                    "after": model_samples(after[g]),
                },
                int(before[g][2].sum()) if before[g][2] is not None else 0,
                int(after[g][2].sum()) if after[g][2] is not None else 0,
            )
        )
    units = [_PARAMS[p][2] for p in params]
    return RollFit(
        estimates=_estimates(params, values, cov, units),
        covariance=cov,
        initial={p: float(_get_param(ship, p)) for p in params},
        ship=fitted,
        comparisons=comparisons,
        info=info,
        config={
            "params": list(params),
            "num_realizations": num_realizations,
            "method": method,
            "dt_s": dt_model,
            "window_model_s": list(window_model_s),
            "roll_offset_deg": [r.meta["roll_offset_deg"] for r in records],
            "bands": list(bands),
            "estimators": list(estimators),
            "theory": None if theory is None else getattr(theory, "__name__", repr(theory)),
            "num_bootstrap": num_bootstrap,
            "seed": seed,
            "records": [r.source for r in records],
            "sensor_noise_deg": math.degrees(noise),
            "hysteresis_deg": math.degrees(hyst),
            "derivative": derivative if theory is None else "autodiff (theory)",
            "fd_step": fd_step,
            "objective": "band means of the amplitude distributions, model − experiment, in standard errors; "
            "common random numbers",
        },
    )


_model_band_means_jit = filter_jit(_model_band_means)
