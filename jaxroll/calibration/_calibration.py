"""Calibration straight from tank records, by least squares with optimistix (formulas: docs/calibration.md).

1. **Decay** (free-roll decay records → b1, b2, b3):
   - `fit_extinction`: the extinction curve Δφ = aφ_m + bφ_m² + cφ_m³ (decrement per half swing against the
     mean amplitude of the swing), fitted to the extremes and converted to b1, b2, b3 by energy balance
     (`extinction_to_damping`);
   - `fit_decay_ode`: the roll equation itself, integrated with diffrax and fitted to the whole time series by
     Levenberg–Marquardt (forward-mode derivatives through the solver, `diffrax.ForwardMode()`).
2. **Captive** (`fit_captive`): ΔGM measured at fixed heel against ΔGM from Grim's effective wave of the
   measured wave (`effective_wave_from_probe`) through the ship's non-memory polynomial: the paper's
   σ_obs/σ_thr, a least-squares scale factor, and optionally the polynomial itself, with cluster-robust
   confidence intervals.
3. **Free-running roll** (`fit_roll_pdf`): damping and/or the GM correction such that the model's amplitude
   distributions (Monte Carlo with common random numbers through the project's integrator, or a theory PDF)
   match the experimental zero-crossing and envelope distributions (band means of the distributions).

Uncertainties are Gauss–Newton: covariance = s² (JᵀJ)⁻¹ with s² = RSS/(n − p), or a sandwich where residuals
are correlated (captive: blocks of the records as clusters; roll: a bootstrap over realizations)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import optimistix as optx

from ..roll._amplitudes import hilbert_envelope
from ..sea._grim import grim_transfer
from ..io._records import Record, RecordError, group_by_sea_state
from ..ship._restoring import delta_gm, restoring_moment
from ..ship._ship import Ship
from ..sea._spectra import GRAVITY, ITTC, wave_frequencies_from_encounter

#: The paper's analysis window of the irregular-wave tank tests [s, model scale, from the wave maker's start].
PAPER_WINDOW_MODEL_S = (70.0, 340.0)


# ------------------------------------------------------------------------------------------------------------
# Results
# ------------------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Estimate:
    """A fitted value with its standard error (normal 95 % interval = value ± 1.96·SE), in SI units."""

    value: float
    std_error: float
    unit: str = "-"

    @property
    def ci95(self) -> tuple[float, float]:
        return (self.value - 1.959964 * self.std_error, self.value + 1.959964 * self.std_error)

    def to_dict(self) -> dict[str, Any]:
        return {"value": self.value, "std_error": self.std_error, "ci95": list(self.ci95), "unit": self.unit}


def _estimates(names, values, cov, units) -> dict[str, Estimate]:
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    return {n: Estimate(float(v), float(s), u) for n, v, s, u in zip(names, values, se, units)}


@dataclasses.dataclass(frozen=True)
class LeastSquaresInfo:
    """Diagnostics of one optimistix least-squares solve."""

    n_obs: int
    n_params: int
    rss: float
    sigma: float  # residual standard deviation s = √(RSS/(n − p)) in the residual's units
    num_steps: int
    result: str  # optimistix result message ("" when successful)
    condition_number: float

    @property
    def converged(self) -> bool:
        return self.result == ""

    def to_dict(self) -> dict[str, Any]:
        return {**dataclasses.asdict(self), "converged": self.converged}


@eqx.filter_jit
def _solve(fn, theta0, args, max_steps, rtol, atol):
    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    sol = optx.least_squares(
        fn, solver, theta0, args, max_steps=max_steps, throw=False, options={"jac": "fwd"}
    )
    return sol.value, sol.result, sol.stats["num_steps"]


@eqx.filter_jit
def _residual_and_jacobian(fn, theta, args):
    return fn(theta, args), jax.jacfwd(fn)(theta, args)


class _WithAux(eqx.Module):
    fn: Any

    def __call__(self, y, args):
        return self.fn(y, args), None


_OPTIONS = {"jac": "fwd"}


@eqx.filter_jit
def _lm_init(solver, fn, y, args):
    f_struct, aux_struct = eqx.filter_eval_shape(fn, y, args)
    return solver.init(fn, y, args, _OPTIONS, f_struct, aux_struct, frozenset())


@eqx.filter_jit
def _lm_step(solver, fn, y, args, state):
    y, state, _ = solver.step(fn, y, args, _OPTIONS, state, frozenset())
    return y, state


def _solve_stepwise(fn, theta0, args, max_steps, rtol, atol, stall_steps):
    """Levenberg–Marquardt step by step (optimistix's own `step`), stopping also after `stall_steps` rejected
    proposals in a row: a Monte Carlo objective with common random numbers is rough below the scale of its
    statistical error, so near the optimum every proposal can look worse and the trust region shrinks
    forever."""
    solver = optx.LevenbergMarquardt(rtol=rtol, atol=atol)
    fn = _WithAux(fn)
    y = theta0
    state = _lm_init(solver, fn, y, args)
    message = "the maximum number of steps was reached; increase `max_steps`"
    steps = 0
    for steps in range(1, max_steps + 1):
        y, state = _lm_step(solver, fn, y, args, state)
        if bool(state.terminate):
            message = "" if state.result == optx.RESULTS.successful else str(optx.RESULTS[state.result])
            break
        if int(state.num_steps_since_acceptance) >= stall_steps:
            message = ""  # converged to the resolution of the objective
            break
    return y, message, steps


def _least_squares(fn, theta0, args, *, max_steps=200, rtol=1e-8, atol=1e-10, stall_steps=None):
    """Levenberg–Marquardt (optimistix, forward-mode Jacobian); returns θ̂, J(θ̂), residuals, info.

    `fn(theta, args)` should be a module-level function (or an `eqx.Module`) so that its compilation is reused
    between calls. With `stall_steps`, the solve also stops after that many rejected steps in a row."""
    theta0 = jnp.asarray(theta0, dtype=float)
    if stall_steps is None:
        theta, result, steps = _solve(fn, theta0, args, max_steps, rtol, atol)
        msg = "" if result == optx.RESULTS.successful else str(optx.RESULTS[result])
    else:
        theta, msg, steps = _solve_stepwise(fn, theta0, args, max_steps, rtol, atol, stall_steps)
    res, jac = _residual_and_jacobian(fn, theta, args)
    r = np.asarray(res, dtype=float)
    j = np.asarray(jac, dtype=float).reshape(r.size, -1)
    n, p = j.shape
    rss = float(r @ r)
    sv = np.linalg.svd(j, compute_uv=False)
    info = LeastSquaresInfo(
        n,
        p,
        rss,
        math.sqrt(rss / max(n - p, 1)),
        int(steps),
        msg,
        float(sv[0] / sv[-1]) if sv[-1] > 0 else float("inf"),
    )
    return np.asarray(theta, dtype=float), j, r, info


def _gauss_newton_covariance(j: np.ndarray, sigma: float) -> np.ndarray:
    return sigma**2 * np.linalg.pinv(j.T @ j)


def _sandwich(j: np.ndarray, r: np.ndarray, clusters: np.ndarray) -> np.ndarray:
    """Cluster-robust covariance (JᵀJ)⁻¹ [Σ_c (J_cᵀ r_c)(J_cᵀ r_c)ᵀ] (JᵀJ)⁻¹ · G/(G − 1)."""
    bread = np.linalg.pinv(j.T @ j)
    ids = np.unique(clusters)
    scores = np.stack([j[clusters == c].T @ r[clusters == c] for c in ids])
    g = ids.size
    return bread @ (scores.T @ scores) @ bread * (g / max(g - 1, 1))


# ------------------------------------------------------------------------------------------------------------
# 1. Free-roll decay
# ------------------------------------------------------------------------------------------------------------


def extinction_to_damping(a, b, c, omega0):
    r"""Extinction coefficients → damping per unit inertia (energy balance over a half swing, THEORY.md §3).

    With the decrement per half swing $\Delta\phi = a\phi_m + b\phi_m^2 + c\phi_m^3$ (radians) and
    $\phi = \phi_m\cos\omega_0 t$ over the swing: $b_1 = 2\omega_0 a/\pi$ [1/s], $b_2 = 3b/4$ [1/rad], $b_3 =
    8c/(3\pi\omega_0)$ [s/rad²]. If a, b, c are quoted per degree, convert first: $b_{rad} = b_{deg}\cdot
    180/\pi$, $c_{rad} = c_{deg}(180/\pi)^2$. `omega0` [rad/s].
    """
    return (2 * omega0 * a / math.pi, 0.75 * b, 8 * c / (3 * math.pi * omega0))


def damping_to_extinction(b1, b2, b3, omega0):
    """Inverse of `extinction_to_damping`: (a [-], b [1/rad], c [1/rad²]) from (b1, b2, b3) at ω0 [rad/s]."""
    return (math.pi * b1 / (2 * omega0), 4 * b2 / 3, 3 * math.pi * omega0 * b3 / 8)


def _noise_std(x: np.ndarray, order: int = 6) -> float:
    """Std of white measurement noise on a smooth, well-sampled series: the robust (MAD) std of its
    `order`-th difference divided by √C(2·order, order). A sinusoid sampled 20 times per period contributes
    (2π/20)⁶ ≈ 1e-3 of its amplitude to the sixth difference, so the signal does not leak into it."""
    d = np.diff(np.asarray(x, dtype=float), n=order)
    mad = np.median(np.abs(d - np.median(d)))
    return float(1.482602 * mad / math.sqrt(math.comb(2 * order, order)))


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
        return np.array([self.damping[k].value for k in ("b1", "b2", "b3")])

    def to_dict(self) -> dict[str, Any]:
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


def _as_list(records) -> list[Record]:
    if isinstance(records, Record):
        return [records]
    records = list(records)
    if not records:
        raise ValueError("no records given.")
    return records


def _check_kind(records: Sequence[Record], kind: str) -> None:
    for r in records:
        if r.kind != kind:
            raise RecordError(f"{r.source}: a {kind} record is needed here; this is a {r.kind} record.")


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


_decay_solution_jit = eqx.filter_jit(decay_solution)


def fit_decay_ode(
    records: Record | Sequence[Record],
    ship: Ship,
    *,
    fit_period: bool = True,
    initial_damping=None,
    start_s: float | None = None,
) -> DecayFit:
    """Damping (and the roll period) by fitting the roll equation to decay time series (diffrax + optimistix).

    Unknowns: β1 = b1/ω0, β2 = b2, β3 = b3·ω0 (dimensionless, so Levenberg–Marquardt sees similar scales), the
    period ratio Tφ/Tφ_ship (if `fit_period`; a3…a9 scale with ω0² so the GZ shape is kept), and the initial
    state (φ, φ̇) of each record at its first extreme (or at `start_s` [s, full scale]). Residuals are φ_model
    − φ_meas at every sample; the Jacobian comes from forward-mode differentiation through the solver
    (`adjoint=diffrax.ForwardMode()`); standard errors are s²(JᵀJ)⁻¹ with s the residual std.

    `initial_damping`: starting (b1, b2, b3) (default: the ship's, with β1 ≥ 0.01 and β2 ≥ 0.05)."""
    records = _as_list(records)
    _check_kind(records, "decay")
    omega_ship = float(ship.omega0)
    starts, series = [], []
    for r in records:
        if start_s is None:
            i0 = int(np.argmax(np.abs(r.roll[: max(int(round(ship.roll_period / r.dt)), 2)])))
        else:
            i0 = int(np.searchsorted(r.time, start_s))
            if i0 >= r.time.size - 16:
                raise RecordError(f"{r.source}: start_s = {start_s} s leaves fewer than 16 samples.")
        ts = jnp.asarray(r.time[i0:] - r.time[i0])
        series.append((ts, jnp.asarray(r.roll[i0:])))
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


# ------------------------------------------------------------------------------------------------------------
# 2. Captive tests: ΔGM at fixed heel against Grim + the non-memory polynomial
# ------------------------------------------------------------------------------------------------------------


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
    omega_e = jnp.arange(m // 2 + 1) * (2 * jnp.pi / (m * dt))
    omega = wave_frequencies_from_encounter(omega_e, speed, "head")[0][:, 0]
    k = omega**2 / GRAVITY
    return jnp.fft.irfft(spec * grim_transfer(k, length) * jnp.exp(-1j * k * probe_x), n=m)[:n]


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

    def correction(self, estimator: str = "std_ratio") -> Estimate:
        """The GM correction to put in the ship: "std_ratio" (the paper's σ_obs/σ_thr) or "ls" (the LS
        scale)."""
        if estimator == "std_ratio":
            return self.std_ratio
        if estimator == "ls":
            return self.ls_scale
        raise ValueError(f"`estimator` must be 'std_ratio' or 'ls'; got {estimator!r}.")

    def to_dict(self) -> dict[str, Any]:
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
    records = _as_list(records)
    _check_kind(records, "captive")
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
        },
    )


# ------------------------------------------------------------------------------------------------------------
# 3. Free-running roll: the model's amplitude distributions against the records
# ------------------------------------------------------------------------------------------------------------

#: Quantile levels bounding the bands whose means `fit_roll_pdf` matches (both estimators).
DEFAULT_BANDS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99)
ESTIMATORS = ("zero_crossing", "envelope")
_PARAMS = {
    "gm_correction": ("gm_correction", None, "-"),
    "b1": ("damping", 0, "1/s"),
    "b2": ("damping", 1, "1/rad"),
    "b3": ("damping", 2, "s/rad^2"),
}


