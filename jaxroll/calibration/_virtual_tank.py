"""Virtual tank: synthetic tank records with known truth, from the project's integrator (the CLI's
`jaxroll tank`; protocols: docs/records.md)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from ..io._records import Record, make_record
from ..roll._equation import RollProblem, roll_time_series
from ..roll._excitation import SampledExcitation
from ..sea._grim import grim_transfer, superposition_length
from ..sea._spectra import GRAVITY, wave_frequencies_from_encounter
from ..ship._restoring import delta_gm


def virtual_sea(
    sea,
    key,
    num_samples: int,
    dt: float,
    *,
    length: float,
    probes: Sequence[float] = (0.0,),
    speed: float = 0.0,
):
    """One realization of a long-crested head sea seen from the ship: wave elevations and Grim's effective
    wave.

    Components at encounter frequencies ω_j = 2πj/(M·dt), M ≥ `num_samples` (the record never repeats), with
    complex Gaussian amplitudes A_j of variance S_e(ω_j)Δω (one-sided encounter spectrum). In the ship frame
    (x forward from amidships, waves from the bow) a component is Re[A_j e^{i(ω_j t + k_j x)}], k_j = ω_j²/g
    at the absolute wave frequency; the probe at x sees A_j e^{ik_j x}, and Grim's effective wave is
    ζ_G = Σ F(k_j) A_j e^{iω_j t} (crest amidships positive), the same as `jaxroll.superpose` in distribution.

    **Arguments:** `sea`: one-sided spectrum; `key`; `num_samples`; `dt` [s]; `length`: L [m]; `probes`: probe
    positions x [m] relative to amidships, positive forward; `speed`: U [m/s] ≥ 0 (head seas).

    **Returns:** `(elevations [m] of shape (len(probes), num_samples), zeta_g [m], dzeta_g [m/s])`."""

    m = superposition_length(num_samples)
    domega = 2 * jnp.pi / (m * dt)
    omega_e = jnp.arange(m // 2 + 1, dtype=float) * domega
    omegas, weights = wave_frequencies_from_encounter(omega_e, speed, "head")
    omega, jac = omegas[:, 0], weights[:, 0]
    s = sea(omega) * jac
    s = s.at[0].set(0.0).at[-1].set(0.0)
    k = omega**2 / GRAVITY
    xy = jr.normal(key, (2, m // 2 + 1))
    coef = jnp.sqrt(s * domega).astype(complex) * jax.lax.complex(xy[0], xy[1]) * (m / 2)
    f = grim_transfer(k, length).astype(complex)  # explicit casts: strict dtype promotion
    kc = k.astype(complex)
    zeta_g = jnp.fft.irfft(f * coef, n=m)[:num_samples]
    dzeta_g = jnp.fft.irfft(1j * omega_e.astype(complex) * f * coef, n=m)[:num_samples]
    elev = jnp.stack([jnp.fft.irfft(coef * jnp.exp(1j * kc * x), n=m)[:num_samples] for x in probes])
    return elev, zeta_g, dzeta_g


def _integration_grid(record_dt: float, max_dt: float) -> tuple[int, float]:
    sub = max(1, math.ceil(record_dt / max_dt - 1e-9))
    return sub, record_dt / sub


def _simulate_roll(
    ship, zeta_g, dzeta_g, dt: float, num_steps: int, phi0: float, dphi0: float = 0.0, moment=None
):
    """Roll (φ, φ̇) on t_k = k·dt, k ≤ num_steps, from the project's RK4 integrator driven by the given
    ζ_G (and, if given, an external roll moment `moment` = (M_w [rad/s²], dM_w/dt) on the same grid)."""

    exc = SampledExcitation(zeta_g, dzeta_g, dt)
    moment_exc = None if moment is None else SampledExcitation(*moment, dt)
    problem = RollProblem(ship, exc, phi0, dphi0, moment_excitation=moment_exc)
    phi, dphi, end = roll_time_series(problem, jr.key(0), num_steps * dt)
    return np.asarray(phi), np.asarray(dphi), bool(end.capsized)


def _random_moment(key, num_samples: int, dt: float, *, std: float, band: tuple[float, float]):
    """A Gaussian roll moment per unit inertia M_w(t) [rad/s²] with a flat one-sided spectrum over `band`
    [rad/s] and standard deviation `std`, and its exact derivative, on t = k·dt (FFT superposition)."""
    m = superposition_length(num_samples)
    domega = 2 * math.pi / (m * dt)
    omega = np.arange(m // 2 + 1) * domega
    s = ((omega >= band[0]) & (omega <= band[1])).astype(float)
    s = s * std**2 / max(s.sum() * domega, 1e-300)
    xy = jr.normal(key, (2, m // 2 + 1))
    coef = jnp.sqrt(s * domega).astype(complex) * jax.lax.complex(xy[0], xy[1]) * (m / 2)
    x = jnp.fft.irfft(coef, n=m)[:num_samples]
    dx = jnp.fft.irfft(1j * omega * coef, n=m)[:num_samples]
    return x, dx


def _noise(rng: np.random.Generator, sigma: float, n: int) -> np.ndarray:
    return rng.normal(0.0, sigma, n) if sigma > 0 else np.zeros(n)


def virtual_decay_record(
    ship,
    *,
    initial_roll_deg: float = 20.0,
    duration_model_s: float = 60.0,
    scale: float = 100.0,
    sampling_hz: float = 20.0,
    roll_noise_deg: float = 0.0,
    seed: int = 0,
    max_dt: float = 0.25,
    realization: int | None = None,
    rest_model_s: float = 0.0,
    roll_offset_deg: float = 0.0,
    drift_deg_per_min: float = 0.0,
    speed_model_m_s: float | None = None,
) -> Record:
    """A free-decay record from the ship's own roll equation (P = 0), released from rest at
    `initial_roll_deg`.

    Integrated with the project's RK4 (`jaxroll.roll_time_series`) at ≤ `max_dt` [s, full scale]; sampled at
    `sampling_hz` (model scale); Gaussian sensor noise of std `roll_noise_deg` [deg] added (numpy `seed`).

    A record as a lab hands it over (docs/calibration.md, "Records as labs hand them over"): `rest_model_s` [s,
    model scale] of the model at rest before it is heeled by hand (over 1.5 s model scale) and released, so the
    release is at t = `rest_model_s` + 1.5 s; a roll offset `roll_offset_deg` [deg] (a model heeled by a
    fraction of a degree: the decay is about it) and a linear sensor drift `drift_deg_per_min` [deg per model-scale
    minute] added to the whole record; `speed_model_m_s` [m/s, model scale] only goes into the header (the
    damping it brings is in `ship`)."""
    record_dt = math.sqrt(scale) / sampling_hz
    n_decay = int(round(duration_model_s * sampling_hz)) + 1
    sub, dt = _integration_grid(record_dt, max_dt)
    steps = (n_decay - 1) * sub
    zeros = jnp.zeros(steps + 1)
    phi, _, capsized = _simulate_roll(ship, zeros, zeros, dt, steps, math.radians(initial_roll_deg))
    if capsized:
        raise ValueError(f"the decay from {initial_roll_deg}° capsizes the ship; start from a smaller angle.")
    phi = phi[::sub][:n_decay]
    if rest_model_s > 0:
        n_rest = int(round(rest_model_s * sampling_hz))
        n_ramp = int(round(1.5 * sampling_hz))
        ramp = 0.5 * (1 - np.cos(np.pi * np.arange(n_ramp) / n_ramp)) * math.radians(initial_roll_deg)
        phi = np.concatenate([np.zeros(n_rest), ramp, phi])
    n = phi.size
    rng = np.random.default_rng(seed)
    t_model = np.arange(n) / sampling_hz
    roll = (
        phi
        + np.radians(_noise(rng, roll_noise_deg, n))
        + math.radians(roll_offset_deg)
        + math.radians(drift_deg_per_min) * t_model / 60
    )
    meta: dict[str, Any] = {"initial_roll_deg": float(initial_roll_deg)}
    if realization is not None:
        meta["realization"] = realization
    if speed_model_m_s is not None:
        meta["speed_model_m_s"] = float(speed_model_m_s)
    meta["generator"] = f"jaxroll virtual tank (ship {ship.name!r})"
    return make_record(
        "decay", np.arange(n) * record_dt, {"roll": roll}, scale=scale, sampling_hz=sampling_hz, **meta
    )


def write_lab_file(record: Record, path, *, angle_unit: str = "rad", units_file: bool = True):
    """Write `record` as a lab writes a motion record (model scale): columns `time,x,y,z,phi,theta,psi` (s, m,
    m, m, then the angles in `angle_unit`, "rad" or "deg"; only `phi` is the roll, the rest 0 apart from a
    little noise-free sway), the names on the first line, and the units in a side file `<stem>_units.csv` of two
    rows (the names, then the units) when `units_file` (else on a second line under the names).

    **Returns:** `(data file, units file or None)`."""
    from pathlib import Path

    if angle_unit not in ("rad", "deg"):
        raise ValueError(f"`angle_unit` must be 'rad' or 'deg'; got {angle_unit!r}.")
    path = Path(path)
    t = record.model_time
    phi = record.roll if angle_unit == "rad" else np.degrees(record.roll)
    zero = np.zeros_like(t)
    data = np.column_stack([t, zero, 1e-3 * np.sin(0.3 * t), zero, phi, zero, zero])
    names = "time,x,y,z,phi,theta,psi"
    units = f"s,m,m,m,{angle_unit},{angle_unit},{angle_unit}"
    body = "\n".join(",".join(f"{v:.7g}" for v in row) for row in data) + "\n"
    side = None
    if units_file:
        side = path.with_name(path.name.split(".")[0] + "_units.csv")
        side.write_text(f"{names}\n{units}\n")
        path.write_text(f"{names}\n{body}")
    else:
        path.write_text(f"{names}\n{units}\n{body}")
    return path, side


def _sea_meta(sea, scale, probe_x_model_m, speed_model_m_s, realization):
    meta = {
        "wave_height_full_m": float(sea.hs),
        "wave_period_full_s": float(sea.t01),
        "probe_x_model_m": float(probe_x_model_m),
        "speed_model_m_s": float(speed_model_m_s),
        "spectrum": "ITTC",
        "heading": "head",
    }
    if realization is not None:
        meta["realization"] = realization
    return meta


def virtual_captive_record(
    ship,
    sea,
    *,
    heel_deg: float,
    seed: int = 0,
    duration_model_s: float = 360.0,
    scale: float = 100.0,
    sampling_hz: float = 20.0,
    probe_x_model_m: float = 2.0,
    speed_model_m_s: float = 0.0,
    wave_noise_mm: float = 0.0,
    gm_noise_mm: float = 0.0,
    realization: int | None = None,
) -> Record:
    """A captive test at fixed heel: wave at the probe and the measured ΔGM, from a sea with known truth.

    Truth: ΔGM_obs(t) = r · Σ C_k ζ_mid(t)^k + noise with r = `ship.gm_correction` (σ_obs/σ_thr) and ζ_mid =
    −ζ_G of the same realization; the virtual tank's ΔGM does not depend on the heel. Noise: Gaussian, std
    `wave_noise_mm` / `gm_noise_mm` [mm, model scale]. `sea` must be `jaxroll.ITTC` (the header records H1/3,
    T01).
    """

    record_dt = math.sqrt(scale) / sampling_hz
    n = int(round(duration_model_s * sampling_hz)) + 1
    speed = speed_model_m_s * math.sqrt(scale)
    elev, zeta_g, _ = virtual_sea(
        sea,
        jr.key(seed),
        n,
        record_dt,
        length=float(ship.lpp),
        probes=(probe_x_model_m * scale,),
        speed=speed,
    )
    dgm = np.asarray(ship.gm_correction * delta_gm(ship, -zeta_g))
    rng = np.random.default_rng([seed, 1])
    wave = np.asarray(elev[0]) + _noise(rng, wave_noise_mm * 1e-3 * scale, n)
    dgm = dgm + _noise(rng, gm_noise_mm * 1e-3 * scale, n)
    meta = _sea_meta(sea, scale, probe_x_model_m, speed_model_m_s, realization)
    meta = {**meta, "heel_deg": float(heel_deg), "generator": f"jaxroll virtual tank (ship {ship.name!r})"}
    return make_record(
        "captive",
        np.arange(n) * record_dt,
        {"wave": wave, "delta_gm": dgm},
        scale=scale,
        sampling_hz=sampling_hz,
        **meta,
    )


def virtual_roll_record(
    ship,
    sea,
    *,
    seed: int = 0,
    duration_model_s: float = 360.0,
    scale: float = 100.0,
    sampling_hz: float = 20.0,
    probe_x_model_m: float = 0.0,
    initial_roll_deg: float = 5.0,
    roll_noise_deg: float = 0.0,
    wave_noise_mm: float = 0.0,
    max_dt: float = 0.25,
    max_attempts: int = 20,
    realization: int | None = None,
    moment_std: float = 0.0,
    moment_band: tuple[float, float] = (0.05, 1.0),
) -> tuple[Record, int]:
    """A free-running roll record in irregular head seas from the project's integrator, and its capsize count.

    Roll from `jaxroll.roll_time_series` driven by Grim's effective wave of the same realization as the wave
    column (the elevation at `probe_x_model_m`, amidships by default); φ(0) = `initial_roll_deg`, φ̇(0) = 0
    (the paper's MCS start). A realization that capsizes is not a record: the tank draws the next one (seed
    sub-streams) and returns how many it discarded.

    **Model error on purpose:** `moment_std` > 0 [rad/s², full scale] adds an external random roll moment per
    unit inertia M_w(t) (`RollProblem(moment_excitation=...)`), Gaussian with a flat spectrum over
    `moment_band` [rad/s, full scale] — something the calibrated roll model does not contain (wind, a beam
    component, sloshing), for testing how the estimators behave under model error (docs/calibration.md).
    5e-4 rad/s² alone rolls the default ship 3–4° rms. Records with `moment_std` = 0 are unchanged.

    **Returns:** `(record, n_capsized_attempts)`.
    """

    if not (math.isfinite(moment_std) and moment_std >= 0):
        raise ValueError(f"`moment_std` must be >= 0 [rad/s²]; got {moment_std!r}.")
    if moment_std > 0 and not (0 <= moment_band[0] < moment_band[1]):
        raise ValueError(
            f"`moment_band` must be (low, high) [rad/s] with 0 <= low < high; got {moment_band!r}."
        )
    record_dt = math.sqrt(scale) / sampling_hz
    n = int(round(duration_model_s * sampling_hz)) + 1
    sub, dt = _integration_grid(record_dt, max_dt)
    steps = (n - 1) * sub
    for attempt in range(max_attempts):
        key = jr.fold_in(jr.key(seed), attempt)
        elev, zeta_g, dzeta_g = virtual_sea(
            sea, key, steps + 1, dt, length=float(ship.lpp), probes=(probe_x_model_m * scale,)
        )
        moment = None
        if moment_std > 0:
            moment = _random_moment(jr.fold_in(key, 77), steps + 1, dt, std=moment_std, band=moment_band)
        phi, _, capsized = _simulate_roll(
            ship, zeta_g, dzeta_g, dt, steps, math.radians(initial_roll_deg), moment=moment
        )
        if not capsized:
            break
    else:
        raise ValueError(f"all {max_attempts} realizations capsized; the sea is too severe for this ship.")
    rng = np.random.default_rng([seed, 2])
    roll = phi[::sub][:n] + np.radians(_noise(rng, roll_noise_deg, n))
    wave = np.asarray(elev[0])[::sub][:n] + _noise(rng, wave_noise_mm * 1e-3 * scale, n)
    meta = _sea_meta(sea, scale, probe_x_model_m, 0.0, realization)
    meta = {
        **meta,
        "initial_roll_deg": float(initial_roll_deg),
        "generator": f"jaxroll virtual tank (ship {ship.name!r})"
        + (
            f"; extra random roll moment, std {moment_std:g} rad/s², band {moment_band[0]:g}–{moment_band[1]:g} rad/s"
            if moment_std > 0
            else ""
        ),
    }
    rec = make_record(
        "roll",
        np.arange(n) * record_dt,
        {"roll": roll, "wave": wave},
        scale=scale,
        sampling_hz=sampling_hz,
        **meta,
    )
    return rec, attempt
