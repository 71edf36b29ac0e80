"""Method 2: a rational linear filter driven by white noise that reproduces the effective-wave spectrum.

    dz = A z dt + b dW (unit-intensity Wiener process W),   ζ_G = cᵀ z,
    H(s) = cᵀ(sI − A)⁻¹ b = s·(β_0 + β_1 s + … + β_{n−3} s^{n−3}) / Π(sections),

one-sided output spectrum S(ω) = |H(iω)|²/π. The numerator has a zero at s = 0 (S_G(0) = 0) and degree ≤ n − 2,
so ζ_G is differentiable (dζ_G/dt = cᵀ A z): the Monte Carlo uses that to interpolate the excitation within a
step. The denominator is a product of stable second-order sections s² + 2ζ_k ω_k s + ω_k² (and s + p for odd n),
so every fitted filter is stable. The fit matches the variance σ_G² exactly (by construction) and S_G in the
least-squares sense, with extra weight on S_G(2ω0), which drives the parametric resonance.
"""

from __future__ import annotations

import functools
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np
import optimistix as optx
from jaxtyping import Array, Float

from .._compiled import SMALL_PROGRAM, cached_program
from .._config import require_float64
from ._grim import EffectiveWave


class ShapingFilter(eqx.Module):
    """State-space filter (A, b, c) in controllable canonical form; one-sided output spectrum |H(iω)|²/π."""

    a: Float[Array, "n n"]
    b: Float[Array, " n"]
    c: Float[Array, " n"]

    @property
    def order(self) -> int:
        """The filter's order n (the state dimension) [-]."""
        return self.a.shape[0]

    def transfer(self, omega) -> Array:
        """H(iω) (complex) at `omega` [rad/s]."""
        n = self.order
        s = 1j * jnp.asarray(omega, dtype=float).astype(complex)
        a, c = self.a[-1].astype(complex), self.c.astype(complex)
        den = s**n - sum(a[k] * s**k for k in range(n))
        num = sum(c[k] * s**k for k in range(n))
        return num / den

    def spectrum(self, omega) -> Float[Array, "..."]:
        """One-sided output spectrum S(ω) = |H(iω)|²/π [m² s/rad] at `omega` [rad/s]."""
        return jnp.abs(self.transfer(omega)) ** 2 / jnp.pi

    def stationary_covariance(self) -> Float[Array, "n n"]:
        """Σ solving A Σ + Σ Aᵀ + b bᵀ = 0 (exact stationary covariance of z) [m² units of the state]."""
        return lyapunov(self.a, jnp.outer(self.b, self.b))

    def variance(self) -> Float[Array, ""]:
        """Stationary output variance cᵀ Σ c [m²]."""
        return self.c @ self.stationary_covariance() @ self.c

    def discretise(self, dt) -> tuple[Float[Array, "n n"], Float[Array, "n n"]]:
        """Exact discretisation at step `dt` [s]: z_{k+1} = Φ z_k + L ε_k, ε_k ~ N(0, I).

        Φ = e^{A dt}; L Lᵀ = Σ − Φ Σ Φᵀ (the exact one-step covariance, from the stationary Σ).
        """
        phi = jsl.expm(self.a * dt)
        sigma = self.stationary_covariance()
        return phi, psd_sqrt(sigma - phi @ sigma @ phi.T)


MAX_FILTER_ORDER = 12
"""Highest supported filter order (docs/numerics.md: the canonical form's conditioning bounds it)."""


