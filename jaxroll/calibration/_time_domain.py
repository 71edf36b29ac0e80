"""Time-domain calibration of the roll model from free-running roll records, by multiple shooting
(docs/calibration.md, "Time-domain calibration").

A free-running record carries the roll φ(t) and the wave η(t) at a probe. Grim's effective wave ζ_G(t) is
reconstructed from the probe (`effective_wave_on_grid`: the reconstruction of `effective_wave_from_probe`,
band-limited onto the integrator's sub-step grid, with its exact derivative), and the project's roll equation
is integrated through it with the project's RK4 step (`rk4_step`, P at the step ends and at the cubic-Hermite
midpoint, exactly as `simulate`).

**Multiple shooting.** The analysis span of each record is cut into windows of equal length (default: four
natural roll periods). Each window starts from its own free initial state (φ, φ̇); the global parameters
(damping, GM correction, ...) are shared. Residual = measured − simulated roll at every sample. The window
states are profiled out (variable projection): for given global parameters each window's state is the
Gauss–Newton least-squares state (`INNER_ITERATIONS` iterations from the state read off the record), and the
outer Levenberg–Marquardt (optimistix) sees the *projected* residual P⊥r, whose forward-mode AD Jacobian is
P⊥J_θ. The optimum is that of the joint least squares over (globals, all window states).

**Uncertainty.** Cluster-robust (sandwich) covariance with every window as a cluster,
(JᵀJ)⁻¹[Σ_c (J_cᵀr_c)(J_cᵀr_c)ᵀ](JᵀJ)⁻¹·G/(G−1), Student-t intervals with G − 1 degrees of freedom; the
model-based s²(JᵀJ)⁻¹ is kept for comparison. Identifiability: correlation matrix, condition number of the
column-equilibrated Jacobian, variance-inflation factors, and a warning naming every parameter that is not
identified.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._config import require_float64
from ..io._records import Record
from ..roll._equation import rk4_step
from ..sea._grim import _fft_length, grim_transfer
from ..sea._spectra import GRAVITY, wave_frequencies_from_encounter
from ..ship._restoring import parametric_excitation
from ..ship._ship import Ship
from ._inputs import PAPER_WINDOW_MODEL_S, _as_list, _noise_std, check_wave_heights, lab_records, waves_arrive
from ._least_squares import _least_squares
from ._time_domain_results import (
    ParameterEstimate,
    RecordDiagnostics,
    TimeDomainFit,
    _issue,
    identifiability,
)

# ------------------------------------------------------------------------------------------------------------
# Fittable parameters
# ------------------------------------------------------------------------------------------------------------

#: name -> (unit, coordinate, natural size, description). "relative": value = θ·size, size = max(|initial|,
#: natural size) (may cross zero); "log": value = initial·exp(θ) (stays positive).
TIME_DOMAIN_PARAMETERS: dict[str, tuple[str, str, float | None, str]] = {
    "b1": ("1/s", "relative", None, "linear roll damping per unit inertia (natural size 2·0.01·ω0)"),
    "b2": ("1/rad", "relative", 0.1, "quadratic roll damping"),
    "b3": ("s/rad^2", "relative", 1.0, "cubic roll damping"),
    "gm_correction": ("-", "log", 1.0, "GM correction r = σ_obs/σ_thr multiplying P(t)"),
    "roll_period": (
        "s",
        "log",
        None,
        "natural roll period Tφ = 2π/√a1 (a3…a9 scale with ω0², GZ shape kept)",
    ),
    "delta_gm_nonlinear": ("-", "log", 1.0, "factor on the nonlinear ΔGM coefficients C2…C6 (C1 kept)"),
}
#: Largest integrator step [s, full scale] unless given (the virtual tank's default `max_dt`).
DEFAULT_MAX_DT = 0.25
#: Default shooting window, in natural roll periods.
DEFAULT_WINDOW_PERIODS = 4.0
#: Edge margin of the analysis span when the record does not cover the paper's window, in mean wave periods
#: T01 (the probe reconstruction of ζ_G is exact only away from the ends).
DEFAULT_EDGE_WAVE_PERIODS = 5.0
#: Gauss–Newton iterations of each window's initial state per evaluation of the residual.
INNER_ITERATIONS = 5


def _natural_size(name: str, ship: Ship) -> float:
    if name == "b1":
        return 0.02 * float(ship.omega0)
    if name == "roll_period":
        return float(ship.roll_period)
    return float(TIME_DOMAIN_PARAMETERS[name][2])


def check_time_domain_params(params: Sequence[str]) -> tuple[str, ...]:
    """`params` as a tuple after checking that the roll model has each of them (`TIME_DOMAIN_PARAMETERS`).

    **Raises:** `ValueError` naming the unknown parameter and the choices (a uniform ΔGM scale is refused:
    it is `gm_correction` exactly)."""
    if isinstance(params, str):
        params = (params,)
    params = tuple(params)
    if not params:
        raise ValueError("`params` is empty; name at least one of " + ", ".join(TIME_DOMAIN_PARAMETERS) + ".")
    for p in params:
        if p not in TIME_DOMAIN_PARAMETERS:
            hint = ""
            if p in ("delta_gm_scale", "delta_gm", "dgm_scale"):
                hint = (
                    " A uniform scale of the ΔGM polynomial is `gm_correction` itself (P = r·ω0²/GM0·ΔGM), "
                    "so it cannot be fitted beside it; `delta_gm_nonlinear` scales C2…C6 only."
                )
            elif p in ("a1", "omega0"):
                hint = " The natural frequency a1 = (2π/Tφ)² is fitted as `roll_period`."
            raise ValueError(
                f"unknown parameter {p!r}: the roll model has no such fittable parameter; choose from "
                f"{', '.join(TIME_DOMAIN_PARAMETERS)}.{hint}"
            )
    if len(set(params)) != len(params):
        raise ValueError(f"`params` names a parameter twice: {params}.")
    return params


def parameter_values(ship: Ship, names: Sequence[str]) -> np.ndarray:
    """The current values of `names` in `ship` (delta_gm_nonlinear: 1)."""
    out = []
    for n in names:
        if n in ("b1", "b2", "b3"):
            out.append(float(ship.damping[("b1", "b2", "b3").index(n)]))
        elif n == "gm_correction":
            out.append(float(ship.gm_correction))
        elif n == "roll_period":
            out.append(float(ship.roll_period))
        else:
            out.append(1.0)
    return np.asarray(out, dtype=float)


def _start_values(ship: Ship, names: Sequence[str], initial: Mapping[str, float] | None) -> np.ndarray:
    v0 = parameter_values(ship, names)
    for k in initial or {}:
        if k not in names:
            raise ValueError(f"`initial` names {k!r}, which is not fitted (`params` = {', '.join(names)}).")
    for i, n in enumerate(names):
        if initial and n in initial:
            v0[i] = float(initial[n])
        if not math.isfinite(v0[i]):
            raise ValueError(f"the starting value of {n!r} must be finite; got {v0[i]}.")
        if TIME_DOMAIN_PARAMETERS[n][1] == "log" and not v0[i] > 0:
            raise ValueError(
                f"the starting value of {n!r} must be > 0 (it is fitted on a log scale); got {v0[i]}."
            )
    return v0


class Coordinates(eqx.Module):
    """Well-scaled coordinates θ of the physical parameters: value = size·θ (relative) or start·exp(θ) (log)."""

    names: tuple[str, ...] = eqx.field(static=True)
    log: tuple[bool, ...] = eqx.field(static=True)
    ref: jax.Array  # size (relative) or starting value (log)

    def __init__(self, ship: Ship, names: Sequence[str], start: np.ndarray):
        self.names = tuple(names)
        self.log = tuple(TIME_DOMAIN_PARAMETERS[n][1] == "log" for n in self.names)
        refs = [
            v if lg else max(abs(v), _natural_size(n, ship)) for n, lg, v in zip(self.names, self.log, start)
        ]
        self.ref = jnp.asarray(refs, dtype=float)

    def theta0(self, start: np.ndarray) -> np.ndarray:
        ref = np.asarray(self.ref)
        return np.array([0.0 if lg else v / r for v, r, lg in zip(start, ref, self.log)])

    def values(self, theta):
        """Physical values [their units] at θ."""
        lg = jnp.asarray(self.log)
        return jnp.where(lg, self.ref * jnp.exp(theta), self.ref * theta)

    def jacobian_diag(self, theta) -> np.ndarray:
        """d value / d θ (diagonal)."""
        v = np.asarray(self.values(jnp.asarray(theta, dtype=float)))
        return np.where(np.asarray(self.log), v, np.asarray(self.ref))


def ship_with(ship: Ship, names: Sequence[str], values) -> Ship:
    """`ship` with the time-domain parameters `names` set to `values` (JAX-traceable)."""
    damping, restoring, period = ship.damping, ship.restoring, ship.roll_period
    r, dgm = ship.gm_correction, ship.delta_gm
    for i, n in enumerate(names):
        v = values[i]
        if n in ("b1", "b2", "b3"):
            damping = damping.at[("b1", "b2", "b3").index(n)].set(v)
        elif n == "gm_correction":
            r = v
        elif n == "roll_period":
            restoring = ship.restoring * (v / ship.roll_period) ** -2
            period = v
        elif n == "delta_gm_nonlinear":
            dgm = dgm.at[2:].multiply(v)
    return eqx.tree_at(
        lambda s: (s.damping, s.restoring, s.roll_period, s.gm_correction, s.delta_gm),
        ship,
        (
            jnp.asarray(damping, dtype=float),
            jnp.asarray(restoring, dtype=float),
            jnp.asarray(period, dtype=float),
            jnp.asarray(r, dtype=float),
            jnp.asarray(dgm, dtype=float),
        ),
    )


# ------------------------------------------------------------------------------------------------------------
# Checks (before anything is computed)
# ------------------------------------------------------------------------------------------------------------


def check_roll_record(record: Record, what: str = "time-domain calibration") -> None:
    """Raise `ValueError` unless `record` has the `roll` and `wave` columns a free-running fit needs and
    states where its wave probe is (the wave is moved from the probe to amidships)."""
    if not isinstance(record, Record):
        raise ValueError(f"expected a jaxroll `Record`; got {type(record).__name__}.")
    missing = [c for c in ("roll", "wave") if c not in record.channels]
    if missing:
        raise ValueError(
            f"{record.source}: the {what} needs a free-running roll record with `roll` and `wave` columns "
            f"(the wave probe drives the excitation); this {record.kind} record has no "
            f"{' and no '.join(f'`{c}`' for c in missing)} column."
        )
    for key, why in (
        (
            "probe_x_model_m",
            "the wave is moved from the probe to amidships by this distance (0 for a probe "
            "amidships); a probe that is not amidships cannot be used without it",
        ),
        (
            "speed_model_m_s",
            "the probe's encounter frequencies are converted to wave numbers with it (0 at rest)",
        ),
    ):
        if key not in record.meta:
            raise ValueError(f"{record.source}: the {what} needs the header entry `{key}`: {why}.")
        value = record.meta[key]
        if not (isinstance(value, int | float) and math.isfinite(value)):
            raise ValueError(f"{record.source}: header entry `{key}` must be a finite number; got {value!r}.")


def analysis_span(record: Record, span_model_s: tuple[float, float] | None) -> tuple[int, int]:
    """Sample indices [i0, i1) of the analysis span: `span_model_s` (model-scale seconds, as the paper's
    70–340 s); by default the paper's window if the record covers it, else the record less an edge margin of
    5·T01 (full scale) at each end, where the probe reconstruction of ζ_G is not exact (from the waves' arrival
    at the probe when the record starts with the tank at rest, `waves_arrive`)."""
    t_model = record.model_time
    tol = 0.5 / float(record.meta["sampling_hz"])
    if span_model_s is None:
        lo, hi = PAPER_WINDOW_MODEL_S
        if t_model[0] <= lo + tol and t_model[-1] >= hi - tol:
            span_model_s = (lo, hi)
        else:
            if "wave_period_full_s" not in record.meta:
                raise ValueError(
                    f"{record.source}: the record does not cover the paper's window {lo:g}–{hi:g} s and has no "
                    "`wave_period_full_s` to set the edge margins (5·T01); give `span_model_s`."
                )
            edge = DEFAULT_EDGE_WAVE_PERIODS * record.wave_period / math.sqrt(record.scale)
            span_model_s = (t_model[waves_arrive(record)] + edge, t_model[-1] - edge)  # after any rest
            if not span_model_s[1] > span_model_s[0]:
                raise ValueError(
                    f"{record.source}: the record ({t_model[-1] - t_model[0]:.1f} s model scale) is shorter than "
                    f"the two edge margins of {edge:.1f} s model scale (5·T01) the probe reconstruction needs."
                )
    lo, hi = (float(x) for x in span_model_s)
    if not hi > lo:
        raise ValueError(f"{record.source}: analysis span {lo:g}–{hi:g} s is empty (stop must be > start).")
    if t_model[0] > lo + tol or t_model[-1] < hi - tol:
        raise ValueError(
            f"{record.source}: the analysis span {lo:g}–{hi:g} s model scale is not covered by the record "
            f"({t_model[0]:.3f}–{t_model[-1]:.3f} s model scale)."
        )
    return int(np.searchsorted(t_model, lo - tol)), int(np.searchsorted(t_model, hi + tol))


def default_window(ship: Ship) -> float:
    """Default shooting window [s, full scale]: four natural roll periods (`DEFAULT_WINDOW_PERIODS`), 97.6 s
    for C11."""
    return DEFAULT_WINDOW_PERIODS * float(ship.roll_period)


@dataclasses.dataclass(frozen=True)
class CheckedInputs:
    """What `check_time_domain_inputs` returns: the checked parameters, records, their analysis spans
    [i0, i1), the common sampling interval [s, full scale], the shooting window [s, full scale] and its
    samples."""

    params: tuple[str, ...]
    records: list[Record]
    spans: list[tuple[int, int]]
    dt: float
    window: float
    window_samples: int


def check_time_domain_inputs(
    ship: Ship,
    records: Record | Sequence[Record],
    *,
    params: Sequence[str] = ("b1", "b2", "gm_correction"),
    window: float | None = None,
    span_model_s: tuple[float, float] | None = None,
    what: str = "time-domain calibration",
    check_window: bool = True,
) -> CheckedInputs:
    """Check everything a time-domain fit needs before anything is computed (cheap, NumPy only): the
    parameters, the records (`roll` and `wave` columns, probe position, one sampling rate, analysis span
    covered) and the shooting window (positive, ≥ 8 samples, no longer than any record's analysis span;
    skipped with `check_window=False`, where `window_samples` is then 0).

    **Raises:** `ValueError` with a message that names the record and the problem."""
    params = check_time_domain_params(params)
    if not isinstance(ship, Ship):
        raise ValueError(f"`ship` must be a jaxroll `Ship`; got {type(ship).__name__}.")
    records = _as_list(records)
    for r in records:
        check_roll_record(r, what)
    dt = records[0].dt
    for r in records[1:]:
        if abs(r.dt - dt) > 1e-9 * dt:
            raise ValueError(
                f"{r.source}: sampling interval {r.dt:g} s differs from {records[0].source} ({dt:g} s); "
                "resample the records to one rate."
            )
    spans = [analysis_span(r, span_model_s) for r in records]
    check_wave_heights(records, span_model_s)
    # the rest said, the roll offset removed (over each analysis span)
    records = lab_records(
        records, [(r.model_time[i0], r.model_time[i1 - 1]) for r, (i0, i1) in zip(records, spans)]
    )
    if not check_window:
        return CheckedInputs(params, records, spans, float(dt), math.nan, 0)
    if window is None:
        window = default_window(ship)
    if isinstance(window, bool) or not (
        isinstance(window, int | float) and math.isfinite(window) and window > 0
    ):
        raise ValueError(f"`window` must be a positive number of seconds (full scale); got {window!r}.")
    window = float(window)
    n = int(round(window / dt)) + 1
    if n < 8:
        raise ValueError(
            f"`window` = {window:g} s holds only {n} samples of {dt:g} s; use at least 8 samples."
        )
    for r, (i0, i1) in zip(records, spans):
        if i1 - i0 < n:
            raise ValueError(
                f"{r.source}: `window` = {window:g} s (full scale) is longer than the record's analysis span "
                f"of {(i1 - i0 - 1) * dt:g} s (full scale, {r.model_time[i0]:.1f}–{r.model_time[i1 - 1]:.1f} s "
                "model scale); use a shorter window."
            )
    return CheckedInputs(params, records, spans, float(dt), window, n)


# ------------------------------------------------------------------------------------------------------------
# Excitation from the probe, on the integrator's grid; one window through the project's integrator
# ------------------------------------------------------------------------------------------------------------


def effective_wave_on_grid(
    wave, dt: float, sub: int, *, length: float, probe_x: float, speed: float = 0.0, pad_factor: int = 2
):
    """Grim's effective wave ζ_G [m] and dζ_G/dt [m/s] from one probe, on the grid dt/`sub`.

    The reconstruction of `effective_wave_from_probe` (FFT of the probe record with the mean removed,
    zero-padded to `pad_factor`× its length; each encounter component moved to amidships and multiplied by
    Grim's F(k)), evaluated band-limited on a `sub`-times finer grid (zero-padding in frequency) and
    differentiated spectrally (×iω_e). At the record's samples it equals `effective_wave_from_probe`.

    **Arguments:** `wave` [m] (probe, full scale, uniform step `dt` [s]); `sub` ≥ 1; `length` L [m];
    `probe_x` [m] (forward of amidships); `speed` [m/s] (head seas).

    **Returns:** `(zeta, dzeta)`, each of length (n − 1)·sub + 1 on t = k·dt/sub.
    """
    wave = jnp.asarray(wave, dtype=float)
    n = wave.shape[-1]
    m = _fft_length(pad_factor * n)
    spec = jnp.fft.rfft(wave - jnp.mean(wave), n=m)
    omega_e = jnp.arange(m // 2 + 1, dtype=float) * (2 * jnp.pi / (m * dt))
    omega = wave_frequencies_from_encounter(omega_e, speed, "head")[0][:, 0]
    k = omega**2 / GRAVITY
    g = spec * (grim_transfer(k, length).astype(complex) * jnp.exp(-1j * k.astype(complex) * probe_x))
    if m % 2 == 0 and sub > 1:
        g = g.at[-1].multiply(0.5)  # the Nyquist bin becomes a conjugate pair on the finer grid
    big = m * sub
    pad = big // 2 + 1 - g.size
    zeta = jnp.fft.irfft(jnp.pad(g, (0, pad)), n=big) * sub
    dzeta = jnp.fft.irfft(jnp.pad(1j * omega_e.astype(complex) * g, (0, pad)), n=big) * sub
    num = (n - 1) * sub + 1
    return zeta[:num], dzeta[:num]


def window_roll(ship: Ship, zeta, dzeta, y0, h: float, sub: int):
    """Roll φ [rad] at the record samples of one window, integrated from y0 = (φ, φ̇) [rad, rad/s].

    `zeta`, `dzeta`: ζ_G [m], dζ_G/dt [m/s] on the integrator grid (step `h` [s], `sub` steps per record
    sample), length (n − 1)·sub + 1 for n samples. The project's `rk4_step` with P(t) at the step ends and at
    the cubic-Hermite midpoint, exactly as `simulate` does (tests: equal to round-off), as one `lax.scan`
    without `simulate`'s capsize bookkeeping and blocks (which triple the compile time here).
    **Returns:** φ at the n samples."""
    z0, z1, d0, d1 = zeta[:-1], zeta[1:], dzeta[:-1], dzeta[1:]
    zm = (z0 + z1) / 2 + h * (d0 - d1) / 8  # cubic Hermite midpoint, as in `simulate`
    p = parametric_excitation(ship, jnp.stack([z0, zm, z1], -1))
    m = jnp.zeros(3)

    def step(y, pk):
        y = rk4_step(ship, y, pk, m, h)
        return y, y[0]

    y0 = jnp.asarray(y0, dtype=float)
    _, phis = jax.lax.scan(step, y0, p)
    return jnp.concatenate([y0[:1], phis[sub - 1 :: sub]])


# ------------------------------------------------------------------------------------------------------------
# Records → windows
# ------------------------------------------------------------------------------------------------------------


def rate_from_record(phi: np.ndarray, dt: float, i: int, half_width: int) -> tuple[float, float]:
    """(φ, φ̇) at sample i [rad, rad/s] from a local cubic least-squares fit over ±half_width samples."""
    lo, hi = max(i - half_width, 0), min(i + half_width + 1, phi.size)
    t = (np.arange(lo, hi) - i) * dt
    c = np.polynomial.polynomial.polyfit(t, phi[lo:hi], 3)
    return float(c[0]), float(c[1])


@dataclasses.dataclass(frozen=True)
class _Prepared:
    record: Record
    zeta: np.ndarray  # fine grid, whole record
    dzeta: np.ndarray
    i0: int
    i1: int
    sub: int
    h: float


def prepare_record(record: Record, ship: Ship, span: tuple[int, int], *, max_dt: float = DEFAULT_MAX_DT):
    """ζ_G and dζ_G/dt of a checked record on the integrator grid (≤ `max_dt`), with its analysis span."""
    sub = max(1, math.ceil(record.dt / max_dt - 1e-9))
    zeta, dzeta = effective_wave_on_grid(
        record.wave, record.dt, sub, length=float(ship.lpp), probe_x=record.probe_x, speed=record.speed
    )
    return _Prepared(record, np.asarray(zeta), np.asarray(dzeta), span[0], span[1], sub, record.dt / sub)


def _half_width(ship: Ship, dt: float) -> int:
    return max(2, int(round(float(ship.roll_period) / 8 / dt)))


class _Windows(eqx.Module):
    """The data of all windows (all records): excitation on the fine grid, measured roll, starting states."""

    zeta: jax.Array  # (W, steps + 1)
    dzeta: jax.Array  # (W, steps + 1)
    phi: jax.Array  # (W, n) measured roll [rad]
    y_start: jax.Array  # (W, 2) state read off the record
    h: float = eqx.field(static=True)
    sub: int = eqx.field(static=True)


def _build_windows(prepared: Sequence[_Prepared], ship: Ship, n: int):
    dt = prepared[0].record.dt
    half = _half_width(ship, dt)
    zs, dzs, phis, starts, owner, first = [], [], [], [], [], []
    for k, p in enumerate(prepared):
        for j in range((p.i1 - p.i0 - 1) // (n - 1)):
            a = p.i0 + j * (n - 1)
            zs.append(p.zeta[a * p.sub : (a + n - 1) * p.sub + 1])
            dzs.append(p.dzeta[a * p.sub : (a + n - 1) * p.sub + 1])
            phis.append(p.record.roll[a : a + n])
            starts.append(rate_from_record(p.record.roll, dt, a, half))
            owner.append(k)
            first.append(a)
    w = _Windows(
        jnp.asarray(np.stack(zs)),
        jnp.asarray(np.stack(dzs)),
        jnp.asarray(np.stack(phis)),
        jnp.asarray(np.asarray(starts)),
        prepared[0].h,
        prepared[0].sub,
    )
    return w, np.asarray(owner), np.asarray(first)


class MultipleShootingObjective(eqx.Module):
    """Projected multiple-shooting residual r(θ) [rad] (measured − simulated roll; window states profiled)."""

    ship: Ship
    coords: Coordinates
    windows: _Windows
    omega0: jax.Array
    free_states: bool = eqx.field(static=True)
    inner_iterations: int = eqx.field(static=True, default=INNER_ITERATIONS)

    def ship_at(self, theta) -> Ship:
        return ship_with(self.ship, self.coords.names, self.coords.values(theta))

    def _state(self, z):
        return z * jnp.stack([jnp.ones_like(self.omega0), self.omega0])  # z = (φ, φ̇/ω0)

    def window_residual(self, ship, zeta, dzeta, phi, z):
        w = self.windows
        return phi - window_roll(ship, zeta, dzeta, self._state(z), w.h, w.sub)

    def states(self, theta):
        """Window states z = (φ, φ̇/ω0) of the least-squares fit at θ (Gauss–Newton from the states read off
        the record, gradients stopped) and the Jacobian ∂r/∂z of each window's residual at the last iterate."""
        w = self.windows
        ship = jax.lax.stop_gradient(self.ship_at(theta))
        z = w.y_start / jnp.stack([jnp.ones_like(self.omega0), self.omega0])

        def gn(z, zeta, dzeta, phi):
            r, jvp = jax.linearize(lambda zz: self.window_residual(ship, zeta, dzeta, phi, zz), z)
            j = jax.vmap(jvp, out_axes=-1)(jnp.eye(2))
            a = j.T @ j
            a = a + 1e-12 * jnp.trace(a) * jnp.eye(2)
            return z - jnp.linalg.solve(a, j.T @ r), j

        jz = jnp.zeros(w.phi.shape + (2,))
        if self.free_states:
            z, jz = jax.lax.fori_loop(
                0, self.inner_iterations, lambda i, c: jax.vmap(gn)(c[0], w.zeta, w.dzeta, w.phi), (z, jz)
            )
        return jax.lax.stop_gradient(z), jax.lax.stop_gradient(jz)

    def __call__(self, theta, args=None):
        w = self.windows
        z, jz = self.states(theta)
        ship = self.ship_at(theta)

        def one(z, jz, zeta, dzeta, phi):
            r = self.window_residual(ship, zeta, dzeta, phi, z)
            if not self.free_states:
                return r
            a = jz.T @ jz
            a = a + 1e-12 * jnp.trace(a) * jnp.eye(2)
            return r - jz @ jnp.linalg.solve(a, jz.T @ r)  # P⊥ r: value r at the optimum, Jacobian P⊥ J_θ

        return jax.vmap(one)(z, jz, w.zeta, w.dzeta, w.phi).reshape(-1)


# ------------------------------------------------------------------------------------------------------------
# The fit
# ------------------------------------------------------------------------------------------------------------


def _condition_number(j: np.ndarray) -> float:
    """Condition number of the column-equilibrated Jacobian (scale-free)."""
    cn = j / np.maximum(np.linalg.norm(j, axis=0), 1e-300)
    sv = np.linalg.svd(cn, compute_uv=False)
    return float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf


def fit_roll_time_domain(
    ship: Ship,
    records: Record | Sequence[Record],
    *,
    params: Sequence[str] = ("b1", "b2", "gm_correction"),
    window: float | None = None,
    initial_state: str = "free",
    span_model_s: tuple[float, float] | None = None,
    initial: Mapping[str, float] | None = None,
    max_dt: float = DEFAULT_MAX_DT,
    max_steps: int = 100,
    warn: bool = True,
) -> TimeDomainFit:
    """Calibrate the roll model on free-running records in the time domain, by multiple shooting.

    **Arguments:**

    - `ship`: the roll model (its values are the starting point and the fixed values of what is not fitted).
    - `records`: free-running roll records (`roll` and `wave` columns, probe position in the header), full
      scale SI as loaded; one sampling rate.
    - `params`: any of b1 [1/s], b2 [1/rad], b3 [s/rad²], gm_correction [-], roll_period [s] (natural
      frequency a1 = (2π/Tφ)²; a3…a9 and P scale with a1), delta_gm_nonlinear [-] (factor on C2…C6).
    - `window`: shooting window [s, full scale]; default four natural roll periods (97.6 s for C11). Rule: long
      enough that damping and the parametric term act over several roll cycles, short enough that a 10–20 %
      parameter error shifts the simulated roll phase by well under a radian within one window (the least
      squares stay close to linear and Levenberg–Marquardt converges from the ship's values); and ≥ 10
      windows in all, since they are the clusters of the robust covariance.
    - `initial_state`: "free" (each window's (φ, φ̇) fitted, profiled out by Gauss–Newton) or "record" (read
      off the record by a local cubic fit; cheaper, biased by the sensor noise).
    - `span_model_s`: analysis span in **model-scale** seconds (default: the paper's 70–340 s when covered,
      else the record less 5·T01 at each end).
    - `initial`: starting values {name: value} overriding the ship's.
    - `max_dt`: largest integrator step [s, full scale]; `max_steps`: Levenberg–Marquardt steps; `warn`: issue
      the identifiability warnings as `UserWarning` (they are in `.warnings` either way).

    **Returns:** `TimeDomainFit`: estimates with cluster-robust standard errors (windows as clusters, t
    intervals with G − 1 degrees of freedom), correlation matrix, condition number, identifiability,
    per-record diagnostics, measured and fitted roll per window.

    **Raises:** `ValueError` — checked before anything is computed — for a record without a `wave` or `roll`
    column or without its probe position, a window longer than a record's analysis span, an unknown
    parameter, records of different sampling rates, an analysis span the record does not cover.
    """
    require_float64("jaxroll.fit_roll_time_domain")
    if initial_state not in ("free", "record"):
        raise ValueError(f"`initial_state` must be 'free' or 'record'; got {initial_state!r}.")
    if not (isinstance(max_dt, int | float) and max_dt > 0):
        raise ValueError(f"`max_dt` must be > 0 [s]; got {max_dt!r}.")
    window_rule = f"{DEFAULT_WINDOW_PERIODS:g} natural roll periods (default)" if window is None else "given"
    checked = check_time_domain_inputs(ship, records, params=params, window=window, span_model_s=span_model_s)
    params, records, window, n_win = checked.params, checked.records, checked.window, checked.window_samples
    start = _start_values(ship, params, initial)
    # --- compute ---
    prepared = [prepare_record(r, ship, s, max_dt=max_dt) for r, s in zip(records, checked.spans)]
    windows, owner, first = _build_windows(prepared, ship, n_win)
    coords = Coordinates(ship, params, start)
    obj = MultipleShootingObjective(ship, coords, windows, ship.omega0, initial_state == "free")
    theta, j, r, info = _least_squares(obj, jnp.asarray(coords.theta0(start)), None, max_steps=max_steps)
    n_w = windows.phi.shape[0]
    p = len(params)
    dof = max(r.size - p - (2 * n_w if initial_state == "free" else 0), 1)
    sigma = math.sqrt(float(r @ r) / dof)
    bread = np.linalg.pinv(j.T @ j)
    clusters = np.repeat(np.arange(n_w), n_win)
    scores = np.stack([j[clusters == c].T @ r[clusters == c] for c in range(n_w)])
    d = coords.jacobian_diag(theta)
    values = np.asarray(coords.values(jnp.asarray(theta)))
    cov = d[:, None] * (bread @ (scores.T @ scores) @ bread * (n_w / max(n_w - 1, 1))) * d[None, :]
    cov_mb = d[:, None] * (sigma**2 * bread) * d[None, :]
    cond = _condition_number(j)
    natural = [_natural_size(nm, ship) for nm in params]
    ident = identifiability(params, values, cov, natural, condition_number=cond)
    messages = [ident.message] if ident.not_identified else []
    if n_w < 10:
        messages.append(
            f"only {n_w} shooting windows are the clusters of the robust covariance; with fewer than ~10 its "
            "standard errors are themselves uncertain. Use longer records, more records or a shorter `window`."
        )
    if not info.converged:
        messages.append(f"the Levenberg–Marquardt solve did not converge: {info.result}.")
    # at the optimum the projected residual is the residual itself (the window states are converged)
    res = r.reshape(n_w, n_win)
    phi = np.asarray(windows.phi)
    diags = []
    for k, pr in enumerate(prepared):
        sel = owner == k
        rec = pr.record
        diags.append(
            RecordDiagnostics(
                rec.source,
                (float(rec.model_time[pr.i0]), float(rec.model_time[pr.i1 - 1])),
                int(sel.sum() * n_win),
                int(sel.sum()),
                float(np.degrees(np.sqrt(np.mean(res[sel] ** 2)))),
                float(np.degrees(_noise_std(rec.roll[pr.i0 : pr.i1]))),
                {"roll_std_deg": float(np.degrees(np.std(rec.roll[pr.i0 : pr.i1])))},
            )
        )
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    return TimeDomainFit(
        method="multiple shooting",
        estimates={
            nm: ParameterEstimate(float(v), float(s), TIME_DOMAIN_PARAMETERS[nm][0], float(n_w - 1))
            for nm, v, s in zip(params, values, se)
        },
        names=params,
        covariance=cov,
        covariance_model_based=cov_mb,
        covariance_kind="cluster-robust sandwich, shooting windows as clusters, G/(G−1)",
        correlation=ident.correlation,
        condition_number=cond,
        identifiability=ident,
        n_windows=n_w,
        window_s=window,
        residual_rms_deg=float(np.degrees(np.sqrt(np.mean(res**2)))),
        records=diags,
        ship=ship_with(ship, params, jnp.asarray(values)),
        warnings=_issue(messages, warn),
        curves={
            "time": [records[o].time[a : a + n_win] for o, a in zip(owner, first)],
            "measured": list(phi),
            "fitted": list(phi - res),
            "record": [int(o) for o in owner],
        },
        info=dataclasses.replace(info, sigma=sigma),
        config={
            "params": list(params),
            "window_s": window,
            "window_samples": int(n_win),
            "window_rule": window_rule,
            "initial_state": initial_state,
            "span_model_s": None if span_model_s is None else [float(x) for x in span_model_s],
            "initial": {nm: float(v) for nm, v in zip(params, start)},
            "integrator": f"jaxroll rk4_step, h = {prepared[0].h:g} s, {prepared[0].sub} step(s) per sample",
            "solver": "optimistix LevenbergMarquardt, jac fwd, window states profiled (Gauss–Newton, "
            f"{INNER_ITERATIONS} iterations)",
            "coordinates": {nm: TIME_DOMAIN_PARAMETERS[nm][1] for nm in params},
            "records": [rec.source for rec in records],
            "roll_offset_deg": [rec.meta["roll_offset_deg"] for rec in records],
        },
    )


def window_jacobian(
    ship: Ship,
    record: Record,
    params: Sequence[str],
    *,
    start_s: float,
    window: float,
    max_dt: float = DEFAULT_MAX_DT,
    fd: bool = False,
    step: float = 1e-5,
):
    """Jacobian of the simulated roll of one window [rad] with respect to the physical parameters `params` and
    the window's initial state (φ [rad], φ̇ [rad/s]), by forward-mode AD through the RK4 integrator
    (`fd=False`) or by central differences (step `step` × each parameter's size). For checks.

    `start_s`: window start [s, full scale, record time]; `window` [s, full scale].
    **Returns:** `(J, x0)`: J of shape (samples, len(params) + 2) and the point x0 (parameters, φ, φ̇)."""
    params = check_time_domain_params(params)
    check_roll_record(record)
    dt = record.dt
    a = int(round((start_s - record.time[0]) / dt))
    n = int(round(window / dt)) + 1
    if a < 0 or a + n > record.time.size:
        raise ValueError(f"window {start_s:g}–{start_s + window:g} s is not inside the record.")
    prep = prepare_record(record, ship, (0, record.time.size), max_dt=max_dt)
    zeta = jnp.asarray(prep.zeta[a * prep.sub : (a + n - 1) * prep.sub + 1])
    dzeta = jnp.asarray(prep.dzeta[a * prep.sub : (a + n - 1) * prep.sub + 1])
    y0 = rate_from_record(record.roll, dt, a, _half_width(ship, dt))
    x0 = np.concatenate([parameter_values(ship, params), np.asarray(y0)])
    p = len(params)

    @jax.jit
    def f(x):
        return window_roll(ship_with(ship, params, x[:p]), zeta, dzeta, x[p:], prep.h, prep.sub)

    if not fd:
        return np.asarray(jax.jit(jax.jacfwd(f))(jnp.asarray(x0))), x0
    sizes = np.concatenate(
        [
            [max(abs(v), _natural_size(nm, ship)) for nm, v in zip(params, x0[:p])],
            [math.radians(1.0), float(ship.omega0) * math.radians(1.0)],
        ]
    )
    cols = []
    for i in range(x0.size):
        e = np.zeros(x0.size)
        e[i] = step * sizes[i]
        cols.append((np.asarray(f(jnp.asarray(x0 + e))) - np.asarray(f(jnp.asarray(x0 - e)))) / (2 * e[i]))
    return np.stack(cols, -1), x0
