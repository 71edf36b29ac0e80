"""State-space calibration of the roll model admitting model error: the extended-Kalman-filter likelihood
(docs/calibration.md, "Time-domain calibration").

    dφ = φ̇ dt,   dφ̇ = −[b1φ̇ + b2φ̇|φ̇| + b3φ̇³ + a1φ + … + P(t)φ] dt + q dW,   y_k = φ(t_k) + v_k,

with P(t) from Grim's effective wave reconstructed from the record's probe (as in `fit_roll_time_domain`),
white process noise of intensity q [rad/s^1.5] on the roll moment per unit inertia (it absorbs what the model
does not explain: an unmodelled roll moment, errors of ζ_G, of ΔGM or of the damping law) and white measurement
noise v ~ N(0, σ_v²) on φ. The extended Kalman filter propagates the mean with the project's RK4 step
(`rk4_step`, same sub-steps and Hermite midpoint as `simulate`) and the covariance with the step's AD Jacobian
F = ∂y_{k+1}/∂y_k: P ← F P Fᵀ + Q_h, Q_h = q²[[h³/3, h²/2], [h²/2, h]]. The negative log-likelihood
Σ_k ½[log 2πS_k + e_k²/S_k] of the innovations e_k (variance S_k) is minimised over the model parameters, q and
log σ_v together (optimistix BFGS, reverse-mode gradient through the filter).

Uncertainty: the inverse Fisher information of the innovations (the expected Hessian of the NLL,
I = Σ_k [∂e_k∂e_kᵀ/S_k + ½∂S_k∂S_kᵀ/S_k²], forward-mode AD through the filter), or a cluster-robust sandwich
I⁻¹[Σ_c g_c g_cᵀ]I⁻¹·G/(G−1) with the scores g_c of blocks of four roll periods as clusters.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from .._compiled import filter_jit
from .._config import require_float64
from ..io._records import Record
from ..roll._equation import rk4_step
from ..ship._restoring import parametric_excitation
from ..ship._ship import Ship
from ._inputs import _noise_std
from ._time_domain import (
    DEFAULT_MAX_DT,
    TIME_DOMAIN_PARAMETERS,
    Coordinates,
    _half_width,
    _natural_size,
    _start_values,
    check_time_domain_inputs,
    default_window,
    prepare_record,
    rate_from_record,
    ship_with,
)
from ._time_domain_results import (
    ParameterEstimate,
    RecordDiagnostics,
    TimeDomainFit,
    _issue,
    identifiability,
)

NOISE_PARAMS = ("process_noise", "measurement_noise")
NOISE_UNITS = {"process_noise": "rad/s^1.5", "measurement_noise": "rad"}


class _KalmanData(eqx.Module):
    zeta: jax.Array  # (R, steps + 1) on the integrator grid
    dzeta: jax.Array
    phi: jax.Array  # (R, N) measured roll [rad]
    mask: jax.Array  # (R, N) 1 where a sample is used
    y_start: jax.Array  # (R, 2) prior mean of the state at the first sample
    h: float = eqx.field(static=True)
    sub: int = eqx.field(static=True)


class KalmanObjective(eqx.Module):
    """Negative log-likelihood of the records under the EKF, per sample (`terms`) or summed and divided by the
    number of samples (`__call__`, for the optimiser)."""

    ship: Ship
    coords: Coordinates
    data: _KalmanData
    noise_ref: jax.Array  # (q_ref, σ_ref)
    prior_std: jax.Array  # (σ_φ0 [rad], σ_φ̇0 [rad/s])
    n_total: float = eqx.field(static=True)

    def split(self, theta):
        p = len(self.coords.names)
        ship = ship_with(self.ship, self.coords.names, self.coords.values(theta[:p]))
        q = self.noise_ref[0] * theta[p]  # linear: q² is even in θ, so q = 0 (no model error) is interior
        sv = self.noise_ref[1] * jnp.exp(theta[p + 1])
        return ship, q, sv

    def terms(self, theta):
        """Per-sample NLL terms, innovations e_k [rad] and their variances S_k [rad²], shape (R, N) each."""
        ship, q, sv = self.split(theta)
        d = self.data
        h, sub = d.h, d.sub
        qh = q**2 * jnp.array([[h**3 / 3, h**2 / 2], [h**2 / 2, h]])
        p0 = jnp.diag(self.prior_std**2)
        m0 = jnp.zeros(3)
        obs = jnp.array([1.0, 0.0])

        def one(zeta, dzeta, phi, mask, y0):
            z0, z1, d0, d1 = zeta[:-1], zeta[1:], dzeta[:-1], dzeta[1:]
            zm = (z0 + z1) / 2 + h * (d0 - d1) / 8
            pf = parametric_excitation(ship, jnp.stack([z0, zm, z1], -1)).reshape(-1, sub, 3)

            def update(m, pc, y, use):
                s = pc[0, 0] + sv**2
                e = y - m[0]
                k = pc[:, 0] / s * use
                m = m + k * e
                a = jnp.eye(2) - jnp.outer(k, obs)
                pc = a @ pc @ a.T + sv**2 * jnp.outer(k, k)  # Joseph form
                pc = (pc + pc.T) / 2
                ll = 0.5 * (jnp.log(2 * jnp.pi * s) + e**2 / s) * use
                return m, pc, ll, e * use, s

            def substep(carry, p):  # one RK4 sub-step of the mean, its Jacobian carrying the covariance
                m, pc = carry

                def f(y):
                    y1 = rk4_step(ship, y, p, m0, h)
                    return y1, y1

                fj, m = jax.jacfwd(f, has_aux=True)(m)  # the Jacobian and the step itself, in one pass
                return (m, fj @ pc @ fj.T + qh), None

            def predict(
                m, pc, pk
            ):  # a loop, not unrolled: `sub` copies of RK4 and its Jacobian compile slowly
                return jax.lax.scan(substep, (m, pc), pk)[0]

            m, pc, ll0, e0, n0 = update(y0, p0, phi[0], mask[0])

            def step(carry, inp):
                m, pc = carry
                pk, y, use = inp
                m, pc = predict(m, pc, pk)
                m, pc, ll, e, nn = update(m, pc, y, use)
                return (m, pc), (ll, e, nn)

            _, (ll, e, nn) = jax.lax.scan(step, (m, pc), (pf, phi[1:], mask[1:]))
            return (
                jnp.concatenate([ll0[None], ll]),
                jnp.concatenate([e0[None], e]),
                jnp.concatenate([n0[None], nn]),
            )

        return jax.vmap(one)(d.zeta, d.dzeta, d.phi, d.mask, d.y_start)

    def __call__(self, theta, args=None):
        return jnp.sum(self.terms(theta)[0]) / self.n_total

    def information(self, theta):
        """Fisher information of the Gaussian innovations, Σ_k [∂e_k∂e_kᵀ/S_k + ½ ∂S_k∂S_kᵀ/S_k²] (forward-mode
        derivatives through the filter), the per-sample scores ∂ℓ_k/∂θ, and the filter outputs (ℓ, e, S)."""
        ll, e, s = self.terms(theta)
        dll, de, ds = jax.jacfwd(self.terms)(theta)
        mask = self.data.mask[..., None, None]
        info = jnp.sum(
            mask
            * (
                de[..., :, None] * de[..., None, :] / s[..., None, None]
                + 0.5 * ds[..., :, None] * ds[..., None, :] / s[..., None, None] ** 2
            ),
            axis=(0, 1),
        )
        return info, dll, ll, e, s


class _Whitened(eqx.Module):
    """NLL − NLL(θ0) as a function of u, θ = θ0 + A u (A from the information at θ0: u ≈ standard errors)."""

    obj: KalmanObjective
    theta0: jax.Array
    a: jax.Array
    f0: jax.Array

    def __call__(self, u, args=None):
        return self.obj(self.theta0 + self.a @ u) * self.obj.n_total - self.f0


@filter_jit
def _minimise(fn, u0, max_steps, rtol, atol):
    sol = optx.minimise(fn, optx.BFGS(rtol=rtol, atol=atol), u0, None, max_steps=max_steps, throw=False)
    return sol.value, sol.result, sol.stats["num_steps"]


@filter_jit
def _information(obj, theta):
    return obj.information(theta)


def _preconditioner(h: np.ndarray) -> np.ndarray:
    """A with Aᵀ|H|A ≈ I (eigenvalues floored at 1e-8 of the largest): BFGS then starts well scaled."""
    lam, v = np.linalg.eigh((h + h.T) / 2)
    lam = np.maximum(np.abs(lam), 1e-8 * np.max(np.abs(lam)))
    return v / np.sqrt(lam)[None, :]


def _positive(name, value):
    if value is not None and not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise ValueError(f"`{name}` must be a positive number; got {value!r}.")


def fit_roll_kalman(
    ship: Ship,
    records: Record | Sequence[Record],
    *,
    params: Sequence[str] = ("b1", "b2", "gm_correction"),
    span_model_s: tuple[float, float] | None = None,
    initial: Mapping[str, float] | None = None,
    process_noise: float | None = None,
    measurement_noise: float | None = None,
    covariance: str = "fisher",
    block: float | None = None,
    max_dt: float = DEFAULT_MAX_DT,
    max_steps: int = 300,
    rtol: float = 1e-6,
    atol: float = 1e-6,
    warn: bool = True,
) -> TimeDomainFit:
    """Calibrate the roll model on free-running records by maximum likelihood with an extended Kalman filter
    (process noise on the roll moment admits model error).

    **Arguments:**

    - `ship`, `records`, `params`, `span_model_s`, `initial`, `max_dt`, `warn`: as `fit_roll_time_domain`.
    - `process_noise`: starting q [rad/s^1.5] (default 1e-4, a small unmodelled moment), fitted in a linear
      coordinate (q enters as q², so q = 0, no model error, is an interior point); `measurement_noise`:
      starting σ_v [rad] (default: the records' sensor noise from the 6th difference, at least 0.001°). Both
      are always fitted and reported as estimates.
    - `covariance`: "fisher" (inverse Fisher information = expected Hessian of the NLL; default, normal
      intervals) or "sandwich" (cluster-robust over blocks of `block` seconds [full scale], default four roll
      periods; t intervals); the other one is kept in `covariance_model_based`.
    - `max_steps`, `rtol`, `atol`: BFGS (optimistix) settings, in coordinates whitened by the information at the
      start (one unit ≈ one standard error), on the NLL relative to its starting value.

    **Returns:** `TimeDomainFit` with `method = "extended Kalman filter (ML)"`; the estimates include
    `process_noise` and `measurement_noise`; `curves["fitted"]` is the one-step prediction of the roll.
    **Raises:** `ValueError` as `fit_roll_time_domain` (checked before anything is computed).
    """
    require_float64("jaxroll.fit_roll_kalman")
    if covariance not in ("fisher", "sandwich"):
        raise ValueError(f"`covariance` must be 'fisher' or 'sandwich'; got {covariance!r}.")
    for name, value in (
        ("process_noise", process_noise),
        ("measurement_noise", measurement_noise),
        ("block", block),
        ("max_dt", max_dt),
    ):
        _positive(name, value)
    checked = check_time_domain_inputs(
        ship,
        records,
        params=params,
        span_model_s=span_model_s,
        what="Kalman-filter calibration",
        check_window=False,
    )
    params, records, dt = checked.params, checked.records, checked.dt
    start = _start_values(ship, params, initial)
    block = default_window(ship) if block is None else float(block)
    # --- compute ---
    prepared = [prepare_record(r, ship, s, max_dt=max_dt) for r, s in zip(records, checked.spans)]
    sub = prepared[0].sub
    n_max = max(p.i1 - p.i0 for p in prepared)
    half = _half_width(ship, dt)
    zs, dzs, phis, masks, starts, noises = [], [], [], [], [], []
    for p in prepared:
        n = p.i1 - p.i0
        pad_f = (n_max - n) * sub
        zs.append(np.pad(p.zeta[p.i0 * sub : (p.i1 - 1) * sub + 1], (0, pad_f)))
        dzs.append(np.pad(p.dzeta[p.i0 * sub : (p.i1 - 1) * sub + 1], (0, pad_f)))
        phis.append(np.pad(p.record.roll[p.i0 : p.i1], (0, n_max - n)))
        masks.append(np.pad(np.ones(n), (0, n_max - n)))
        starts.append(rate_from_record(p.record.roll, dt, p.i0, half))
        noises.append(_noise_std(p.record.roll[p.i0 : p.i1]))
    data = _KalmanData(
        jnp.asarray(np.stack(zs)),
        jnp.asarray(np.stack(dzs)),
        jnp.asarray(np.stack(phis)),
        jnp.asarray(np.stack(masks)),
        jnp.asarray(np.asarray(starts)),
        prepared[0].h,
        sub,
    )
    n_total = float(np.sum(masks))
    coords = Coordinates(ship, params, start)
    q0 = 1e-4 if process_noise is None else float(process_noise)
    s0 = (
        max(float(np.median(noises)), math.radians(1e-3))
        if measurement_noise is None
        else float(measurement_noise)
    )
    prior = jnp.asarray([max(3 * s0, math.radians(0.2)), float(ship.omega0) * math.radians(1.0)])
    obj = KalmanObjective(ship, coords, data, jnp.asarray([q0, s0]), prior, n_total)
    theta0 = np.concatenate([coords.theta0(start), [1.0, 0.0]])
    # the information at the start (the same compiled function as for the covariance) whitens the coordinates
    h0, _, ll0, _, _ = (np.asarray(x) for x in _information(obj, jnp.asarray(theta0)))
    a = _preconditioner(h0)
    fn = _Whitened(obj, jnp.asarray(theta0), jnp.asarray(a), jnp.asarray(float(np.sum(ll0))))
    u, result, steps = _minimise(fn, jnp.zeros(theta0.size), max_steps, rtol, atol)
    msg = "" if result == optx.RESULTS.successful else str(optx.RESULTS[result])
    theta = theta0 + a @ np.asarray(u)
    hess, scores, ll, e, s_k = (np.asarray(x) for x in _information(obj, jnp.asarray(theta)))
    nn = np.where(np.asarray(data.mask) > 0, e**2 / s_k, 0.0)
    p = len(params)
    names = params + NOISE_PARAMS
    # clusters: blocks of `block` seconds within each record
    nb = max(1, int(round(block / dt)))
    g = []
    for r_i, pr in enumerate(prepared):
        n = pr.i1 - pr.i0
        for b0 in range(0, n, nb):
            g.append(scores[r_i, b0 : min(b0 + nb, n)].sum(0))
    g = np.stack(g)
    n_cl = g.shape[0]
    hinv = np.linalg.pinv(hess)
    cov_sand_t = hinv @ (g.T @ g) @ hinv * (n_cl / max(n_cl - 1, 1))
    q_ref, s_ref = (float(x) for x in obj.noise_ref)
    sv_hat = s_ref * math.exp(theta[p + 1])
    d = np.concatenate([coords.jacobian_diag(theta[:p]), [q_ref * (np.sign(theta[p]) or 1.0), sv_hat]])
    values = np.concatenate(
        [np.asarray(coords.values(jnp.asarray(theta[:p]))), [abs(q_ref * theta[p]), sv_hat]]
    )
    cov_h = d[:, None] * hinv * d[None, :]
    cov_s = d[:, None] * cov_sand_t * d[None, :]
    cov, cov_other = (cov_h, cov_s) if covariance == "fisher" else (cov_s, cov_h)
    # scale-free conditioning: √cond of the equilibrated information (comparable to a Jacobian's condition number)
    dh = 1 / np.sqrt(np.clip(np.abs(np.diag(hess)), 1e-300, None))
    ev = np.linalg.eigvalsh(dh[:, None] * hess * dh[None, :])
    cond = float(math.sqrt(ev[-1] / ev[0])) if ev[0] > 0 else math.inf
    natural = [_natural_size(nm, ship) for nm in params] + [q_ref, sv_hat]
    ident = identifiability(names, values, cov, natural, condition_number=cond, check=params)
    messages = [ident.message] if ident.not_identified else []
    if msg:
        messages.append(f"the BFGS solve did not converge: {msg}.")
    diags, curves = [], {"time": [], "measured": [], "fitted": [], "record": []}
    for r_i, pr in enumerate(prepared):
        n = pr.i1 - pr.i0
        rec = pr.record
        diags.append(
            RecordDiagnostics(
                rec.source,
                (float(rec.model_time[pr.i0]), float(rec.model_time[pr.i1 - 1])),
                int(n),
                len(range(0, n, nb)),
                float(np.degrees(np.sqrt(np.mean(e[r_i, :n] ** 2)))),
                float(np.degrees(noises[r_i])),
                {
                    "normalised_innovation_rms": float(np.sqrt(np.mean(nn[r_i, :n]))),
                    "nll": float(ll[r_i, :n].sum()),
                    "roll_std_deg": float(np.degrees(np.std(rec.roll[pr.i0 : pr.i1]))),
                },
            )
        )
        curves["time"].append(rec.time[pr.i0 : pr.i1])
        curves["measured"].append(rec.roll[pr.i0 : pr.i1])
        curves["fitted"].append(rec.roll[pr.i0 : pr.i1] - e[r_i, :n])
        curves["record"].append(r_i)
    units = [TIME_DOMAIN_PARAMETERS[nm][0] for nm in params] + [NOISE_UNITS[nm] for nm in NOISE_PARAMS]
    se = np.sqrt(np.clip(np.diag(cov), 0, None))
    n_e = int(n_total)
    dof = math.inf if covariance == "fisher" else float(n_cl - 1)
    return TimeDomainFit(
        method="extended Kalman filter (ML)",
        estimates={
            nm: ParameterEstimate(float(v), float(s), u, dof) for nm, v, s, u in zip(names, values, se, units)
        },
        names=names,
        covariance=cov,
        covariance_model_based=cov_other,
        covariance_kind=(
            "inverse Fisher information of the innovations"
            if covariance == "fisher"
            else f"cluster-robust sandwich, blocks of {block:g} s as clusters, G/(G−1)"
        ),
        correlation=ident.correlation,
        condition_number=cond,
        identifiability=ident,
        n_windows=n_cl,
        window_s=block,
        residual_rms_deg=float(np.degrees(np.sqrt(np.sum(e**2) / n_e))),
        records=diags,
        ship=ship_with(ship, params, jnp.asarray(values[:p])),
        warnings=_issue(messages, warn),
        curves=curves,
        info={
            "nll": float(np.sum(ll)),
            "n_obs": n_e,
            "num_steps": int(steps),
            "result": msg,
            "converged": msg == "",
            "normalised_innovation_rms": float(np.sqrt(np.sum(nn) / n_e)),
        },
        config={
            "params": list(params),
            "covariance": covariance,
            "block_s": block,
            "span_model_s": None if span_model_s is None else [float(x) for x in span_model_s],
            "initial": {nm: float(v) for nm, v in zip(params, start)},
            "integrator": f"jaxroll rk4_step, h = {prepared[0].h:g} s, {sub} step(s) per sample",
            "solver": "optimistix BFGS on the NLL, coordinates whitened by the information at the start",
            "process_noise_start": q0,
            "measurement_noise_start": s0,
            "records": [r.source for r in records],
            "roll_offset_deg": [r.meta["roll_offset_deg"] for r in records],
        },
    )