def check_filter_fit(fit: "FilterFit", dt=None) -> list[str]:
    """Gate a run on the quality of a filter fit; raise `ValueError` when the filter would give a wrong sea.

    Checks, independently of the Lyapunov solve used by the fit: the output variance by quadrature of |H|²/π
    against the target (error: > 10 %, warning: > 3 %), S at the match frequency (error: > 25 %, warning: > 10 %),
    the relative L2 error (error: > 0.5, warning: > 0.25), the stationary covariance Σ (must be positive
    definite) and, given `dt`, the discretised filter: spectral radius of Φ < 1 and Σ − ΦΣΦᵀ positive
    semi-definite up to round-off. **Returns:** the warnings (also issued with `warnings.warn`).
    """
    import warnings

    f = fit.filter
    errors, warns = [], []
    var_q, s_match, sigma, phi = jax.device_get(
        _fit_diagnostics(f, fit.match_frequency, dt)
    )  # numpy; phi may be None
    var_q = float(var_q)
    var_t = float(fit.variance_target)
    # Beam seas: the target is ζ_G ≡ 0 and the fit a zero-gain filter (output exactly 0).
    dv = abs(var_q - var_t) / var_t if var_t > 0 else (0.0 if var_q == 0 else math.inf)
    (errors if dv > 0.10 else warns if dv > 0.03 else []).append(
        f"filter output variance {var_q:.4g} m² (by quadrature) vs target {var_t:.4g} m² ({100 * dv:.1f} % off)"
    )
    sm, st = float(s_match), float(fit.spectrum_target_at_match)
    dm = abs(sm - st) / st if st > 0 else 0.0
    off = f"{100 * dm:.0f} % off" if dm < 10 else f"{sm / st:.3g} times the target"
    if dm >= 10 and st < 1e-6 * var_t:  # e.g. short waves: the filter's tail is all there is at 2ω0
        off += "; the sea has almost no energy at 2ω0, where the roll is excited parametrically"
    (errors if dm > 0.25 else warns if dm > 0.10 else []).append(
        f"filter spectrum at {float(fit.match_frequency):.3g} rad/s (2ω0) is {sm:.4g} vs target {st:.4g} m² s "
        f"({off})"
    )
    rel = float(fit.relative_l2_error)
    (errors if rel > 0.5 else warns if rel > 0.25 else []).append(
        f"relative L2 error of the fit is {rel:.3g}"
    )
    ev = np.linalg.eigvalsh(sigma)
    if not (np.all(np.isfinite(ev)) and ev.min() > 0):
        errors.append(
            f"stationary covariance not positive definite (eigenvalues {ev.min():.3g} … {ev.max():.3g})"
        )
    if dt is not None and not errors:
        rho = float(np.abs(np.linalg.eigvals(phi)).max())
        if not rho < 1.0:
            errors.append(f"discretised filter is not stable (spectral radius of Φ = {rho:.6f} ≥ 1)")
        q = sigma - phi @ sigma @ phi.T
        wq = np.linalg.eigvalsh((q + q.T) / 2)
        if wq.min() < -1e-6 * max(wq.max(), 1e-300):
            errors.append(f"Σ − ΦΣΦᵀ is indefinite (eigenvalues {wq.min():.3g} … {wq.max():.3g})")
    if errors:
        raise ValueError(
            f"the order-{f.order} shaping-filter fit is not usable: "
            + "; ".join(errors)
            + ". A rational filter "
            "cannot follow every effective-wave spectrum (e.g. following seas at speed, where encounter compresses "
            "it). Use the superposition excitation, which synthesises any spectrum (RollProblem.from_sea(..., "
            "excitation='superposition'); on the command line --method superposition), or another filter order "
            "(filter_order, --filter-order)."
        )
    for w in warns:
        warnings.warn(f"order-{f.order} shaping filter: {w}", stacklevel=2)
    return warns


@cached_program(compiler_options=SMALL_PROGRAM)
def _fit_diagnostics(f, match_frequency, dt):
    """The numbers `check_filter_fit` judges, in one compiled program: output variance by quadrature of S on
    (0, 20] rad/s [m²], S at the match frequency, Σ, and Φ = e^{A dt} (None without `dt`)."""
    grid = jnp.linspace(0.0, 20.0, 40001)[1:]
    var_q = jnp.trapezoid(f.spectrum(grid), grid)
    phi = None if dt is None else jsl.expm(f.a * dt)
    return var_q, f.spectrum(match_frequency), f.stationary_covariance(), phi


def lyapunov(a, q):
    """Solve A X + X Aᵀ + Q = 0 for X (small dense systems, by Kronecker vectorisation)."""
    n = a.shape[0]
    eye = jnp.eye(n)
    big = jnp.kron(eye, a) + jnp.kron(a, eye)
    x = jnp.linalg.solve(big, -q.reshape(-1)).reshape(n, n)
    return (x + x.T) / 2


