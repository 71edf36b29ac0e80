"""Free-roll decay records → damping b1, b2, b3 (formulas: docs/calibration.md §1).

Both fits analyse each record from its release (found, or a given start; `_decay_inputs`), about its roll offset,
with a damping model (`DAMPING_MODELS`: linear, linear+quadratic by default, linear+cubic, all three) whose
coefficients are kept ≥ 0 by fitting their logarithms; the results (`DecayFit`, with the equivalent linear damping
ζ_eq(A)) are in `_decay_results`.

- `fit_extinction`: the extinction curve Δφ = aφ_m + bφ_m² + cφ_m³ (decrement per half swing against the mean
  amplitude of the swing), fitted to the extremes and converted to b1, b2, b3 by energy balance at the observed
  period (`extinction_to_damping`);
- `fit_decay_ode`: the roll equation itself, integrated with diffrax and fitted to the whole time series by
  Levenberg–Marquardt (forward-mode derivatives through the solver, `diffrax.ForwardMode()`)."""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._compiled import filter_jit
from .._config import require_float64
from ..io._records import Record, RecordError
from ..ship._restoring import restoring_moment
from ..ship._ship import Ship
from ._decay_inputs import check_angle_unit, decay_segment
from ._decay_results import DecayFit, check_damping_model
from ._inputs import _as_list, _check_kind, _noise_std
from ._least_squares import (
    SOLVER_HINT,
    Estimate,
    FitFailure,
    _estimates,
    _gauss_newton_covariance,
    _least_squares,
)


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


def _decay_ship(ship: Ship, b, period_ratio) -> Ship:
    """`ship` with damping b and roll period Tφ·period_ratio (restoring a3…a9 scaled with ω0², GZ shape
    kept)."""
    scale = period_ratio**-2
    return eqx.tree_at(
        lambda s: (s.damping, s.roll_period, s.restoring),
        ship,
        (jnp.asarray(b, dtype=float), ship.roll_period * period_ratio, ship.restoring * scale),
    )


def _decay_field(t, y, ship):
    """(φ̇, φ̈) of the free decay (P = 0) of `ship`, per unit roll inertia."""
    damping = ship.damping[0] + ship.damping[1] * jnp.abs(y[1]) + ship.damping[2] * y[1] ** 2
    return jnp.stack([y[1], -(y[1] * damping) - restoring_moment(ship, y[0])])


