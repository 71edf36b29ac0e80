"""Amplitude estimators of the roll-PDF fit: zero crossings with hysteresis and the Hilbert envelope."""

# To move next to jaxroll/roll/_amplitudes.py (zero_crossing_amplitudes, hilbert_envelope).

from __future__ import annotations

import jax
import jax.numpy as jnp

from ..roll._amplitudes import hilbert_envelope


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