def psd_sqrt(m):
    """A square root L (L Lᵀ = M) of a symmetric positive semi-definite matrix; round-off negatives clipped."""
    m = (m + m.T) / 2
    w, v = jnp.linalg.eigh(m)
    return v * jnp.sqrt(jnp.clip(w, 0.0, None))


def _polymul(p, q):
    return jnp.convolve(p, q)


def filter_from_parameters(params: Float[Array, " p"], order: int) -> ShapingFilter:
    """Build a stable filter from unconstrained parameters: per section (ln ω_k, ln ζ_k), ln p (odd n), then β."""
    n_sections, odd = divmod(order, 2)
    den = jnp.ones(1)
    i = 0
    for _ in range(n_sections):
        w, z = jnp.exp(params[i]), jnp.exp(params[i + 1])
        den = _polymul(den, jnp.stack([1.0, 2 * z * w, w**2]))
        i += 2
    if odd:
        den = _polymul(den, jnp.stack([1.0, jnp.exp(params[i])]))
        i += 1
    beta = params[i:]  # β_0 … β_{n−3}, numerator s·β(s)
    den_low = den[::-1][:order]  # α_0 … α_{n−1} (ascending), monic
    a = jnp.zeros((order, order)).at[:-1, 1:].set(jnp.eye(order - 1)).at[-1].set(-den_low)
    b = jnp.zeros(order).at[-1].set(1.0)
    c = jnp.zeros(order).at[1 : 1 + beta.size].set(beta)
    return ShapingFilter(a, b, c)


def fitted_form(order: int) -> ShapingFilter:
    """A filter of `order` with the structure every `filter_from_parameters` (hence `fit_filter`) result has: the
    companion rows of A, b = e_n, c₀ = c_{n−1} = 0, and ones where a fit has free coefficients. Its shapes, and
    which coefficients are zero, are those of the fit, so a program built for the fit can be traced and compiled
    with it before the fit is made (`jaxroll.theory.iter_theory_summaries`). No computation: its arrays are placed
    on the default device as the fit's outputs are (committed), so that the compiled program is the same. Raises
    `fit_filter`'s error for an order it refuses (a program is not traced for it)."""
    _check_order(order)
    a = np.zeros((order, order))
    a[:-1, 1:] = np.eye(order - 1)
    a[-1] = 1.0
    b = np.zeros(order)
    b[-1] = 1.0
    c = np.zeros(order)
    c[1 : order - 1] = 1.0
    device = jax.config.jax_default_device or jax.devices()[0]
    return ShapingFilter(*(jax.device_put(x, device) for x in (a, b, c)))


def _scaled(params, order, variance):
    """The filter of `params` with its gain scaled so that its output variance is exactly `variance`."""
    f = filter_from_parameters(params, order)
    return eqx.tree_at(lambda f: f.c, f, f.c * jnp.sqrt(variance / f.variance()))


class FilterFit(eqx.Module):
    """A fitted shaping filter and the quality of its fit."""

    filter: ShapingFilter
    relative_l2_error: Float[Array, ""]
    variance_target: Float[Array, ""]
    variance_filter: Float[Array, ""]
    match_frequency: Float[Array, ""]
    spectrum_target_at_match: Float[Array, ""]
    spectrum_filter_at_match: Float[Array, ""]
    result: optx.RESULTS
    # Set by `fit_filter_in_band`: the band [rad/s] the order was chosen on and the fit's error there (`band_error`).
    band: Float[Array, " 2"] | None = None
    band_error: Float[Array, ""] | None = None

    def summary(self) -> dict:
        """Fit quality as plain numbers (for JSON)."""
        return {
            "order": int(self.filter.order),
            "converged": bool(self.result == optx.RESULTS.successful),
            "relative_l2_error": float(self.relative_l2_error),
            "variance_target_m2": float(self.variance_target),
            "variance_filter_m2": float(self.variance_filter),
            "match_frequency_rad_s": float(self.match_frequency),
            "spectrum_target_at_match_m2s": float(self.spectrum_target_at_match),
            "spectrum_filter_at_match_m2s": float(self.spectrum_filter_at_match),
            **(
                {}
                if self.band is None
                else {
                    "band_rad_s": [float(x) for x in self.band],
                    "band_error": float(self.band_error),
                    "order_chosen": "auto",
                }
            ),
        }