def decay_solution(
    ship: Ship, phi0, dphi0, ts, *, rtol: float = 1e-9, atol: float = 1e-12, max_steps: int = 200_000
):
    """φ(t) [rad] of the free decay (P = 0) of `ship` from (φ0, φ̇0) at t = 0, saved at `ts` [s] (increasing,
    from 0): diffrax's Tsit5 under its PID step-size control (`rtol`, `atol`), forward-mode differentiable; NaN at
    every sample where the integration fails (a step size that collapses, `max_steps` steps).

    The loop is diffrax's own pieces (the solver's `step`, the controller's `adapt_step_size`, the solver's
    interpolant read at each sample within an accepted step) in a `lax.while_loop`: the same steps and the same
    bits as `diffrax.diffeqsolve(..., SaveAt(ts=ts), adjoint=ForwardMode())`, without its host callbacks (it
    checks `ts` and its own failure with `eqx.error_if`), which JAX's persistent cache does not keep and
    `jax.export` cannot store: the decay fit's programs were traced and compiled afresh by every process."""
    import diffrax
    from jax import lax

    term, solver = diffrax.ODETerm(_decay_field), diffrax.Tsit5(scan_kind="lax")  # as ForwardMode sets it
    controller = diffrax.PIDController(rtol=rtol, atol=atol)
    order = solver.error_order(term)
    ts = jnp.asarray(ts, dtype=float)
    n, t0, t1 = ts.shape[0], jnp.asarray(0.0), ts[-1]
    y0 = jnp.stack([jnp.asarray(phi0, dtype=float), jnp.asarray(dphi0, dtype=float)])
    # a first step of 0.01 s, as `diffeqsolve(dt0=None)` takes for its wrapped term (no estimate made for it)
    tnext, c_state = controller.init(term, t0, t1, y0, 0.01, ship, solver.func, order)
    tnext = jnp.minimum(tnext, t1)
    # the last step ends exactly at t1 once it comes within 100 ulp of it (as in diffrax)
    t1_floor = lax.fori_loop(0, 100, lambda _, t: jnp.nextafter(t, -jnp.inf), t1)

    def step(state):
        tprev, tnext, y, s_state, c_state, saved, phi, n_steps, ok = state
        y1, y_error, dense, s_new, s_result = solver.step(term, tprev, tnext, y, ship, s_state, False)
        y_error = jnp.where(jnp.isnan(y_error), jnp.inf, y_error)
        keep, t_a, t_b, _, c_state, c_result = controller.adapt_step_size(
            tprev, tnext, y, y1, ship, y_error, order, c_state
        )
        t_a = jnp.minimum(t_a, t1)
        t_b = jnp.where(t_b > t1_floor, jnp.where(keep, t1, t_a + 0.5 * (t1 - t_a)), t_b)
        path = solver.interpolation_cls(t0=tprev, t1=tnext, **dense)

        def save(carry):
            i, phi = carry
            return i + 1, phi.at[i].set(path.evaluate(ts[i])[0])

        saved, phi = lax.while_loop(
            lambda c: keep & (c[0] < n) & (ts[jnp.minimum(c[0], n - 1)] <= tnext), save, (saved, phi)
        )
        ok = ok & (c_result == diffrax.RESULTS.successful)
        ok = ok & (~keep | (s_result == diffrax.RESULTS.successful))
        y = jnp.where(keep, y1, y)
        s_state = jax.tree.map(lambda a, b: jnp.where(keep, a, b), s_new, s_state)
        return t_a, t_b, y, s_state, c_state, saved, phi, n_steps + 1, ok

    state = (
        t0,
        tnext,
        y0,
        solver.init(term, t0, tnext, y0, ship),
        c_state,
        jnp.asarray(0),
        jnp.full(n, jnp.inf),
        jnp.asarray(0),
        jnp.asarray(True),
    )
    state = lax.while_loop(lambda s: (s[0] < t1) & s[8] & (s[7] < max_steps), step, state)
    return jnp.where(state[8] & (state[0] >= t1), state[6], jnp.nan)


def _decay_base_ship(ship: Ship | None, period: float) -> Ship:
    """The ship a decay fit integrates: `ship` (its GZ shape) or, without one, the default ship's particulars with
    linear restoring at the observed roll period `period` [s] — the damping in 1/s needs only the record."""
    if ship is not None:
        return ship
    from ..ship._ship import c11_representative

    base = c11_representative()
    return eqx.tree_at(
        lambda s: (s.roll_period, s.restoring, s.damping),
        base,
        (jnp.asarray(float(period)), jnp.zeros_like(base.restoring), jnp.zeros(3)),
    )


def _prepare(records, start_model_s, stop_model_s, hysteresis_deg, min_amplitude_deg):
    """Each record's analysed segment, its extremes about the roll offset, the pooled observed period [s] and the
    amplitude range [rad]."""
    segs = [decay_segment(r, start_model_s=start_model_s, stop_model_s=stop_model_s) for r in records]
    thresholds, ext = [], []
    for s in segs:
        unit_note = check_angle_unit(s)
        centred = dataclasses.replace(s.analysed, channels={"roll": s.analysed.roll - s.offset})
        h, a = _extinction_thresholds(centred, hysteresis_deg, min_amplitude_deg)
        thresholds.append((h, a))
        try:
            ext.append(decay_extremes(centred, hysteresis_deg=h, min_amplitude_deg=a))
        except RecordError as e:
            if unit_note is None:
                raise
            raise RecordError(f"{e} {unit_note.removeprefix(s.record.source + ': ')}") from None
    periods = [2 * float(np.median(np.diff(e.time))) for e in ext]
    amps = np.concatenate([np.abs(e.value) for e in ext])
    return segs, thresholds, ext, periods, (float(amps.min()), float(amps.max()))