def _get_param(ship: Ship, name: str):
    attr, idx, _ = _PARAMS[name]
    v = getattr(ship, attr)
    return v if idx is None else v[idx]


def _set_params(ship: Ship, names: Sequence[str], values) -> Ship:
    for name, v in zip(names, values):
        attr, idx, _ = _PARAMS[name]
        if idx is None:
            ship = eqx.tree_at(lambda s: getattr(s, attr), ship, jnp.asarray(v, dtype=float))
        else:
            ship = eqx.tree_at(lambda s: getattr(s, attr), ship, getattr(ship, attr).at[idx].set(v))
    return ship


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
    n = jnp.sum(mask)
    cum = jnp.concatenate([jnp.zeros(1), jnp.cumsum(s)])
    edges = jnp.asarray(edges, dtype=float)
    x = edges * n
    i = jnp.clip(jnp.floor(x).astype(int), 0, n - 1)
    g = (cum[i] + (x - i) * s[i]) / n  # ∫_0^q Q(u) du
    return jnp.diff(g) / jnp.diff(edges)


def _np_band_means(x: np.ndarray, edges) -> np.ndarray:
    s = np.sort(x)
    n = s.size
    cum = np.concatenate([[0.0], np.cumsum(s)])
    e = np.asarray(edges, dtype=float)
    i = np.clip(np.floor(e * n).astype(int), 0, n - 1)
    g = (cum[i] + (e * n - i) * s[i]) / n
    return np.diff(g) / np.diff(e)