def fit_filter(
    wave: EffectiveWave, *, order: int = 4, match_frequency=None, match_weight: float = 10.0, num: int = 400
) -> FilterFit:
    """Fit a Method-2 shaping filter of `order` (≥ 3) to Grim's effective-wave spectrum S_G (optimistix LM).

    **Arguments:**

    - `wave`: the effective wave (sea, ship length, speed, heading).
    - `order`: filter order n ≥ 3 (4 is the default: docs/theory.md reports order 2 under-excites roll by ~16 %).
    - `match_frequency`: encounter frequency [rad/s] where S_G is matched with extra weight (use 2ω0).
    - `match_weight`: weight of that point relative to one grid point of the L2 fit.
    - `num`: number of fit frequencies.

    **Returns:** a `FilterFit`; the output variance equals ∫S_G exactly, `relative_l2_error` = ‖S−S_G‖/‖S_G‖ on
    the fit grid.
    """
    require_float64("jaxroll.fit_filter")
    _check_order(order)
    return _fit_filter(wave, order, match_frequency, match_weight, num)


def _check_order(order: int) -> None:
    if order > MAX_FILTER_ORDER:
        raise ValueError(
            f"`order` must be <= {MAX_FILTER_ORDER} (got {order}): the controllable canonical form is too "
            "ill-conditioned above it (cond(A) ~1e13 and an indefinite stationary covariance at order 30; an "
            "unstable discretised filter at order 40), so the simulated sea would be wrong."
        )
    if order < 3:
        raise ValueError(
            f"`order` must be >= 3 (got {order}): the filter needs relative degree 2 so that ζ_G is differentiable."
        )


def _fit_residuals(params, data, order: int, match_weight: float):
    """The fit's residuals: (S − S_G)/max S_G on the grid, and √w·(S − S_G)/max S_G at the match frequency."""
    variance, grid, target, scale, wm, target_m = data
    f = _scaled(params, order, variance)
    r = (f.spectrum(grid) - target) / scale
    rm = jnp.sqrt(match_weight) * (f.spectrum(wm) - target_m) / scale
    return jnp.concatenate([r, rm[None]])


@functools.partial(jax.custom_jvp, nondiff_argnums=(0, 1))
def _at_optimum(order: int, match_weight: float, params, data):
    """`params`, the least-squares optimum for `data`, carrying its derivative in `data`: the implicit function
    theorem on the optimality condition g(θ, d) = ∇θ ½‖r(θ, d)‖² = 0 gives dθ = −(∂g/∂θ)⁻¹ (∂g/∂d)·dd — what
    optimistix's implicit adjoint computes, solved here by LU without a run-time check."""
    return params


@_at_optimum.defjvp
def _at_optimum_jvp(order, match_weight, primals, tangents):
    params, data = primals
    _, t_data = tangents

    def gradient(p, d):
        return jax.grad(lambda q: 0.5 * jnp.sum(_fit_residuals(q, d, order, match_weight) ** 2))(p)

    _, g_dot = jax.jvp(lambda d: gradient(params, d), (data,), (t_data,))
    # The numerator β is fitted only up to its scale (`_scaled` sets the gain from the variance): the residuals do
    # not change along v = (0, β), so the Hessian is singular there (its smallest eigenvalue 2e-16 for the paper's
    # sea) and g_dot ⟂ v. A plain solve returned an arbitrary, rounding-dependent multiple of v, which the scaling
    # removes only up to cancellation: compiled with other XLA options, dc/dH1/3 came out 2 % wrong. Adding α·v vᵀ
    # (α ~ the Hessian's mean eigenvalue) makes the system regular and leaves the solution orthogonal to v.
    hessian = jax.jacfwd(gradient)(params, data)
    v = jnp.zeros_like(params).at[order:].set(params[order:])
    alpha = jnp.trace(hessian) / (params.size * jnp.sum(v * v))
    # Beam seas (σ_G² = 0): every residual vanishes whatever θ, the Hessian is 0, and the zero filter stays zero.
    sea = data[0] > 0
    regular = jnp.where(sea, hessian + alpha * jnp.outer(v, v), jnp.eye(params.size, dtype=params.dtype))
    return params, jnp.where(sea, -jnp.linalg.solve(regular, g_dot), 0.0)