def _period_std_error(ext: Sequence[Extremes]) -> float:
    """Standard error [s] of the observed period, twice the mean time between extremes, from their scatter."""
    d = np.concatenate([np.diff(e.time) for e in ext])
    return 2 * float(np.std(d, ddof=1)) / math.sqrt(d.size) if d.size > 1 else 0.0


def _check_ship_period(ship: Ship | None, observed: float) -> None:
    if ship is None:
        return
    diff = float(ship.roll_period) / observed - 1
    if abs(diff) > 0.02:
        warnings.warn(
            f"the ship's roll period {float(ship.roll_period):.4g} s differs from the records' observed "
            f"{observed:.4g} s by {100 * diff:+.1f} %; the damping is converted and fitted with the observed period "
            "(give the ship's --roll-period, or a ship file that matches the model tested).",
            stacklevel=3,
        )


def _b_scales(omega):
    """b = scale · β with β dimensionless (β1 = b1/ω, β2 = b2, β3 = b3·ω); `omega` [rad/s] a number or an array
    (traced in the fit's program)."""
    xp = np if isinstance(omega, float) else jnp
    return xp.stack([omega, xp.ones_like(omega), 1 / omega])


def _extinction_residual(theta, args):
    x, y, idx = args
    coef = jnp.zeros(3).at[jnp.asarray(idx)].set(jnp.exp(theta))
    return (coef[0] * x + coef[1] * x**2 + coef[2] * x**3) - y


def _fit_abc(ext: Sequence[Extremes], idx: tuple[int, ...]):
    """(a, b, c) ≥ 0 of the model's terms (a = e^θ: positive by construction), their covariance, info."""
    pm = np.concatenate([e.mean_amplitude for e in ext])
    dec = np.concatenate([e.decrement for e in ext])
    # start: the linear least-squares fit of the model's terms, floored at a small positive value
    x = np.stack([pm, pm**2, pm**3], axis=1)[:, idx]
    lin = np.linalg.lstsq(x, dec, rcond=None)[0]
    floor = np.array([1e-4, 1e-3, 1e-2])[list(idx)]
    theta0 = np.log(np.maximum(lin, floor))
    theta, j, _, info = _least_squares(
        _extinction_residual,
        jnp.asarray(theta0),
        (jnp.asarray(pm), jnp.asarray(dec), tuple(idx)),
        stored=True,
    )
    coef = np.zeros(3)
    coef[list(idx)] = np.exp(theta)
    g = np.zeros((3, len(idx)))
    g[list(idx), range(len(idx))] = np.exp(theta)
    cov = g @ _gauss_newton_covariance(j, info.sigma) @ g.T
    return coef, cov, info, pm, dec


def _extinction_thresholds(record: Record, hysteresis_deg, min_amplitude_deg) -> tuple[float, float]:
    sigma = math.degrees(_noise_std(record.roll))
    h = hysteresis_deg if hysteresis_deg is not None else 3 * sigma
    a_min = min_amplitude_deg if min_amplitude_deg is not None else max(0.5, 10 * sigma)
    return h, a_min


def _record_summaries(segs, periods, offsets) -> tuple[dict, ...]:
    return tuple(
        {
            **s.config(),
            "roll_offset_deg": math.degrees(o),
            "observed_period_s": p,
            "initial_amplitude_deg": math.degrees(s.peak),
        }
        for s, p, o in zip(segs, periods, offsets)
    )


