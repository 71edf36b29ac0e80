"""The device side of multilevel splitting (`monte_carlo_splitting`, docs/rare_events.md): one stage's runs as one
compiled program — a pool of lanes (realizations in flight), vmapped and sharded over the devices, that simulates
`SEGMENT` source steps at a time and hands every lane whose run ended (its target reached, or the end of the
exposure) the next clone of the stage's queue, longest remaining time first — and `_RollStages`, which runs the
stages of one roll problem for the host-side estimator (`_splitting.py`).

A clone's entrance is its Markov state (φ, φ̇, filter state z, ζ_G, time step k, alive) with what its last source
step saw: `score` (the score â + κ·ê there, −∞ before the discard) and `reach` (its largest |φ| after the discard),
from which any stage's target is evaluated — the score level, or the event |φ| > angle or a capsize for the
stage's angle — so one run passes the events of several angles on its way up.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np
import scipy.linalg
from jaxtyping import Array

from ..ship._restoring import parametric_excitation, restoring_moment, restoring_potential
from ._equation import RollProblem, as_dtype, computed_once, rk4_step, runtime_one
from ._excitation import BLOCK, block_normals_by_column
from ._sharding import (
    REALIZATION_AXIS,
    _compiled,
    _global_array,
    _replicate,
    _to_host,
    default_chunk_size,
    realization_mesh,
)

#: Source steps simulated between two refills of the lanes (divides `BLOCK`): a lane whose run ended waits at most
#: this long for its next clone (16 source steps = 32 s at dt 0.5 s, m 4).
SEGMENT = 16
#: The fewest lanes a pool has (idle ones where a stage has fewer runs a device): XLA:CPU compiled the pool of 8 or
#: 16 lanes (under `import jaxroll`'s small-loop threshold) into a program whose memory grew past 6 GB.
MIN_LANES = 32
#: With `lanes=None`, a pool has about a quarter of a device's runs of the stage (at most `default_chunk_size`'s
#: per device): N = 1000 at H1/3 4.5 m, 1 h, on 2 CPU cores ran its stages in 2.1 s with 125 lanes a device, 3.6 s
#: with 500 (one wave: lanes idle once their run ended), 2.35 s with 250 and 2.1 s with 64.
WAVES = 4

#: A clone's entrance: its Markov state, the score and the reach of its last source step (module docstring).
_FIELDS = ("phi", "dphi", "z", "x", "k", "alive", "score", "reach")


# ----------------------------------------------------------------------------------------------------------------
# One stage: a pool of lanes over a queue of clones (one compiled program per problem structure and queue shape)
# ----------------------------------------------------------------------------------------------------------------


class Importance(eqx.Module):
    """The importance function's constants: h = â(E) + κ·ê [deg] at a source step's end, â the energy amplitude of
    the step's largest roll energy E (`energy_amplitude`) and ê the wave envelope there in standard deviations,
    √(ζ_G² + (ζ̇_G/ω_r)²)/σ_G, ζ̇_G = (Aᵀc)·z, ω_r = 2ω0 (the parametric resonance's encounter frequency). Arrays
    only (traced: one program for every sea and level)."""

    vanishing: Array
    c_a: Array
    omega_ref: Array
    sigma: Array
    kappa: Array


def energy_amplitude(ship, energy, vanishing):
    """The energy amplitude â [rad]: V(â) = `energy` [rad²/s²] (V the calm-water restoring energy, increasing up to
    the vanishing angle `vanishing` [rad], where â is clipped), by three Newton steps from √(2E/a1): within 3e-6°
    of the root up to 60° for the default ship, within 1° near the vanishing angle. 0 for E ≤ 0."""
    e = jnp.maximum(energy, 0)
    a1 = ship.restoring_coefficients[0]
    a = jnp.minimum(jnp.sqrt(2 * e / a1), vanishing)
    for _ in range(3):
        slope = jnp.maximum(restoring_moment(ship, a), 1e-6 * a1)
        a = jnp.clip(a + (e - restoring_potential(ship, a)) / slope, 0, vanishing)
    return a


def _stage_target(alive, reach, score, level, angle, final):
    """A stage's target at a source step: `(top, reached)`. The step has the event of the stage's `angle` [rad]
    where the run capsized (not `alive`) or its largest |φ| after the discard (`reach`) exceeds the angle; `top` is
    then +∞ (the event outranks every level), else the step's `score` [deg]; `reached` is the event where the
    stage's target is the event (`final`), else `top` ≥ `level` [deg]."""
    hit = ~alive | (reach > angle)
    top = jnp.where(hit, jnp.asarray(jnp.inf, score.dtype), score)
    return top, jnp.where(final, hit, top >= level)


def _lane_segment(
    problem: RollProblem,
    importance: Importance,
    level,
    angle,
    final,
    lane,
    *,
    num_steps,
    discard_steps,
    segment,
    dtype,
):
    """`segment` source steps of one lane (vmapped over the pool). A lane runs while `run` holds; it stops at the
    end of the source step where it reached the stage's target (`_stage_target`) or at the end of the exposure,
    and is then frozen. The arithmetic per source step is `simulate`'s, and a lane's noise is row `r` on of its
    key's stream, so stage 0 of a one-stage run is `monte_carlo_max_roll`'s trials, and a run continued from where
    it stopped with its own key and the next row is the trial that did not stop."""
    ship, exc, h = problem.ship, problem.excitation, problem.dt
    m, n = exc.substeps, exc.noise_rank
    r = lane["r"]
    eps = block_normals_by_column(jr.wrap_key_data(lane["key"]), r // BLOCK, n, r % BLOCK, segment)
    eps = tuple(e.astype(dtype) for e in eps)
    inf = jnp.asarray(jnp.inf, dtype)

    def step(c, e):
        phi, dphi, z, x, k, alive = c["phi"], c["dphi"], c["z"], c["x"], c["k"], c["alive"]
        z1, values = exc.advance(z, e, m)
        one = runtime_one(phi)
        p = [computed_once(parametric_excitation(ship, v), one) for v in (x, *values)]
        mw = [0.0] * len(p)
        energy, reach, counted_any = -inf, jnp.zeros((), dtype), jnp.array(False)
        for s in range(m):
            phi1, dphi1 = rk4_step(ship, (phi, dphi), p[2 * s : 2 * s + 3], mw[2 * s : 2 * s + 3], h, one)
            ok = jnp.isfinite(phi1) & jnp.isfinite(dphi1) & (jnp.abs(phi1) < problem.capsize_angle)
            inside = k < num_steps
            alive = alive & ~(alive & ~ok & inside)
            phi, dphi = jnp.where(alive, phi1, phi), jnp.where(alive, dphi1, dphi)
            k = k + 1
            counted = inside & (k > discard_steps)  # MaxRoll's steps: after the discard, within the duration
            e_roll = dphi * dphi / 2 + restoring_potential(ship, phi)
            energy = jnp.where(counted, jnp.maximum(energy, e_roll), energy)
            reach = jnp.where(counted, jnp.maximum(reach, jnp.abs(phi)), reach)
            counted_any = counted_any | counted
        zeta, dzeta = values[-1], sum(importance.c_a[i] * z1[i] for i in range(n))
        envelope = jnp.sqrt(zeta * zeta + (dzeta / importance.omega_ref) ** 2) / importance.sigma
        amplitude = energy_amplitude(ship, energy, importance.vanishing)
        score = jnp.where(counted_any, amplitude * (180 / math.pi) + importance.kappa * envelope, -inf)
        top, done = _stage_target(alive, reach, score, level, angle, final)
        new = {
            "phi": phi,
            "dphi": dphi,
            "z": z1,
            "x": values[-1],
            "k": k,
            "alive": alive,
            "score": score,
            "reach": reach,
            "peak": jnp.maximum(c["peak"], top),
            "success": done,
            "run": ~done & (k < num_steps),
        }
        return jax.tree.map(lambda a, b: jnp.where(c["run"], a, b), new, c), None

    state = {key: lane[key] for key in (*_FIELDS, "peak", "success", "run")}
    state, _ = jax.lax.scan(step, state, eps)
    return {**lane, **state, "r": r + segment}


def _stage_chunk(args, key, queue, valid, num_steps, discard_steps, lanes, segment, dtype):
    """Run every clone of `queue` (this device's share) through the stage with a pool of `lanes` lanes.

    `args` = (problem, `Importance`, level [deg], angle [rad], final: whether the stage's target is the event of
    the angle); `key`: the stage's key (clone j of the queue draws its noise from fold_in(key, queue["index"][j]),
    from row queue["r"][j] of that stream on). **Returns:** `(summed, per_clone)`: summed = the lane-steps the pool
    ran (idle lanes included); per clone its end (the entrance state of the next stage where it succeeded),
    `success`, and `peak`, the largest top (`_stage_target`) over its run."""
    problem, importance, level, angle, final = as_dtype(args, dtype)
    size = queue["k"].shape[0]
    n = problem.excitation.c.size
    segment_fn = jax.vmap(
        lambda lane: _lane_segment(
            problem,
            importance,
            level,
            angle,
            final,
            lane,
            num_steps=num_steps,
            discard_steps=discard_steps,
            segment=segment,
            dtype=dtype,
        )
    )

    def clone_key(i):
        return jr.key_data(jr.fold_in(key, i))

    def empty_lanes():
        zero = jnp.zeros((lanes,), dtype)
        return {
            "phi": zero,
            "dphi": zero,
            "z": tuple(zero for _ in range(n)),
            "x": zero,
            "k": jnp.zeros((lanes,), jnp.int32),
            "alive": jnp.ones((lanes,), bool),
            "score": zero,
            "reach": zero,
            "peak": zero,
            "success": jnp.zeros((lanes,), bool),
            "run": jnp.zeros((lanes,), bool),
            "r": jnp.zeros((lanes,), jnp.int32),
            "key": jnp.zeros((lanes, 2), jnp.uint32),
            "id": jnp.full((lanes,), -1, jnp.int32),
        }

    def empty_outputs():
        zero = jnp.zeros((size,), dtype)
        return {
            "phi": zero,
            "dphi": zero,
            "z": jnp.zeros((size, n), dtype),
            "x": zero,
            "k": jnp.zeros((size,), jnp.int32),
            "alive": jnp.ones((size,), bool),
            "score": zero,
            "reach": zero,
            "peak": zero,
            "success": jnp.zeros((size,), bool),
        }

    def retire(lane, out):
        """Write the lanes whose run ended (id ≥ 0, not running) at their clones' places; empty them."""
        ended = (lane["id"] >= 0) & ~lane["run"]
        where = jnp.where(ended, lane["id"], size)  # out of range: dropped
        values = {key: lane[key] for key in out if key != "z"}
        out = {
            key: out[key].at[where].set(values[key], mode="drop") if key != "z" else out[key] for key in out
        }
        out["z"] = out["z"].at[where].set(jnp.stack(lane["z"], -1), mode="drop")
        return {**lane, "id": jnp.where(ended, -1, lane["id"])}, out

    def refill(lane, following):
        """Hand the empty lanes the next clones of the queue."""
        empty = lane["id"] < 0
        position = following + jnp.cumsum(empty.astype(jnp.int32)) - 1
        take = empty & (position < size)
        at = jnp.clip(position, 0, size - 1)
        q = jax.tree.map(lambda a: a[at], queue)
        ok = valid[at]
        # the entrance step, evaluated for this stage's target, may already reach it
        top, immediate = _stage_target(q["alive"], q["reach"], q["score"], level, angle, final)
        z = tuple(q["z"][:, i] for i in range(n))
        loaded = {
            "phi": q["phi"],
            "dphi": q["dphi"],
            "z": z,
            "x": q["x"],
            "k": q["k"],
            "alive": q["alive"],
            "score": q["score"],
            "reach": q["reach"],
            "peak": top,
            "success": ok & immediate,
            "run": ok & ~immediate & (q["k"] < num_steps),
            "r": q["r"],
            "key": jax.vmap(clone_key)(q["index"]),
            "id": position.astype(jnp.int32),
        }
        lane = jax.tree.map(
            lambda new, old: jnp.where(take.reshape(-1, *([1] * (old.ndim - 1))), new, old), loaded, lane
        )
        return lane, jnp.minimum(following + jnp.sum(empty, dtype=jnp.int32), size)

    def body(carry):
        lane, following, out, segments = carry
        lane, out = retire(lane, out)
        lane, following = refill(lane, following)
        return segment_fn(lane), following, out, segments + 1

    def more(carry):
        lane, following, _, _ = carry
        return (following < size) | jnp.any(lane["run"])

    carry = (empty_lanes(), jnp.array(0, jnp.int32), empty_outputs(), jnp.array(0, jnp.int64))
    lane, _, out, segments = jax.lax.while_loop(more, body, carry)
    _, out = retire(lane, out)
    m = problem.excitation.substeps
    return {"lane_steps": segments * (lanes * segment * m)}, out


# ----------------------------------------------------------------------------------------------------------------
# The stages of one roll problem, for the host-side estimator
# ----------------------------------------------------------------------------------------------------------------


class _RollStages:
    """Runs the stages of one roll problem: the initial states and one compiled program per stage shape.
    `angle_rad`: the angle of the stages run without one; `capsize_angle` [rad]: the angle whose event is a capsize
    alone (`continuation`)."""

    def __init__(
        self, problem, angle_rad, num_steps, discard_steps, lanes, devices, dtype, wave_weight=0.0, capacity=0
    ):
        self.problem, self.angle, self.dtype, self.capacity = problem, angle_rad, dtype, capacity
        # |φ| stays below the capsize angle while alive (the step that reaches it is not taken): its event is ~alive
        self.capsize_angle = float(problem.capsize_angle)
        self.importance = importance_tables(problem, wave_weight)
        self.num_steps, self.discard_steps = num_steps, discard_steps
        self.mesh = realization_mesh(devices)
        self.devices = self.mesh.devices.size
        self.lanes = lanes
        self.lane_cap = default_chunk_size(False, devices) // self.devices
        self.fn = _compiled(_stage_chunk, self.mesh)
        self.placed = None
        self.sharding = jax.sharding.NamedSharding(self.mesh, jax.sharding.PartitionSpec(REALIZATION_AXIS))

    def initial(self, key, num) -> dict:
        """Stage 0's queue: trial i starts from (φ0, φ̇0) and the filter's stationary draw of fold_in(key, i)."""
        z, x = _initial_filter(as_dtype(self.problem, self.dtype), key, num)
        cast = self.dtype
        return {
            "phi": np.full(num, np.asarray(self.problem.phi0, cast)),
            "dphi": np.full(num, np.asarray(self.problem.dphi0, cast)),
            "z": np.asarray(z),
            "x": np.asarray(x),
            "k": np.zeros(num, np.int32),
            "alive": np.ones(num, bool),
            "score": np.full(num, -np.inf, cast),
            "reach": np.zeros(num, cast),
            "index": np.arange(num, dtype=np.int32),
            "r": np.zeros(num, np.int32),
        }

    def continuation(self, queue: dict, out: dict, chosen) -> dict:
        """The queue that continues the `chosen` clones of a stage run on `queue` (ending in `out`) from where they
        stopped, each with its own key and the next row of its noise: the runs as if they had not stopped."""
        m = self.problem.excitation.substeps
        used = (out["k"].astype(np.int64) - queue["k"]) // m  # a source step per noise row
        following = {f: out[f][chosen] for f in _FIELDS}
        following["index"] = queue["index"][chosen]
        following["r"] = (queue["r"] + used)[chosen].astype(np.int32)
        return following

    def run(
        self, key, queue: dict, level: float, final: bool, angle: float | None = None
    ) -> tuple[dict, int]:
        """One stage: every clone of `queue` until the level [deg] (`final`: the event of `angle` [rad], default
        the stages' angle) or the end of the exposure. **Returns:** `(per_clone, lane_steps)`, per clone in the
        queue's order."""
        num = queue["k"].size
        # Longest remaining time first (the pool's tail is then short), dealt round-robin to the devices; padded to
        # the run's capacity, so that the stages of the estimate (or of the pilot), intermediate or last, are one
        # program, and a device's share to a power of two, so that runs of other sizes (the cells of
        # `jaxroll.longterm`, Neyman-allocated) share programs too (a padded slot costs its lane one segment).
        order = np.argsort(queue["k"], kind="stable")
        per_device = _power_of_two(-(-max(num, self.capacity) // self.devices))
        if (
            self.lanes is None
        ):  # a few waves a device: lanes freed by runs that end early take the next clones
            lanes = max(MIN_LANES, min(self.lane_cap, per_device // WAVES))
        else:
            lanes = max(MIN_LANES, min(self.lanes, per_device))
        padded = per_device * self.devices
        slots = np.full(padded, -1)
        slots[:num] = order
        layout = slots.reshape(per_device, self.devices).T.reshape(-1)  # device d: sorted clones d, d + D, …
        valid = layout >= 0
        take = np.where(valid, layout, 0)
        placed = {k: _global_array(np.ascontiguousarray(v[take]), self.sharding) for k, v in queue.items()}
        if self.placed is None:
            self.placed = _replicate((self.problem, self.importance), self.mesh)
        angle = self.angle if angle is None else angle
        settings = (np.asarray(level, float), np.asarray(angle, float), np.asarray(final))
        args = (*self.placed, *_replicate(tuple(jnp.asarray(x) for x in settings), self.mesh))
        summed, out = self.fn(
            args,
            key,
            placed,
            _global_array(valid, self.sharding),
            self.num_steps,
            self.discard_steps,
            lanes,
            SEGMENT,
            self.dtype,
        )
        summed, out = _to_host((summed, out))
        back = np.empty(num, int)
        back[layout[valid]] = np.nonzero(valid)[0]
        return {k: v[back] for k, v in out.items()}, int(summed["lane_steps"])


def importance_tables(problem: RollProblem, wave_weight: float) -> Importance:
    """`Importance` of `problem` with κ = `wave_weight` [deg per standard deviation of the wave envelope]."""
    ship, exc = problem.ship, problem.excitation
    if problem.filter_fit is not None:
        a = np.asarray(problem.filter_fit.filter.a, float)
    else:  # A from the exact step Φ = exp(A m dt)
        a = np.real(scipy.linalg.logm(np.asarray(exc.phi, float))) / (exc.substeps * exc.dt)
    c = np.asarray(exc.c, float)
    chol = np.asarray(exc.stationary_chol, float)
    sigma = math.sqrt(float(c @ chol @ chol.T @ c))
    return Importance(
        jnp.asarray(float(problem.capsize_angle)),
        jnp.asarray(a.T @ c),
        jnp.asarray(2 * float(ship.omega0)),
        jnp.asarray(max(sigma, 1e-300)),
        jnp.asarray(float(wave_weight)),
    )


def _power_of_two(n: int) -> int:
    return 1 << max(0, int(n) - 1).bit_length()


def _initial_filter(problem: RollProblem, key, num: int):
    """The filter's stationary start of trials 0 … num − 1 (as `simulate` draws it) and ζ_G there (computed for a
    power of two of trials: one program for runs of several sizes)."""
    z, x = _initial_filter_program(problem, key, jnp.arange(_power_of_two(num), dtype=jnp.int32))
    return z[:num], x[:num]


@eqx.filter_jit
def _initial_filter_program(problem, key, indices):
    def one(i):
        z, x = problem.excitation.init(jr.fold_in(key, i), 1, problem.excitation.substeps, problem.phi0.dtype)
        return jnp.stack(z), x

    return jax.vmap(one)(indices)