@cached_program
def _fit_filter(wave: EffectiveWave, order: int, match_frequency, match_weight: float, num: int) -> FilterFit:
    """`fit_filter`'s numerics as one compiled program (kept on disk by the CLI: a warm run neither traces nor
    compiles it; ~100 small programs dispatched op by op before)."""
    variance = wave.variance()
    grid = jnp.linspace(0.0, 3.0, num + 1)[1:]
    target = wave.spectrum(grid)
    scale = jnp.max(target)
    peak = grid[jnp.argmax(target)]
    # Beam seas: S_G ≡ 0 and the fit is the zero-gain filter; its poles (any) start well conditioned near 0.5 rad/s.
    peak = jnp.where(scale > 0, peak, 0.5)
    scale = jnp.where(scale > 0, scale, 1.0)
    wm = peak if match_frequency is None else jnp.asarray(match_frequency, dtype=float)
    target_m = wave.spectrum(wm)

    n_sections, odd = divmod(order, 2)
    spread = jnp.linspace(-0.25, 0.25, n_sections) if n_sections > 1 else jnp.zeros(1)
    init = []
    for k in range(n_sections):
        init += [jnp.log(peak) + spread[k], jnp.log(0.25)]
    if odd:
        init.append(jnp.log(peak))
    init += [1.0] + [0.0] * (order - 3)
    init = jnp.stack([jnp.asarray(v, dtype=float) for v in init])

    # The optimum's derivative in the fit's data by the implicit function theorem (`_at_optimum`): the solve
    # itself sees no tangents, so optimistix's own adjoint (whose lineax solve checks its result with a host
    # callback, which keeps a program out of JAX's disk cache) is not traced.
    data = (variance, grid, target, scale, wm, target_m)
    sol = optx.least_squares(
        functools.partial(_fit_residuals, order=order, match_weight=match_weight),
        optx.LevenbergMarquardt(rtol=1e-10, atol=1e-12),
        jax.lax.stop_gradient(init),
        jax.lax.stop_gradient(data),
        max_steps=2000,
        throw=False,
    )
    f = _scaled(_at_optimum(order, match_weight, sol.value, data), order, variance)
    fitted = f.spectrum(grid)
    norm = jnp.linalg.norm(target)
    rel = jnp.where(norm > 0, jnp.linalg.norm(fitted - target) / jnp.where(norm > 0, norm, 1.0), 0.0)
    # Beam seas: every residual is 0 whatever the parameters, so the zero-gain filter is exact.
    result = optx.RESULTS.where(variance > 0, sol.result, optx.RESULTS.successful)
    return FilterFit(f, rel, variance, f.variance(), wm, target_m, f.spectrum(wm), result)


# ----------------------------------------------------------------------------------------------------------------
# The order the roll needs: the fit checked on the band of encounter frequencies the roll responds to
# ----------------------------------------------------------------------------------------------------------------

#: Orders `fit_filter_in_band` tries, lowest first. Not 6: its fits carry high-frequency content that the Monte
#: Carlo's bridge cannot interpolate over 4 time steps (m = 1–2: 3–6 normals a time step against order 8's 2), so
#: order 8 is both closer on the band and cheaper. Not 10 or 12: their Levenberg–Marquardt fits run to the step
#: limit (30–100 s on a 2-core CPU) for little gain on the band.
BAND_ORDERS = (4, 8)
#: The largest band error `fit_filter_in_band` accepts (`band_error`).
BAND_TOLERANCE = 0.05
#: Below this fraction of the band's largest S_G, errors count against that level instead of S_G itself.
BAND_FLOOR = 0.1