def zero_crossing_hysteresis(phi, hysteresis):
    """Zero-crossing amplitudes of φ [rad] with hysteresis h [rad]: a half cycle ends when φ passes −h (from a
    positive one) or +h (from a negative one), so sensor noise near zero does not split a swing; its amplitude
    is the largest signed excursion in it. With h = 0 this is `jaxroll.zero_crossing_amplitudes`.

    **Returns:** an array the length of `phi`, > 0 at the sample where a half cycle ended (0 elsewhere; the
    first and the unfinished last half cycles are not counted).
    """
    phi = jnp.asarray(phi, dtype=float)

    def step(state, v):
        sign, started, peak = state
        crossed = jnp.where(sign > 0, v < -hysteresis, v > hysteresis) & ~((v == 0) & (hysteresis == 0))
        amp = jnp.where(crossed & started, peak, 0.0)
        new_sign = jnp.where(crossed, -sign, sign)
        peak = jnp.where(crossed, new_sign * v, jnp.maximum(peak, sign * v))
        return (new_sign, started | crossed, peak), amp

    s0 = jnp.where(phi[0] >= 0, 1.0, -1.0)
    _, amps = jax.lax.scan(step, (s0, jnp.array(False), s0 * phi[0]), phi)
    return amps


def amplitude_samples(phi, hysteresis=0.0):
    """The paper's two amplitude estimators applied to each row of `phi` [rad] (shape (realizations,
    samples)):
    zero-crossing amplitudes with `hysteresis` [rad] (`zero_crossing_hysteresis`) and the Hilbert envelope.

    **Returns:** `(zc, zc_mask, env)`: zero-crossing amplitudes [rad] with the mask of the samples where a
    half cycle ended, and the envelope [rad] at every sample.
    """
    phi = jnp.atleast_2d(phi)
    zc = jax.vmap(zero_crossing_hysteresis, in_axes=(0, None))(phi, hysteresis)
    return zc, zc > 0, hilbert_envelope(phi)


