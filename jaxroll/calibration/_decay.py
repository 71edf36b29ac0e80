"""Free-roll decay records → damping b1, b2, b3 (formulas: docs/calibration.md §1).

- `fit_extinction`: the extinction curve Δφ = aφ_m + bφ_m² + cφ_m³ (decrement per half swing against the mean
  amplitude of the swing), fitted to the extremes and converted to b1, b2, b3 by energy balance
  (`extinction_to_damping`);
- `fit_decay_ode`: the roll equation itself, integrated with diffrax and fitted to the whole time series by
  Levenberg–Marquardt (forward-mode derivatives through the solver, `diffrax.ForwardMode()`)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._compiled import filter_jit
from .._config import require_float64
from ..io._records import Record, RecordError
from ..ship._restoring import restoring_moment
from ..ship._ship import Ship
from ._inputs import _as_list, _check_kind, _noise_std
from ._least_squares import Estimate, LeastSquaresInfo, _estimates, _gauss_newton_covariance, _least_squares


def extinction_to_damping(a, b, c, omega0):
    r"""Extinction coefficients → damping per unit inertia, by energy balance over a half swing
    (docs/calibration.md §1).

    With the decrement per half swing $\Delta\phi = a\phi_m + b\phi_m^2 + c\phi_m^3$ (radians) and
    $\phi = \phi_m\cos\omega_0 t$ over the swing: $b_1 = 2\omega_0 a/\pi$ [1/s], $b_2 = 3b/4$ [1/rad], $b_3 =
    8c/(3\pi\omega_0)$ [s/rad²]. If a, b, c are quoted per degree, convert first: $b_{rad} = b_{deg}\cdot
    180/\pi$, $c_{rad} = c_{deg}(180/\pi)^2$. `omega0` [rad/s].
    """
    return (2 * omega0 * a / math.pi, 0.75 * b, 8 * c / (3 * math.pi * omega0))


def damping_to_extinction(b1, b2, b3, omega0):
    """Inverse of `extinction_to_damping`: (a [-], b [1/rad], c [1/rad²]) from (b1, b2, b3) at ω0 [rad/s]."""
    return (math.pi * b1 / (2 * omega0), 4 * b2 / 3, 3 * math.pi * omega0 * b3 / 8)


@dataclasses.dataclass(frozen=True)
class Extremes:
    """Extremes of a decay record, one per half swing: time [s], signed value [rad]."""

    time: np.ndarray
    value: np.ndarray

    @property
    def mean_amplitude(self) -> np.ndarray:
        """φ_m = (|φ_n| + |φ_{n+1}|)/2 [rad]."""
        a = np.abs(self.value)
        return (a[:-1] + a[1:]) / 2

    @property
    def decrement(self) -> np.ndarray:
        """Δφ = |φ_n| − |φ_{n+1}| [rad] per half swing."""
        a = np.abs(self.value)
        return a[:-1] - a[1:]


def decay_extremes(
    record: Record, *, hysteresis_deg: float | None = None, min_amplitude_deg: float | None = None
) -> Extremes:
    """The extreme of every half swing of a decay record, refined by a local least-squares parabola.

    Half swings are separated by zero crossings with hysteresis (a crossing counts once |φ| passes
    `hysteresis_deg`, default 3× the estimated sensor noise), so noise near zero does not split a swing. The
    last, unfinished swing is dropped, and so are the swings after the amplitude first falls below
    `min_amplitude_deg` (default max(0.5°, 10× the noise)). The peak of each swing is the vertex of a parabola
    fitted over ±T/12 around the largest sample (T from the mean swing duration).
    """
    t, phi = record.time, record.roll
    sigma = _noise_std(phi)
    h = math.radians(hysteresis_deg) if hysteresis_deg is not None else 3 * sigma
    a_min = (
        math.radians(min_amplitude_deg)
        if min_amplitude_deg is not None
        else max(math.radians(0.5), 10 * sigma)
    )
    state = np.zeros(phi.size, dtype=int)
    s = 1 if phi[0] >= 0 else -1
    for i, v in enumerate(phi):  # hysteresis sign
        if s > 0 and v < -h:
            s = -1
        elif s < 0 and v > h:
            s = 1
        state[i] = s
    edges = np.nonzero(np.diff(state))[0] + 1
    bounds = np.concatenate([[0], edges, [phi.size]])
    segments = [(bounds[i], bounds[i + 1]) for i in range(bounds.size - 1)][:-1]  # last swing unfinished
    if len(segments) < 3:
        raise RecordError(
            f"{record.source}: only {len(segments)} complete half swings; a decay analysis needs "
            "at least 3 (record longer, or released from a larger angle)."
        )
    durations = np.array([t[b - 1] - t[a] for a, b in segments[1:]] or [t[-1] - t[0]])
    period = 2 * float(np.median(durations)) if durations.size else float(t[-1] - t[0])
    w = max(1, int(round(period / 12 / record.dt)))
    times, values = [], []
    for a, b in segments:
        seg = phi[a:b] * state[a]
        i = a + int(np.argmax(seg))
        lo, hi = max(i - w, 0), min(i + w + 1, phi.size)
        peak_t, peak_v = t[i], phi[i]
        if i - lo >= 1 and hi - i >= 2:
            tt = t[lo:hi] - t[i]
            coef = np.polyfit(tt, phi[lo:hi], 2)
            if coef[0] * state[a] < 0:
                tv = -coef[1] / (2 * coef[0])
                if abs(tv) <= tt[-1]:
                    peak_t, peak_v = t[i] + tv, np.polyval(coef, tv)
        if abs(peak_v) < a_min:
            break
        times.append(peak_t)
        values.append(peak_v)
    if len(values) < 4:
        raise RecordError(
            f"{record.source}: only {len(values)} extremes above {math.degrees(a_min):.2f}°; the "
            "extinction curve needs at least 4 (3 decrements)."
        )
    return Extremes(np.asarray(times), np.asarray(values))


@dataclasses.dataclass(frozen=True)
class DecayFit:
    """Damping from free-decay records by one method ("extinction" or "ode").

    `damping`: Estimates of b1 [1/s], b2 [1/rad], b3 [s/rad²]; `damping_covariance` (3×3, SI); `extinction`:
    a [-], b [1/rad], c [1/rad²] (extinction method, and implied by the ODE fit's b's); `roll_period`: Tφ [s]
    (fitted by the ODE method; the ship's own for the extinction method); `info`: solver diagnostics;
    `curves`: data for the figures.
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

    @property
    def b(self) -> np.ndarray:
        """(b1 [1/s], b2 [1/rad], b3 [s/rad²]) as an array."""
        return np.array([self.damping[k].value for k in ("b1", "b2", "b3")])

    def _repr_html_(self) -> str:
        """Jupyter's view: the damping and roll period with their standard errors and intervals."""
        from .._display import estimates_table

        rows = {
            **self.damping,
            "Tφ": self.roll_period,
            **{f"extinction {k}": v for k, v in self.extinction.items()},
        }
        return estimates_table(
            f"Decay fit ({self.method})",
            rows,
            note="Tφ: fitted" if self.method == "ode" else "Tφ: the ship's (not fitted)",
        )

    def to_dict(self) -> dict[str, Any]:
        """The fit as JSON-ready values (the CLI's calibration.json)."""
        return {
            "method": self.method,
            "damping": {k: v.to_dict() for k, v in self.damping.items()},
            "damping_covariance": self.damping_covariance.tolist(),
            "extinction_coefficients_rad": {k: v.to_dict() for k, v in self.extinction.items()},
            "roll_period": self.roll_period.to_dict(),
            "omega0_rad_s": self.omega0,
            "diagnostics": self.info.to_dict(),
            "config": self.config,
        }

    def to_xarray(self):
        """The fit as an `xarray.Dataset` on `parameter` (b1, b2, b3; `estimates_dataset`): estimates, standard
        errors, 95 % intervals and covariance, the solver's diagnostics, the extinction coefficients a, b, c
        (`extinction_*`), the roll period Tφ and ω0; `method` and the configuration as attributes."""
        from .._labels import config_attrs
        from ._least_squares import estimates_dataset

        extra = {
            "roll_period_s": ((), self.roll_period.value, "s", "roll period Tφ"),
            "roll_period_std_error_s": ((), self.roll_period.std_error, "s", "standard error of Tφ"),
            "omega0_rad_s": ((), self.omega0, "rad s-1", "natural roll frequency ω0"),
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
        return estimates_dataset(
            self.damping,
            self.damping_covariance,
            info=self.info,
            residual_unit="rad",
            extra=extra,
            attrs={"method": self.method, **config_attrs(self.config)},
        )


def _extinction_residual(theta, args):
    x, y = args
    return (theta[0] * x + theta[1] * x**2 + theta[2] * x**3) - y


def _fit_abc(ext: Sequence[Extremes]):
    pm = np.concatenate([e.mean_amplitude for e in ext])
    dec = np.concatenate([e.decrement for e in ext])
    theta, j, _, info = _least_squares(
        _extinction_residual, jnp.zeros(3), (jnp.asarray(pm), jnp.asarray(dec))
    )
    return theta, _gauss_newton_covariance(j, info.sigma), info, pm, dec


def _extinction_thresholds(record: Record, hysteresis_deg, min_amplitude_deg) -> tuple[float, float]:
    sigma = math.degrees(_noise_std(record.roll))
    h = hysteresis_deg if hysteresis_deg is not None else 3 * sigma
    a_min = min_amplitude_deg if min_amplitude_deg is not None else max(0.5, 10 * sigma)
    return h, a_min


def fit_extinction(
    records: Record | Sequence[Record],
    ship: Ship,
    *,
    hysteresis_deg: float | None = None,
    min_amplitude_deg: float | None = None,
    correct_bias: bool = True,
) -> DecayFit:
    """Damping from the extinction curve of one or more decay records (pooled decrements).

    Fits Δφ = aφ_m + bφ_m² + cφ_m³ [rad] by least squares (optimistix Levenberg–Marquardt; the problem is
    linear, so it converges in a step) and converts with `extinction_to_damping` at ω0 = 2π/Tφ of `ship`.
    Standard errors are Gauss–Newton, s²(JᵀJ)⁻¹, propagated linearly to b1, b2, b3.

    The conversion is first order in the damping and ignores the restoring nonlinearity: on the default ship
    from 20° it biases b1 and b2 by about 1 % and b3 by 0.1–0.2 s/rad² (docs/calibration.md). With
    `correct_bias` (default) the bias is removed by simulation: find b such that a noise-free decay of the
    ship with damping b, sampled and analysed like the record, gives the measured a, b, c (two fixed-point
    iterations b ← b + (b̂ − b̂_sim)). The raw conversion is kept in `curves["uncorrected"]`.
    """
    require_float64("jaxroll.fit_extinction")
    records = _as_list(records)
    _check_kind(records, "decay")
    thresholds = [_extinction_thresholds(r, hysteresis_deg, min_amplitude_deg) for r in records]
    ext = [decay_extremes(r, hysteresis_deg=h, min_amplitude_deg=a) for r, (h, a) in zip(records, thresholds)]
    theta, cov_abc, info, pm, dec = _fit_abc(ext)
    omega0 = float(ship.omega0)
    m = np.diag([2 * omega0 / math.pi, 0.75, 8 / (3 * math.pi * omega0)])
    b_raw = m @ theta
    cov_b = m @ cov_abc @ m.T
    b = b_raw.copy()
    if correct_bias:
        starts = []
        for r, e in zip(records, ext):
            i0 = int(np.argmin(np.abs(r.time - e.time[0])))
            starts.append((i0, float(e.value[0])))
        for _ in range(2):
            sim_ext = []
            s = eqx.tree_at(lambda x: x.damping, ship, jnp.asarray(np.maximum(b, [0.0, 0.0, -np.inf])))
            for r, (h, a), (i0, phi0) in zip(records, thresholds, starts):
                ts = jnp.asarray(r.time[i0:] - r.time[i0])
                phi = np.concatenate([r.roll[:i0], np.asarray(_decay_solution_jit(s, phi0, 0.0, ts))])
                sim = dataclasses.replace(r, channels={"roll": phi})
                sim_ext.append(decay_extremes(sim, hysteresis_deg=h, min_amplitude_deg=a))
            b = b + (b_raw - m @ _fit_abc(sim_ext)[0])
    periods = [2 * np.median(np.diff(e.time)) for e in ext]
    return DecayFit(
        method="extinction",
        damping=_estimates(("b1", "b2", "b3"), b, cov_b, ("1/s", "1/rad", "s/rad^2")),
        damping_covariance=cov_b,
        extinction=_estimates(("a", "b", "c"), theta, cov_abc, ("-", "1/rad", "1/rad^2")),
        roll_period=Estimate(float(ship.roll_period), 0.0, "s"),
        omega0=omega0,
        info=info,
        curves={
            "mean_amplitude": pm,
            "decrement": dec,
            "extremes": ext,
            "uncorrected": b_raw,
            "observed_period_s": float(np.mean(periods)),
        },
        config={
            "hysteresis_deg": [h for h, _ in thresholds],
            "min_amplitude_deg": [a for _, a in thresholds],
            "correct_bias": correct_bias,
            "records": [r.source for r in records],
            "omega0_from": "ship roll_period",
        },
    )


def _decay_ship(ship: Ship, b, period_ratio) -> Ship:
    """`ship` with damping b and roll period Tφ·period_ratio (restoring a3…a9 scaled with ω0², GZ shape
    kept)."""
    scale = period_ratio**-2
    return eqx.tree_at(
        lambda s: (s.damping, s.roll_period, s.restoring),
        ship,
        (jnp.asarray(b, dtype=float), ship.roll_period * period_ratio, ship.restoring * scale),
    )


def decay_solution(ship: Ship, phi0, dphi0, ts, *, rtol: float = 1e-9, atol: float = 1e-12):
    """φ(t) [rad] of the free decay (P = 0) of `ship` from (φ0, φ̇0) at t = 0, saved at `ts` [s] (diffrax
    Tsit5,
    adaptive, forward-mode differentiable)."""

    def field(t, y, args):
        return jnp.stack(
            [
                y[1],
                -(y[1] * (args.damping[0] + args.damping[1] * jnp.abs(y[1]) + args.damping[2] * y[1] ** 2))
                - restoring_moment(args, y[0]),
            ]
        )

    import diffrax  # here: every other command would pay its import (~0.1 s)

    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(field),
        diffrax.Tsit5(),
        t0=0.0,
        t1=ts[-1],
        dt0=None,
        y0=jnp.stack([jnp.asarray(phi0, dtype=float), jnp.asarray(dphi0, dtype=float)]),
        args=ship,
        saveat=diffrax.SaveAt(ts=ts),
        stepsize_controller=diffrax.PIDController(rtol=rtol, atol=atol),
        adjoint=diffrax.ForwardMode(),
        max_steps=200_000,
    )
    return sol.ys[:, 0]


def _decay_residual(theta, args):
    ship, fit_period, series = args
    omega_ship = ship.omega0
    n_global = 4 if fit_period else 3
    ratio = jnp.exp(theta[3]) if fit_period else jnp.asarray(1.0)
    b = jnp.stack([theta[0] * omega_ship, theta[1], theta[2] / omega_ship])
    s = _decay_ship(ship, b, ratio)
    out = []
    for k, (ts, phi) in enumerate(series):
        out.append(
            decay_solution(s, theta[n_global + 2 * k], theta[n_global + 2 * k + 1] * omega_ship, ts) - phi
        )
    return jnp.concatenate(out)


_decay_solution_jit = filter_jit(decay_solution)


def fit_decay_ode(
    records: Record | Sequence[Record],
    ship: Ship,
    *,
    fit_period: bool = True,
    initial_damping=None,
    start_s: float | None = None,
    samples_per_period: int = 50,
) -> DecayFit:
    """Damping (and the roll period) by fitting the roll equation to decay time series (diffrax + optimistix).

    Unknowns: β1 = b1/ω0, β2 = b2, β3 = b3·ω0 (dimensionless, so Levenberg–Marquardt sees similar scales), the
    period ratio Tφ/Tφ_ship (if `fit_period`; a3…a9 scale with ω0² so the GZ shape is kept), and the initial
    state (φ, φ̇) of each record at its first extreme (or at `start_s` [s, full scale]). Residuals are φ_model
    − φ_meas at every sample; the Jacobian comes from forward-mode differentiation through the solver
    (`adjoint=diffrax.ForwardMode()`); standard errors are s²(JᵀJ)⁻¹ with s the residual std.

    `initial_damping`: starting (b1, b2, b3) (default: the ship's, with β1 ≥ 0.01 and β2 ≥ 0.05).
    `samples_per_period`: records sampled more densely than this many samples per roll period are decimated (every
    k-th sample) before the fit: a 10⁶-row record then fits in seconds, and the standard errors are not made
    over-confident by residuals correlated over neighbouring samples. The factor k is in `config["decimation"]`."""
    require_float64("jaxroll.fit_decay_ode")
    if not (isinstance(samples_per_period, int) and samples_per_period >= 8):
        raise ValueError(f"`samples_per_period` must be an integer >= 8; got {samples_per_period!r}.")
    records = _as_list(records)
    _check_kind(records, "decay")
    omega_ship = float(ship.omega0)
    starts, series, decimation = [], [], []
    for r in records:
        if start_s is None:
            i0 = int(np.argmax(np.abs(r.roll[: max(int(round(ship.roll_period / r.dt)), 2)])))
        else:
            i0 = int(np.searchsorted(r.time, start_s))
            if i0 >= r.time.size - 16:
                raise RecordError(f"{r.source}: start_s = {start_s} s leaves fewer than 16 samples.")
        k = max(1, int(ship.roll_period / r.dt) // samples_per_period)
        decimation.append(k)
        ts = jnp.asarray(r.time[i0::k] - r.time[i0])
        series.append((ts, jnp.asarray(r.roll[i0::k])))
        starts.append((float(r.roll[i0]), 0.0))
    b0 = np.asarray(ship.damping if initial_damping is None else initial_damping, dtype=float)
    beta0 = [max(b0[0] / omega_ship, 0.01), max(b0[1], 0.05), b0[2] * omega_ship]
    n_rec = len(records)
    theta0 = np.concatenate([beta0, [0.0] if fit_period else [], np.ravel(starts)])
    n_global = 4 if fit_period else 3

    args = (ship, fit_period, tuple(series))
    theta, j, r, info = _least_squares(_decay_residual, jnp.asarray(theta0), args)
    cov_theta = _gauss_newton_covariance(j, info.sigma)
    # Jacobian of (b1, b2, b3, Tφ) with respect to θ (global part).
    ratio = math.exp(theta[3]) if fit_period else 1.0
    d = np.diag([omega_ship, 1.0, 1 / omega_ship])
    b = d @ theta[:3]
    cov_b = d @ cov_theta[:3, :3] @ d.T
    period = float(ship.roll_period) * ratio
    period_se = period * math.sqrt(cov_theta[3, 3]) if fit_period else 0.0
    omega = 2 * math.pi / period
    # Extinction coefficients implied by the fitted b's (for the figure and the comparison of methods).
    m = np.diag([math.pi / (2 * omega), 4 / 3, 3 * math.pi * omega / 8])
    abc = m @ b
    fitted = r + np.concatenate([np.asarray(p) for _, p in series])
    return DecayFit(
        method="ode",
        damping=_estimates(("b1", "b2", "b3"), b, cov_b, ("1/s", "1/rad", "s/rad^2")),
        damping_covariance=cov_b,
        extinction=_estimates(("a", "b", "c"), abc, m @ cov_b @ m.T, ("-", "1/rad", "1/rad^2")),
        roll_period=Estimate(period, period_se, "s"),
        omega0=omega,
        info=info,
        curves={
            "time": [np.asarray(ts) for ts, _ in series],
            "measured": [np.asarray(p) for _, p in series],
            "fitted": np.split(fitted, np.cumsum([p.size for _, p in series])[:-1]),
            "initial_state": theta[n_global:].reshape(n_rec, 2) * np.array([1.0, omega_ship]),
        },
        config={
            "fit_period": fit_period,
            "start_s": start_s,
            "records": [r.source for r in records],
            "decimation": decimation,
            "solver": "diffrax Tsit5 (rtol 1e-9), optimistix LevenbergMarquardt, jac fwd",
        },
    )


def decay_agreement(a: DecayFit, b: DecayFit) -> dict[str, float]:
    """z-scores (difference / combined standard error) of b1, b2, b3 between two decay fits.

    The two methods use the same record, so their errors are positively correlated and |z| is conservative.
    """
    out = {}
    for k in ("b1", "b2", "b3"):
        ea, eb = a.damping[k], b.damping[k]
        se = math.hypot(ea.std_error, eb.std_error)
        out[k] = (ea.value - eb.value) / se if se > 0 else float("inf")
    return out