def band_error(shaping_filter: ShapingFilter, wave: EffectiveWave, band, *, num: int = 201) -> float:
    """The largest error of the filter's spectrum against S_G on the encounter-frequency `band` (lo, hi) [rad/s]:
    max |S − S_G| / max(S_G, `BAND_FLOOR`·max S_G) over `num` points [-] (relative where S_G carries weight, against
    a tenth of the band's peak where it carries little). Host arithmetic on concrete inputs: S_G interpolated from
    `spectrum_on_grid` (step 5e-4 rad/s), the filter's from `ShapingFilter.spectrum`."""
    from ._grim import SPECTRUM_GRID, spectrum_on_grid

    grid = np.linspace(float(band[0]), float(band[1]), num)
    s_g = np.interp(grid, SPECTRUM_GRID, np.asarray(spectrum_on_grid(wave)))
    s_f = np.asarray(shaping_filter.spectrum(grid))
    if not np.any(s_g > 0):
        return 0.0 if np.allclose(s_f, 0.0) else math.inf
    level = np.maximum(s_g, BAND_FLOOR * s_g.max())
    return float(np.max(np.abs(s_f - s_g) / level))


def band_warning(order: int, err: float, band, tolerance: float = BAND_TOLERANCE, orders=BAND_ORDERS) -> str:
    """`fit_filter_in_band`'s warning where no order of `orders` follows S_G within `tolerance` on `band`."""
    return (
        f"no shaping filter of order {', '.join(map(str, orders))} follows the effective-wave spectrum within "
        f"{100 * tolerance:g} % on {band[0]:.3g}–{band[1]:.3g} rad/s, where the roll is excited; the best, order "
        f"{order}, is {100 * err:.0f} % off there, which biases the roll's tail. Use the superposition "
        "excitation (excitation='superposition', --method superposition) for this sea state."
    )


def fit_filter_in_band(
    wave: EffectiveWave,
    band,
    *,
    match_frequency=None,
    tolerance: float = BAND_TOLERANCE,
    orders=BAND_ORDERS,
    warn: bool = True,
) -> FilterFit:
    """The lowest-order shaping filter whose spectrum follows S_G within `tolerance` on the encounter-frequency
    `band` (lo, hi) [rad/s] the roll responds to (`band_error`), fitted by `fit_filter` at each order of `orders`
    (default 4, then 8: `BAND_ORDERS`) in turn. Where none does, the order with the smallest band error, with a warning that gives it.

    Why: the tail of the roll is set by S_G over the frequencies 2ω(A) of the amplitudes A it reaches, which a
    softening GZ lowers below 2ω0; the paper's order-4 filter matches the variance and S_G(2ω0) but is 10–100 % off
    elsewhere on that band in some seas, which biases P(roll > angle) (docs/numerics.md, "The filter's order").

    `warn=False`: no warning here (`RollProblem.from_sea` warns after its usability check, `band_warning`).

    **Returns:** the `FilterFit`, with `band` and `band_error` set (also in `summary()`).
    """
    import warnings

    require_float64("jaxroll.fit_filter_in_band")
    lo, hi = float(band[0]), float(band[1])
    if not (0 < lo < hi and math.isfinite(hi)):
        raise ValueError(f"`band` must be (lo, hi) with 0 < lo < hi [rad/s]; got {band!r}.")
    if not orders:
        raise ValueError("`orders` must name at least one filter order.")
    best = None
    for order in orders:
        fit = fit_filter(wave, order=order, match_frequency=match_frequency)
        err = band_error(fit.filter, wave, (lo, hi))  # converged or not: the band says whether it is good
        err = err if math.isfinite(err) else math.inf
        if best is None or err < best[1]:
            best = (fit, err)
        if err <= tolerance:
            break
    fit, err = best
    if err > tolerance and warn:
        warnings.warn(band_warning(fit.filter.order, err, (lo, hi), tolerance, orders), stacklevel=2)
    return eqx.tree_at(
        lambda f: (f.band, f.band_error),
        fit,
        (jnp.asarray([lo, hi]), jnp.asarray(err)),
        is_leaf=lambda x: x is None,
    )