def fit_extinction(
    records: Record | Sequence[Record],
    ship: Ship | None = None,
    *,
    damping_model: str = "linear+quadratic",
    hysteresis_deg: float | None = None,
    min_amplitude_deg: float | None = None,
    correct_bias: bool = False,
    start_model_s: float | None = None,
    stop_model_s: float | None = None,
) -> DecayFit:
    """Damping from the extinction curve of one or more decay records (pooled decrements).

    Each record is analysed from its release (found, `decay_segment`) or from `start_model_s` to `stop_model_s`
    [s, model scale, the record's own time], about its roll offset. Fits Δφ = aφ_m + bφ_m² + cφ_m³ [rad] with the
    terms of `damping_model` (`DAMPING_MODELS`; the others 0) by least squares, the coefficients kept ≥ 0 by
    fitting their logarithms, and converts with `extinction_to_damping` at the **observed** ω = 2π/T (T: twice
    the median time between extremes; a `UserWarning` when `ship`'s period differs by more than 2 %). Standard
    errors are Gauss–Newton, propagated linearly to b1, b2, b3. `ship` (optional) only gives the GZ shape the bias
    correction simulates with (without one: linear restoring).

    The conversion is first order in the damping. On realistic records (ζ ≈ 0.005–0.05, releases 8–20°,
    docs/calibration.md) its bias in ζ_eq is well under the standard error, so `correct_bias` is off by default.
    With it, the bias is removed by simulation: b such that a noise-free decay at the observed period with
    damping b, sampled and analysed like the record, gives the measured a, b, c (two multiplicative updates b ←
    b · b̂/b̂_sim, which keep b ≥ 0). The raw conversion is kept in `curves["uncorrected"]`.
    """
    require_float64("jaxroll.fit_extinction")
    idx = tuple(["b1", "b2", "b3"].index(n) for n in check_damping_model(damping_model))
    records = _as_list(records)
    _check_kind(records, "decay")
    segs, thresholds, ext, periods, amp_range = _prepare(
        records, start_model_s, stop_model_s, hysteresis_deg, min_amplitude_deg
    )
    period = float(np.mean(periods))
    _check_ship_period(ship, period)
    omega = 2 * math.pi / period
    theta, cov_abc, info, pm, dec = _fit_abc(ext, idx)
    m = np.diag([2 * omega / math.pi, 0.75, 8 / (3 * math.pi * omega)])
    b_raw = m @ theta
    cov_b = m @ cov_abc @ m.T
    b = b_raw.copy()
    if correct_bias:
        base = _decay_base_ship(ship, period)
        ratio = period / float(base.roll_period)
        for _ in range(2):
            sim_ext = []
            s = _decay_ship(base, jnp.asarray(b), ratio)
            for seg, (h, a), e in zip(segs, thresholds, ext):
                r = seg.analysed
                i0 = int(np.argmin(np.abs(r.time - e.time[0])))
                ts = jnp.asarray(r.time[i0:] - r.time[i0])
                decay = np.asarray(_decay_solution_jit(s, e.value[0], 0.0, ts))
                if not np.all(np.isfinite(decay)):
                    raise FitFailure(
                        f"the roll equation could not be integrated for the bias correction. {SOLVER_HINT}"
                    )
                phi = np.concatenate([r.roll[:i0] - seg.offset, decay])
                sim = dataclasses.replace(r, channels={"roll": phi})
                sim_ext.append(decay_extremes(sim, hysteresis_deg=h, min_amplitude_deg=a))
            b_sim = m @ _fit_abc(sim_ext, idx)[0]
            b = np.where(b_sim > 0, b * b_raw / np.where(b_sim > 0, b_sim, 1.0), b)
    return DecayFit(
        method="extinction",
        damping=_estimates(("b1", "b2", "b3"), b, cov_b, ("1/s", "1/rad", "s/rad^2")),
        damping_covariance=cov_b,
        extinction=_estimates(("a", "b", "c"), theta, cov_abc, ("-", "1/rad", "1/rad^2")),
        roll_period=Estimate(period, _period_std_error(ext), "s"),
        omega0=omega,
        info=info,
        curves={
            "mean_amplitude": pm,
            "decrement": dec,
            "extremes": ext,
            "uncorrected": b_raw,
            "observed_period_s": period,
        },
        config={
            "hysteresis_deg": [h for h, _ in thresholds],
            "min_amplitude_deg": [a for _, a in thresholds],
            "correct_bias": correct_bias,
            "records": [r.source for r in records],
            "omega0_from": "observed period (twice the median time between extremes)",
            "damping_model": damping_model,
        },
        damping_model=damping_model,
        amplitude_range=amp_range,
        records=_record_summaries(segs, periods, [s.offset for s in segs]),
    )


