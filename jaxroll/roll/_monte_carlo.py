"""Monte Carlo over realizations: chunked, vmapped, keyed by realization index, reduced on the fly.

Memory is bounded by `chunk_size` whatever the number of realizations; results are identical for a given seed
whatever the chunk size (realization i always uses `fold_in(key, i)`, histogram counts are integers and
per-realization sums are added in index order on the host).
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import re
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from ._amplitudes import (
    hilbert_envelope,
    histogram_counts,
    zero_crossing_init,
    zero_crossing_update,
)
from ._equation import FilterExcitation, RollProblem, SuperpositionExcitation, simulate
from ..sea._filters import FilterFit, fit_filter
from ..sea._grim import EffectiveWave
from ..ship._ship import Ship
from ..sea._spectra import AbstractWaveSpectrum

QUANTILE_LEVELS = (0.5, 0.9, 0.99)


def excitation_bandwidth(wave: EffectiveWave, fraction: float = 0.999) -> float:
    """Encounter frequency [rad/s] below which `fraction` of the effective-wave variance lies."""
    w = np.linspace(0.0, 6.0, 12001)
    s = np.asarray(wave.spectrum(w))
    cum = np.concatenate([[0.0], np.cumsum((s[1:] + s[:-1]) / 2 * np.diff(w))])
    return float(np.interp(fraction * cum[-1], cum, w))


def check_time_step(dt: float, ship: Ship, wave: EffectiveWave) -> None:
    """Validate the time step [s] against the roll period and the excitation bandwidth.

    Error when dt > Tφ/10 or ω_max·dt > 1 (RK4 loses accuracy and may go unstable); a warning when
    dt > Tφ/40 or ω_max·dt > 0.6 (halving dt may then change the mean amplitude by more than ~1 %). ω_max is the
    encounter frequency below which 99.9 % of the effective-wave variance lies.
    """
    if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
        raise ValueError(f"`dt` must be a finite number > 0 [s]; got {dt!r}.")
    t_roll = float(ship.roll_period)
    w_max = excitation_bandwidth(wave)
    if dt > t_roll / 10 or w_max * dt > 1.0:
        raise ValueError(
            f"dt = {dt} s is too large: it must be <= Tφ/10 = {t_roll / 10:.3g} s and <= 1/ω_max = "
            f"{1 / w_max:.3g} s (ω_max = {w_max:.3g} rad/s holds 99.9 % of the effective-wave variance). "
            f"Use dt <= {min(t_roll / 40, 0.6 / w_max):.3g} s for ~1 % accuracy."
        )
    if dt > t_roll / 40 or w_max * dt > 0.6:
        warnings.warn(
            f"dt = {dt} s may bias the amplitudes by more than ~1 %. This warning appears because dt > Tφ/40 = "
            f"{t_roll / 40:.3g} s or ω_max·dt > 0.6 (ω_max = {w_max:.3g} rad/s); use dt <= "
            f"{min(t_roll / 40, 0.6 / w_max):.3g} s.",
            stacklevel=3,
        )


def make_problem(
    ship: Ship,
    sea: AbstractWaveSpectrum,
    *,
    speed: float = 0.0,
    heading: str = "head",
    method: str = "filter",
    dt: float = 0.5,
    filter_order: int = 4,
    phi0_deg: float = 5.0,
    dphi0_deg_s: float = 0.0,
) -> tuple[RollProblem, FilterFit | None]:
    """Assemble a `RollProblem`: Grim's effective wave of `sea` for `ship`, excitation by `method`, initial roll.

    **Arguments:** `ship`; `sea`: one-sided sea spectrum; `speed` [m/s]; `heading`: "head" | "following";
    `method`: "filter" (Method 2, the paper's for Monte Carlo) or "superposition" (Method 1); `dt`: time step
    [s]; `filter_order` (Method 2); `phi0_deg` [deg], `dphi0_deg_s` [deg/s]: initial condition.

    **Returns:** `(problem, filter_fit)` (`filter_fit` is None for superposition).
    """
    if method not in ("filter", "superposition"):
        raise ValueError(f"`method` must be 'filter' or 'superposition'; got {method!r}.")
    for name, value in (("phi0_deg", phi0_deg), ("dphi0_deg_s", dphi0_deg_s)):
        if not math.isfinite(value):
            raise ValueError(f"`{name}` must be finite; got {value!r}.")
    wave = EffectiveWave(sea, ship.lpp, speed, heading)
    check_time_step(dt, ship, wave)
    if method == "filter":
        fit = fit_filter(wave, order=filter_order, match_frequency=2 * ship.omega0)
        excitation = FilterExcitation(fit.filter, dt)
    else:
        fit = None
        excitation = SuperpositionExcitation(wave, dt)
    problem = RollProblem(ship, excitation, jnp.deg2rad(phi0_deg), jnp.deg2rad(dphi0_deg_s))
    if abs(phi0_deg) >= float(jnp.rad2deg(problem.capsize_angle)):
        raise ValueError(
            f"`phi0_deg` = {phi0_deg} is beyond the angle of vanishing stability "
            f"({float(jnp.rad2deg(problem.capsize_angle)):.1f}°)."
        )
    return problem, fit


# ----------------------------------------------------------------------------------------------------------------
# Amplitude statistics
# ----------------------------------------------------------------------------------------------------------------


class CapsizeCounts:
    """Capsize counts of a Monte Carlo result with a per-realization boolean array `capsized`."""

    capsized: np.ndarray

    @property
    def n_realizations(self) -> int:
        return int(self.capsized.size)

    @property
    def n_capsized(self) -> int:
        return int(self.capsized.sum())

    @property
    def capsize_probability(self) -> float:
        """Fraction of realizations that capsized [-]."""
        return self.n_capsized / max(self.n_realizations, 1)


@dataclass
class AmplitudeStatistics(CapsizeCounts):
    """Reduced Monte Carlo statistics of roll amplitudes (host numpy arrays; angles in degrees).

    `counts_*` are histograms on the fine grid `edges_deg`; per-realization arrays are in realization order.
    Capsized realizations are excluded from every amplitude statistic and counted in `capsized`.
    """

    edges_deg: np.ndarray
    counts_zero_crossing: np.ndarray
    counts_envelope: np.ndarray
    capsized: np.ndarray
    capsize_time: np.ndarray
    per_realization: dict[str, np.ndarray] = field(default_factory=dict)
    config: dict = field(default_factory=dict)

    def n_amplitudes(self, method: str) -> int:
        return int(self._counts(method).sum())

    def _counts(self, method: str) -> np.ndarray:
        if method == "zero_crossing":
            return self.counts_zero_crossing
        if method == "envelope":
            return self.counts_envelope
        raise ValueError(f"`method` must be 'zero_crossing' or 'envelope'; got {method!r}.")

    def mean(self, method: str) -> float:
        """Mean amplitude [deg] (exact: from per-realization sums, not the histogram)."""
        key = "zc" if method == "zero_crossing" else "env"
        self._counts(method)
        n = self.per_realization[f"n_{key}"].sum()
        return float(np.rad2deg(self.per_realization[f"sum_{key}"].sum() / n)) if n else float("nan")

    def moment(self, method: str, order: int = 2) -> float:
        """E[Aⁿ] [rad^n] for n = 1, 2 (exact, from per-realization sums)."""
        key = "zc" if method == "zero_crossing" else "env"
        n = self.per_realization[f"n_{key}"].sum()
        name = {1: "sum", 2: "sumsq"}[order]
        return float(self.per_realization[f"{name}_{key}"].sum() / n) if n else float("nan")

    def quantiles(self, method: str, levels=QUANTILE_LEVELS) -> np.ndarray:
        """Quantiles [deg] of the amplitude (linear within the fine bins, ±half a fine bin)."""
        counts = self._counts(method)
        cdf = np.concatenate([[0.0], np.cumsum(counts)]) / max(counts.sum(), 1)
        return np.interp(np.asarray(levels, dtype=float), cdf, self.edges_deg)

    def pdf(self, method: str, bins_deg: np.ndarray) -> np.ndarray:
        """Density per degree on `bins_deg` (edges that are a subset of the fine edges), integrating to 1."""
        counts = self._counts(method)
        cum = np.concatenate([[0.0], np.cumsum(counts)])
        idx = np.searchsorted(self.edges_deg, bins_deg - 1e-9 * (self.edges_deg[1] - self.edges_deg[0]))
        if not np.allclose(self.edges_deg[np.clip(idx, 0, self.edges_deg.size - 1)], bins_deg, atol=1e-9):
            raise ValueError("`bins_deg` must be edges of the fine histogram grid (multiples of its width).")
        binned = np.diff(cum[idx])
        total = counts.sum()
        return binned / max(total, 1) / np.diff(bins_deg)

    def summary(self, bins_deg) -> dict:
        """The amplitude statistics as plain numbers on `bins_deg` (the `pdf.json` fields; angles in degrees)."""
        bins_deg = np.asarray(bins_deg, dtype=float)
        out: dict = {"bins_deg": bins_deg}
        for method in ("zero_crossing", "envelope"):
            out[f"pdf_{method}"] = self.pdf(method, bins_deg)
        labels = {"zero_crossing": "per half cycle", "envelope": "per time sample"}
        out["amplitude_sampling"] = labels
        out["n_amplitudes"] = {m: self.n_amplitudes(m) for m in labels}
        out["mean_amplitude_deg"] = {m: self.mean(m) for m in labels}
        out["quantiles_deg"] = {
            m: {f"{int(q * 100)}": float(v) for q, v in zip(QUANTILE_LEVELS, self.quantiles(m), strict=True)}
            for m in labels
        }
        out["n_realizations"] = self.n_realizations
        out["n_capsized"] = self.n_capsized
        out["capsize_probability"] = self.capsize_probability
        out["roll_moments"] = self.phi_moments()
        return out

    def distribution(self, method: str = "zero_crossing", *, pool: int = 1):
        """The amplitude law as a `jaxroll.AmplitudeDistribution` (radians): the histogram PDF on bin centres.

        `pool` merges that many fine bins (0.05° each; e.g. 20 → 1° bins): the maximum-value formulas amplify
        histogram noise. Zero-crossing amplitudes give the per-cycle law the maxima and risk formulas need.
        """
        from ..extremes._maxima import AmplitudeDistribution

        counts = self._counts(method)
        if counts.size % pool:
            raise ValueError(f"`pool` must divide the {counts.size} fine bins; got {pool}.")
        counts = counts.reshape(-1, pool).sum(1)
        edges = np.deg2rad(self.edges_deg[::pool])
        pdf = counts / max(counts.sum(), 1) / np.diff(edges)
        return AmplitudeDistribution.from_pdf((edges[1:] + edges[:-1]) / 2, pdf)

    def phi_moments(self) -> dict[str, float]:
        """Time-sampled E[φ²] [rad²] and E[φ⁴] [rad⁴] over surviving realizations (after the discard)."""
        pr = self.per_realization
        n = pr["n_samples"].sum()
        if n == 0:
            return {"E_phi2": float("nan"), "E_phi4": float("nan")}
        return {"E_phi2": float(pr["sum_phi2"].sum() / n), "E_phi4": float(pr["sum_phi4"].sum() / n)}


def _chunk_statistics(problem, key, indices, valid, num_steps, discard_steps, width, nbins):
    """Amplitude statistics of one chunk: (summed histograms, per-realization arrays)."""

    def one(i):
        def observe(zc, k, y, alive):
            zc, amp = zero_crossing_update(zc, y[0])
            return zc, (y[0], amp)

        _, (phi, amp), end = simulate(
            problem, jr.fold_in(key, i), num_steps, observe, zero_crossing_init(problem.phi0)
        )
        return phi, amp, end

    phi, amp, end = jax.vmap(one)(indices)
    keep = valid & ~end.capsized
    phi = phi[:, discard_steps:]
    amp = amp[:, discard_steps:]
    zc_w = ((amp > 0) & keep[:, None]).astype(float)
    env = hilbert_envelope(phi)
    env_w = jnp.broadcast_to(keep[:, None], env.shape).astype(float)
    deg = 180 / jnp.pi
    summed = {
        "counts_zero_crossing": histogram_counts(amp * deg, zc_w, width, nbins),
        "counts_envelope": histogram_counts(env * deg, env_w, width, nbins),
    }
    kf = keep.astype(float)
    per = {
        "capsized": end.capsized & valid,
        "capsize_time": end.capsize_time,
        "n_zc": jnp.sum(zc_w, 1),
        "sum_zc": jnp.sum(zc_w * amp, 1),
        "sumsq_zc": jnp.sum(zc_w * amp**2, 1),
        "n_env": jnp.sum(env_w, 1),
        "sum_env": jnp.sum(env_w * env, 1),
        "sumsq_env": jnp.sum(env_w * env**2, 1),
        "n_samples": kf * phi.shape[1],
        "sum_phi2": kf * jnp.sum(phi**2, 1),
        "sum_phi4": kf * jnp.sum(phi**4, 1),
    }
    return summed, per


REALIZATION_AXIS = "realizations"
CHECKPOINT_FILE = "checkpoint.npz"
CHECKPOINT_SECONDS = 60.0  # default checkpoint interval [s] of wall time when `checkpoint_every` is None


def realization_mesh(devices=None) -> jax.sharding.Mesh:
    """The 1-D device mesh (axis `"realizations"`) a Monte Carlo is sharded over.

    **Arguments:** `devices`: None (every device of every process, `jax.devices()`), an int n (the first n of
    them), or a sequence of devices.
    """
    all_devices = jax.devices()
    if devices is None:
        chosen = all_devices
    elif isinstance(devices, int) and not isinstance(devices, bool):
        if not 1 <= devices <= len(all_devices):
            raise ValueError(
                f"`devices` = {devices} must be between 1 and the number of devices, {len(all_devices)} "
                f"({all_devices[0].platform})."
            )
        chosen = all_devices[:devices]
    else:
        chosen = list(devices)
        if not chosen or len(set(chosen)) != len(chosen) or any(d not in all_devices for d in chosen):
            raise ValueError(f"`devices` must be distinct devices from jax.devices(); got {devices!r}.")
    return jax.sharding.Mesh(np.array(chosen), (REALIZATION_AXIS,))


def _global_array(host: np.ndarray, sharding) -> jax.Array:
    """A global array with `sharding` from a host array every process holds in full (works multi-process)."""
    return jax.make_array_from_callback(host.shape, sharding, lambda index: host[index])


def _replicate(tree, mesh):
    """Place the array leaves of `tree` on every device of `mesh` (PRNG keys are left to jit, which copies
    them)."""
    sharding = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec())

    def put(x):
        if not isinstance(x, jax.Array) or jnp.issubdtype(x.dtype, jax.dtypes.prng_key):
            return x
        if jax.process_count() == 1:
            return jax.device_put(x, sharding)
        return _global_array(np.asarray(x), sharding)

    return jax.tree_util.tree_map(put, tree)


def _to_host(tree):
    """Host numpy copies of (possibly sharded, possibly multi-process) global arrays."""
    if jax.process_count() > 1:
        from jax.experimental import multihost_utils

        return multihost_utils.process_allgather(tree, tiled=True)
    return jax.tree_util.tree_map(np.asarray, tree)


def _run_fingerprint(chunk_fn, problem, key, num_realizations, chunk_size, static) -> dict[str, str]:
    """What identifies a run, item by item (hashes for the arrays), so a mismatch can say what differs."""
    from .. import __version__

    def digest(leaves) -> str:
        h = hashlib.sha256()
        for leaf in leaves:
            arr = np.asarray(leaf)
            h.update(f"{arr.dtype.str}{arr.shape}".encode())
            h.update(np.ascontiguousarray(arr).tobytes())
        return h.hexdigest()[:16]

    leaves, treedef = jax.tree_util.tree_flatten(problem)
    if isinstance(key, jax.Array) and jnp.issubdtype(key.dtype, jax.dtypes.prng_key):
        key_bytes = [jr.key_data(key), np.frombuffer(str(jr.key_impl(key)).encode(), np.uint8)]
    else:
        key_bytes = [key]
    structure = re.sub(r"0x[0-9a-f]+", "", str(treedef))  # static fields (dt, names); no memory addresses
    name = getattr(chunk_fn, "__qualname__", repr(chunk_fn))
    return {
        "chunk_fn": f"{getattr(chunk_fn, '__module__', '?')}.{name}",
        "problem": digest(leaves) + ":" + hashlib.sha256(structure.encode()).hexdigest()[:8],
        "key": digest(key_bytes),
        "num_realizations": str(num_realizations),
        "chunk_size": str(chunk_size),
        "static": repr(static),
        "jaxroll_version": __version__,
    }


_FINGERPRINT_MEANING = {
    "chunk_fn": "the kind of Monte Carlo",
    "problem": "the problem (ship, sea state, speed/heading, excitation, dt, initial roll)",
    "key": "the random key (seed)",
    "num_realizations": "the number of realizations",
    "chunk_size": "the chunk size",
    "static": "the run settings (duration, discard, histogram grid, ...)",
    "jaxroll_version": "the jaxroll version",
}


def _load_checkpoint(path: Path, fingerprint: dict[str, str]):
    """`(next_start, summed, per)` from a checkpoint of this very run; ValueError if unreadable or foreign."""
    advice = f"Delete {path.parent} (or the file) to start afresh, or pass another checkpoint directory."
    try:
        with open(path, "rb") as f, np.load(f, allow_pickle=False) as data:
            contents = {name: data[name] for name in data.files}
        stored = json.loads(str(contents.pop("fingerprint")))
        next_start = int(contents.pop("next_start"))
        lengths = {v.shape[0] for k, v in contents.items() if k.startswith("per/")}
        if not (0 < next_start <= int(stored["num_realizations"])) or lengths - {next_start}:
            raise ValueError(f"inconsistent contents (next start {next_start}, arrays of lengths {lengths})")
    except Exception as e:  # zipfile.BadZipFile, EOFError, OSError, KeyError, ValueError, ...
        raise ValueError(
            f"checkpoint {path} is unreadable (truncated or corrupted: {type(e).__name__}: {e}). {advice}"
        ) from e
    differ = [k for k in fingerprint if stored.get(k) != fingerprint[k]]
    if differ:
        detail = "; ".join(
            f"{_FINGERPRINT_MEANING[k]} ({k}: {stored.get(k)!r} there, {fingerprint[k]!r} now)"
            for k in differ
        )
        raise ValueError(f"checkpoint {path} belongs to a different run: {detail}. {advice}")
    summed = {k[len("summed/") :]: v for k, v in contents.items() if k.startswith("summed/")}
    per = {k[len("per/") :]: v for k, v in contents.items() if k.startswith("per/")}
    return next_start, summed, per


def _save_checkpoint(path: Path, fingerprint: dict, next_start: int, summed: dict, per: dict) -> None:
    """Write the accumulated state atomically (temporary file in the same folder, fsync, then os.replace)."""
    arrays = {"fingerprint": np.array(json.dumps(fingerprint)), "next_start": np.array(next_start)}
    arrays.update({f"summed/{k}": v for k, v in summed.items()})
    arrays.update({f"per/{k}": v[:next_start] for k, v in per.items()})
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(buf.getvalue())
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def run_chunks(
    chunk_fn,
    problem,
    key,
    num_realizations: int,
    chunk_size: int,
    static: tuple,
    progress=None,
    *,
    devices=None,
    checkpoint: str | os.PathLike | None = None,
    checkpoint_every: int | None = None,
):
    """Run `chunk_fn(problem, key, indices, valid, *static) -> (summed, per_realization)` over all
    realizations.

    `summed` (dict of arrays reduced over the chunk's realization axis) is added over chunks;
    `per_realization` (dict of arrays with a leading chunk axis) is placed at the realizations' indices. The
    last chunk is padded with invalid realizations (`valid` False) so that every chunk has the same shape and
    compiles once.

    The realization axis of every chunk is sharded over a 1-D mesh of devices (axis `"realizations"`), across
    processes too after `jax.distributed.initialize()`: the chunk is rounded up to a multiple of the device
    count, `summed` is reduced across devices by XLA inside the compiled chunk, and `per_realization` is
    gathered to every process. Realization i uses `fold_in(key, i)` whatever the device, so results do not
    depend on the number of devices, processes or chunks: bit for bit when every device gets the same number
    of realizations per chunk, otherwise to round-off (XLA on CPU compiles a batch-size-dependent matrix
    product, ~1e-15 in φ). `summed` entries should be integer-valued (counts), which any reduction order adds
    exactly; float sums belong in `per_realization` (added on the host in index order).

    **Arguments:**

    - `chunk_fn`: the chunk function (jitted once per mesh; `static` entries must be hashable Python values).
    - `problem`, `key`: passed to every chunk (replicated on every device).
    - `num_realizations`, `chunk_size`: realizations in all, and per compiled chunk (memory bound).
    - `progress`: called with the number of realizations done after each chunk.
    - `devices`: None (all devices, `jax.devices()`), an int n (the first n), or a sequence of devices.
    - `checkpoint`: a directory; the accumulated state is saved there (`checkpoint.npz`, atomically) with a
      fingerprint of the run, and a rerun with the same directory resumes where it stopped and gives exactly
      the result of an uninterrupted run. A finished run leaves its final state, so a rerun returns at once.
    - `checkpoint_every`: save every this many chunks; None (default) saves when `CHECKPOINT_SECONDS` (60 s)
      of wall time have passed since the last save, and always after the last chunk.

    **Returns:** `(summed, per_realization)` as host numpy arrays (the same on every process).

    **Raises:** `ValueError` when the checkpoint is unreadable or belongs to a different run (the message says
    what differs and how to proceed).
    """
    if checkpoint_every is not None and not (isinstance(checkpoint_every, int) and checkpoint_every >= 1):
        raise ValueError(f"`checkpoint_every` must be None or an integer >= 1; got {checkpoint_every!r}.")
    mesh = realization_mesh(devices)
    num_devices = mesh.devices.size
    chunk = -(-min(chunk_size, num_realizations) // num_devices) * num_devices
    sharding = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec(REALIZATION_AXIS))
    fn = _compiled(chunk_fn, mesh)

    summed: dict[str, np.ndarray] = {}
    per: dict[str, np.ndarray] = {}
    start = 0
    path = fingerprint = None
    if checkpoint is not None:
        path = Path(checkpoint) / CHECKPOINT_FILE
        fingerprint = _run_fingerprint(chunk_fn, problem, key, num_realizations, chunk_size, static)
        if path.exists():
            start, summed, saved_per = _load_checkpoint(path, fingerprint)
            for k, v in saved_per.items():
                per[k] = np.zeros((num_realizations, *v.shape[1:]), v.dtype)
                per[k][:start] = v
        if jax.process_count() > 1:
            from jax.experimental import multihost_utils

            multihost_utils.assert_equal(
                np.array(start),
                "processes read different checkpoints: put the "
                "checkpoint directory on a file system every process shares.",
            )
    problem = _replicate(problem, mesh)
    last_save, chunks_since_save = time.monotonic(), 0
    while start < num_realizations:
        idx = np.arange(start, start + chunk)
        valid = idx < num_realizations
        s, p = fn(problem, key, _global_array(idx, sharding), _global_array(valid, sharding), *static)
        s, p = _to_host((s, p))
        n = int(valid.sum())
        for k, v in s.items():
            summed[k] = summed.get(k, 0) + v
        for k, v in p.items():
            if k not in per:
                per[k] = np.zeros((num_realizations, *v.shape[1:]), v.dtype)
            per[k][start : start + n] = v[:n]
        start += n
        chunks_since_save += 1
        if path is not None:
            due = (
                chunks_since_save >= checkpoint_every
                if checkpoint_every is not None
                else time.monotonic() - last_save >= CHECKPOINT_SECONDS
            )
            if due or start >= num_realizations:
                if jax.process_index() == 0:
                    _save_checkpoint(path, fingerprint, start, summed, per)
                last_save, chunks_since_save = time.monotonic(), 0
        if progress is not None:
            progress(start)
    return summed, per


_COMPILED: dict = {}


def _compiled(fn, mesh: jax.sharding.Mesh | None = None):
    """`fn` under `eqx.filter_jit`, with its outputs' shardings fixed on `mesh` (summed replicated,
    per-realization sharded along the realization axis), cached per (function, mesh)."""
    if (fn, mesh) not in _COMPILED:
        if mesh is None:
            _COMPILED[fn, mesh] = eqx.filter_jit(fn)
        else:
            replicated = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec())
            along = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec(REALIZATION_AXIS))

            def sharded(problem, key, indices, valid, *static):
                summed, per = fn(problem, key, indices, valid, *static)
                summed = jax.lax.with_sharding_constraint(summed, replicated)
                per = jax.lax.with_sharding_constraint(per, along)
                return summed, per

            sharded.__name__ = sharded.__qualname__ = getattr(fn, "__name__", "chunk_fn")
            _COMPILED[fn, mesh] = eqx.filter_jit(sharded)
    return _COMPILED[fn, mesh]


def monte_carlo_amplitudes(
    problem: RollProblem,
    key,
    *,
    num_realizations: int = 10_000,
    duration: float = 3600.0,
    discard: float = 0.0,
    chunk_size: int = 1000,
    bin_width_deg: float = 0.05,
    max_deg: float = 90.0,
    progress: Callable[[int], None] | None = None,
    devices=None,
    checkpoint: str | os.PathLike | None = None,
    checkpoint_every: int | None = None,
) -> AmplitudeStatistics:
    """Monte Carlo amplitude statistics of `problem` (the paper's MCS protocol by default).

    **Arguments:**

    - `problem`: from `make_problem`.
    - `key`: a JAX PRNG key (`jax.random.key(seed)`); realization i uses `fold_in(key, i)`.
    - `num_realizations`: trials (10⁴); `duration`: simulated time per trial [s] (3600).
    - `discard`: initial transient excluded from the statistics [s] (0).
    - `chunk_size`: realizations per compiled batch (bounds the memory: ~chunk·duration/dt·24 bytes).
    - `bin_width_deg`, `max_deg`: the fine histogram grid [deg] behind every PDF and quantile.
    - `progress`: called with the number of realizations done after each chunk.
    - `devices`, `checkpoint`, `checkpoint_every`: sharding over devices and interruptible runs, as in
      `run_chunks` (results are identical whatever the devices, the chunking or the interruptions).

    **Returns:** `AmplitudeStatistics` (zero-crossing amplitudes per half cycle, envelope amplitudes per sample).
    """
    for name, value in (("num_realizations", num_realizations), ("chunk_size", chunk_size)):
        if not (isinstance(value, int) and value > 0):
            raise ValueError(f"`{name}` must be a positive integer; got {value!r}.")
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"`duration` must be > 0 [s]; got {duration!r}.")
    if not (0 <= discard < duration):
        raise ValueError(f"`discard` must be in [0, duration) = [0, {duration}) s; got {discard!r}.")
    dt = problem.dt
    num_steps = int(round(duration / dt))
    discard_steps = int(round(discard / dt))
    if num_steps - discard_steps < 16:
        raise ValueError(f"duration − discard = {duration - discard} s leaves fewer than 16 time steps of {dt} s.")
    nbins = int(round(max_deg / bin_width_deg))
    summed, per = run_chunks(
        _chunk_statistics,
        problem,
        key,
        num_realizations,
        chunk_size,
        (num_steps, discard_steps, bin_width_deg, nbins),
        progress,
        devices=devices,
        checkpoint=checkpoint,
        checkpoint_every=checkpoint_every,
    )
    capsized = per.pop("capsized")
    capsize_time = per.pop("capsize_time")
    return AmplitudeStatistics(
        edges_deg=np.arange(nbins + 1) * bin_width_deg,
        counts_zero_crossing=summed["counts_zero_crossing"],
        counts_envelope=summed["counts_envelope"],
        capsized=capsized,
        capsize_time=capsize_time,
        per_realization=per,
        config={"num_realizations": num_realizations, "duration_s": duration, "discard_s": discard, "dt_s": dt},
    )