_amplitude_samples_jit = eqx.filter_jit(amplitude_samples)


def _model_band_means(ship, problem, keys, num_steps, sub, start, bands, estimators, noise, hysteresis):
    """Model band means of the amplitude estimators from a Monte Carlo with fixed keys (common random
    numbers),
    with the records' sensor noise `noise` [rad] added (fixed keys too) before estimation."""
    from ..roll._equation import roll_time_series

    problem = eqx.tree_at(lambda p: p.ship, problem, ship)

    @jax.checkpoint
    def one(key):
        phi, _, end = roll_time_series(problem, key, num_steps * problem.dt)
        phi = phi[::sub][start:]
        return phi + noise * jr.normal(jr.fold_in(key, 0x5E45), phi.shape), end.capsized

    phi, capsized = jax.vmap(one)(keys)
    zc, zc_mask, env = amplitude_samples(phi, hysteresis)
    alive = ~capsized[:, None]
    out = []
    for est in estimators:
        if est == "zero_crossing":
            out.append(band_means(zc, zc_mask & alive, bands))
        else:
            out.append(band_means(env, jnp.broadcast_to(alive, env.shape), bands))
    return jnp.concatenate(out), phi, capsized


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
    keys: Any
    targets: tuple
    weights: tuple
    scales: Any
    names: tuple = eqx.field(static=True)
    num_steps: int = eqx.field(static=True)
    sub: int = eqx.field(static=True)
    start: int = eqx.field(static=True)
    bands: tuple = eqx.field(static=True)
    estimators: tuple = eqx.field(static=True)
    theory: Any = eqx.field(static=True)
    grid: Any
    noise: Any
    hysteresis: Any
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
                        ship,
                        prob,
                        self.keys,
                        self.num_steps,
                        self.sub,
                        self.start,
                        self.bands,
                        self.estimators,
                        self.noise,
                        self.hysteresis,
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

    def to_dict(self) -> dict[str, Any]:
        return {
            "estimates": {k: v.to_dict() for k, v in self.estimates.items()},
            "covariance": self.covariance.tolist(),
            "initial": self.initial,
            "sea_states": [c.to_dict() for c in self.comparisons],
            "diagnostics": self.info.to_dict(),
            "config": self.config,
        }


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
    model side is a Monte Carlo through the project's integrator (`make_problem(..., method=method)` and
    `roll_time_series`; same start φ(0) as the records, same window, sampling, sensor noise and estimators)
    with **common random numbers**: realization i always uses `fold_in(key, i)`, so the objective is a
    deterministic, continuous function of the parameters. Capsized model realizations are excluded. The
    records' sensor noise (`sensor_noise_deg`, default: estimated from the records) is added to the model's
    roll with fixed keys, and zero crossings use a hysteresis (`hysteresis_deg`, default 3× the noise) on both
    sides, so that noise does not split swings into spurious small amplitudes.

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
    from ..roll._monte_carlo import make_problem

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
    keys = jax.vmap(lambda i: jr.fold_in(key, i))(jnp.arange(num_realizations))
    rng = np.random.default_rng(seed)

    problems, seas, targets, cov_e, exp_samples = [], [], [], [], []
    for (hs, t01), recs in groups.items():
        sea = ITTC(hs, t01)
        phi0 = float(recs[0].meta.get("initial_roll_deg", 5.0))
        prob, _ = make_problem(ship, sea, speed=recs[0].speed, method=method, dt=dt_model, phi0_deg=phi0)
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

    def model_run(s: Ship):
        out = []
        for prob in problems:
            q, phi, cap = _model_band_means_jit(
                s, prob, keys, num_steps, sub, start, bands, estimators, noise, hyst
            )
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
        keys,
        tuple(jnp.asarray(t) for t in targets),
        tuple(jnp.asarray(w) for w in weights),
        jnp.asarray(scales),
        params,
        num_steps,
        sub,
        start,
        bands,
        estimators,
        theory,
        grid,
        jnp.asarray(noise),
        jnp.asarray(hyst),
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