def _decay_residual(theta, args):
    ship, fit_period, idx, omega_ref, series = args
    n_b = len(idx)
    n_global = n_b + (1 if fit_period else 0)
    ratio = jnp.exp(theta[n_b]) if fit_period else jnp.asarray(1.0)
    scales = _b_scales(omega_ref)
    b = jnp.zeros(3).at[jnp.asarray(idx)].set(scales[jnp.asarray(idx)] * jnp.exp(theta[:n_b]))
    s = _decay_ship(ship, b, ratio)
    out = []
    for k, (ts, phi) in enumerate(series):
        p = theta[n_global + 3 * k : n_global + 3 * k + 3]
        out.append(decay_solution(s, p[0], p[1] * omega_ref, ts) + p[2] - phi)
    return jnp.concatenate(out)


_decay_solution_jit = filter_jit(decay_solution)


def _start_rate(t: np.ndarray, phi: np.ndarray, period: float) -> float:
    """φ̇ at the first sample [rad/s]: slope of a quadratic through the first T/20."""
    n = max(3, int(np.searchsorted(t, t[0] + period / 20)))
    c = np.polyfit(t[:n] - t[0], phi[:n], 2)
    return float(c[1])


def fit_decay_ode(
    records: Record | Sequence[Record],
    ship: Ship | None = None,
    *,
    damping_model: str = "linear+quadratic",
    fit_period: bool = True,
    initial_damping=None,
    start_model_s: float | None = None,
    stop_model_s: float | None = None,
    samples_per_period: int = 50,
    start_s: float | None = None,
) -> DecayFit:
    """Damping (and the roll period) by fitting the roll equation to decay time series (diffrax + optimistix).

    Each record is analysed from its release (found, `decay_segment`) or from `start_model_s` to `stop_model_s`
    [s, model scale, the record's own time]. Unknowns: the damping coefficients of `damping_model`
    (`DAMPING_MODELS`; the others 0) as β_k = e^{θ_k} (β1 = b1/ω, β2 = b2, β3 = b3·ω: dimensionless, similar
    scales for Levenberg–Marquardt, and b ≥ 0 by construction), the period ratio (if `fit_period`), and per record
    the state (φ, φ̇) at its first analysed sample and a **roll offset** (the level it decays about). The model is
    `ship`'s GZ shape scaled to the fitted period, or without a ship linear restoring (the damping in 1/s needs
    only the record). Residuals are φ_model + offset − φ_meas at every sample; the Jacobian comes from
    forward-mode differentiation through the solver; standard errors are s²(JᵀJ)⁻¹ with s the residual std,
    propagated to b by the delta method.

    The start is the extinction curve of the same records (positive, observed period), so the fit converges in
    a few steps. `initial_damping`: starting (b1, b2, b3) instead. `samples_per_period`: records sampled more
    densely are decimated (every k-th sample; `config["decimation"]`): a 10⁶-row record fits in seconds, and
    the standard errors are not made over-confident by residuals correlated over neighbouring samples.
    `start_s` [s, full scale]: deprecated, use `start_model_s`."""
    require_float64("jaxroll.fit_decay_ode")
    names = check_damping_model(damping_model)
    idx = tuple(["b1", "b2", "b3"].index(n) for n in names)
    if not (isinstance(samples_per_period, int) and samples_per_period >= 8):
        raise ValueError(f"`samples_per_period` must be an integer >= 8; got {samples_per_period!r}.")
    records = _as_list(records)
    _check_kind(records, "decay")
    if start_s is not None:
        warnings.warn(
            "`start_s` [s, full scale] is deprecated: give `start_model_s` [s, model scale, the record's time].",
            DeprecationWarning,
            stacklevel=2,
        )
        start_model_s = start_s / math.sqrt(records[0].scale)
    segs, _, ext, periods, amp_range = _prepare(records, start_model_s, stop_model_s, None, None)
    period0 = float(np.mean(periods))
    _check_ship_period(ship, period0)
    base = _decay_base_ship(ship, period0)
    ratio0 = period0 / float(base.roll_period)
    omega_ref = 2 * math.pi / period0
    if initial_damping is None:
        m = np.diag([2 * omega_ref / math.pi, 0.75, 8 / (3 * math.pi * omega_ref)])
        b0 = m @ _fit_abc(ext, idx)[0]
    else:
        b0 = np.asarray(initial_damping, dtype=float)
    beta0 = np.asarray(b0)[list(idx)] / _b_scales(omega_ref)[list(idx)]
    beta0 = np.maximum(beta0, np.array([1e-4, 1e-3, 1e-3])[list(idx)])
    series, starts, decimation = [], [], []
    for s in segs:
        r = s.analysed
        k = max(1, int(period0 / r.dt) // samples_per_period)
        decimation.append(k)
        ts = r.time[::k] - r.time[0]
        series.append((jnp.asarray(ts), jnp.asarray(r.roll[::k])))
        phi0 = float(r.roll[0]) - s.offset
        starts.append([phi0, _start_rate(r.time, r.roll, period0) / omega_ref, s.offset])
    theta0 = np.concatenate([np.log(beta0), [math.log(ratio0)] if fit_period else [], np.ravel(starts)])
    n_b = len(idx)
    n_global = n_b + (1 if fit_period else 0)
    base_fixed = base  # with a fixed period: the ship's own
    # ω_ref as an array: a number would key the stored program to this record (`_least_squares(stored=True)`)
    args = (base_fixed, fit_period, idx, jnp.asarray(omega_ref), tuple(series))
    theta, j, res, info = _least_squares(_decay_residual, jnp.asarray(theta0), args, stored=True)
    cov_theta = _gauss_newton_covariance(j, info.sigma)
    scales = _b_scales(omega_ref)
    b = np.zeros(3)
    b[list(idx)] = scales[list(idx)] * np.exp(theta[:n_b])
    g = np.zeros((3, n_b))
    g[list(idx), range(n_b)] = b[list(idx)]
    cov_b = g @ cov_theta[:n_b, :n_b] @ g.T
    ratio = math.exp(theta[n_b]) if fit_period else 1.0
    period = float(base_fixed.roll_period) * ratio
    period_se = period * math.sqrt(cov_theta[n_b, n_b]) if fit_period else 0.0
    omega = 2 * math.pi / period
    m = np.diag([math.pi / (2 * omega), 4 / 3, 3 * math.pi * omega / 8])
    abc = m @ b
    fitted = res + np.concatenate([np.asarray(p) for _, p in series])
    per_record = theta[n_global:].reshape(len(segs), 3)
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
            "model_time": [
                s.start_model_s + np.asarray(ts) / math.sqrt(s.record.scale)
                for (ts, _), s in zip(series, segs)
            ],
            "measured": [np.asarray(p) for _, p in series],
            "fitted": np.split(fitted, np.cumsum([p.size for _, p in series])[:-1]),
            "initial_state": per_record[:, :2] * np.array([1.0, omega_ref]),
            "before": [
                (
                    s.record.model_time[: np.searchsorted(s.record.model_time, s.start_model_s)][::k],
                    s.record.roll[: np.searchsorted(s.record.model_time, s.start_model_s)][::k],
                )
                for s, k in zip(segs, decimation)
            ],
            "released": [s.released for s in segs],
            "start_model_s": [s.start_model_s for s in segs],
        },
        config={
            "fit_period": fit_period,
            "start_model_s": start_model_s,
            "stop_model_s": stop_model_s,
            "records": [r.source for r in records],
            "decimation": decimation,
            "damping_model": damping_model,
            "restoring": "the ship's GZ shape" if ship is not None else "linear (no ship given)",
            "solver": "diffrax Tsit5 (rtol 1e-9), optimistix LevenbergMarquardt, jac fwd",
        },
        damping_model=damping_model,
        amplitude_range=amp_range,
        records=_record_summaries(segs, periods, per_record[:, 2]),
    )


def decay_agreement(a: DecayFit, b: DecayFit) -> dict[str, float]:
    """z-scores (difference / combined standard error) of the damping coefficients both decay fits estimated.

    The two methods use the same record, so their errors are positively correlated and |z| is conservative.
    """
    out = {}
    for k in ("b1", "b2", "b3"):
        if k not in a.fitted_parameters or k not in b.fitted_parameters:
            continue
        ea, eb = a.damping[k], b.damping[k]
        se = math.hypot(ea.std_error, eb.std_error)
        out[k] = (ea.value - eb.value) / se if se > 0 else float("inf")
    return out