_model_band_means_jit = eqx.filter_jit(_model_band_means)


def calibrated_ship(
    ship: Ship,
    *,
    decay: DecayFit | None = None,
    captive: CaptiveFit | None = None,
    roll: RollFit | None = None,
    estimator: str = "std_ratio",
    name: str | None = None,
) -> Ship:
    """`ship` with the calibrated values: damping (and Tφ, for an ODE fit with a fitted period) from `decay`,
    the GM correction from `captive` (`estimator` "std_ratio" or "ls"), then the parameters of `roll`."""
    out = ship
    notes = []
    if decay is not None:
        b = jnp.asarray(np.maximum(decay.b, 0.0))
        if decay.method == "ode" and decay.config.get("fit_period"):
            out = _decay_ship(out, b, decay.roll_period.value / float(out.roll_period))
        else:
            out = eqx.tree_at(lambda s: s.damping, out, b)
        notes.append(f"damping from free decay ({decay.method})")
    if captive is not None:
        out = eqx.tree_at(lambda s: s.gm_correction, out, jnp.asarray(captive.correction(estimator).value))
        notes.append(f"GM correction from captive tests ({estimator})")
    if roll is not None:
        out = _set_params(out, list(roll.estimates), [e.value for e in roll.estimates.values()])
        notes.append(f"{', '.join(roll.estimates)} from free-running roll PDFs")
    provenance = f"{ship.provenance} | calibrated by jaxroll: {'; '.join(notes)}".strip(" |")
    return Ship(
        lpp=out.lpp,
        breadth=out.breadth,
        depth=out.depth,
        draught=out.draught,
        displacement=out.displacement,
        block_coefficient=out.block_coefficient,
        gm0=out.gm0,
        roll_period=out.roll_period,
        restoring=out.restoring,
        damping=out.damping,
        delta_gm=out.delta_gm,
        gm_correction=out.gm_correction,
        name=name or f"{ship.name} (calibrated)",
        provenance=provenance,
    )
