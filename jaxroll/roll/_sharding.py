"""Running a Monte Carlo in chunks: sharded over devices and hosts, checkpointed, identical whatever the layout.

Realization i always uses `fold_in(key, i)`; histogram counts are integers and per-realization arrays are placed
at their indices, so results do not depend on the chunk size, the device count or interruptions.
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import os
import re
import time
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.random as jr
import numpy as np

from .._atomic import NotRegularFile, atomic_write_bytes, read_regular
from .._compiled import MONTE_CARLO_PROGRAM, cached_program

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


def _spans_processes(mesh) -> bool:
    """Whether `mesh` holds devices of other processes (after `jax.distributed.initialize()`): then its arrays are
    global and its results are gathered across the processes. A mesh of this process's own devices
    (`devices=jax.local_devices()`) runs as in a single process, so that several processes can run different Monte
    Carlos at once (`jaxroll.longterm` shares its cells among the processes so)."""
    return jax.process_count() > 1 and any(d.process_index != jax.process_index() for d in mesh.devices.flat)


def _replicate(tree, mesh):
    """Place the array leaves of `tree` on every device of `mesh` (PRNG keys are left to jit, which copies
    them)."""
    sharding = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec())
    leaves, treedef = jax.tree.flatten(tree)
    moved = [
        i
        for i, x in enumerate(leaves)
        if isinstance(x, jax.Array) and not jnp.issubdtype(x.dtype, jax.dtypes.prng_key)
    ]
    if not _spans_processes(
        mesh
    ):  # one batched transfer (leaf by leaf: 7 ms for the paper's problem, every run)
        placed = jax.device_put([leaves[i] for i in moved], sharding)
    else:
        placed = [_global_array(np.asarray(leaves[i]), sharding) for i in moved]
    for i, x in zip(moved, placed, strict=True):
        leaves[i] = x
    return jax.tree.unflatten(treedef, leaves)


def _to_host(tree, mesh=None):
    """Host numpy copies of (possibly sharded, possibly multi-process) global arrays on `mesh` (None: all)."""
    if jax.process_count() > 1 and (mesh is None or _spans_processes(mesh)):
        from jax.experimental import multihost_utils

        return multihost_utils.process_allgather(tree, tiled=True)
    return jax.tree_util.tree_map(np.asarray, tree)


def _run_fingerprint(chunk_fn, problem, key, num_realizations, chunk_size, static) -> dict[str, str]:
    """What identifies a run, item by item (hashes for the arrays), so a mismatch can say what differs."""
    from .._version import __version__

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


def _content_digest(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 of a checkpoint's entries (names, dtypes, shapes and bytes, in name order)."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        arr = np.asarray(arrays[name])
        h.update(f"{name}\0{arr.dtype.str}\0{arr.shape}\0".encode())
        h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()


def _load_checkpoint(path: Path, fingerprint: dict[str, str], consistency=None):
    """`(next_start, summed, per)` from a checkpoint of this very run; ValueError if unreadable, edited, inconsistent
    or foreign. `consistency(summed, per) -> list[str]`: the observer's checks of its totals against its
    per-realization arrays (`AbstractObserver.consistency`)."""
    advice = f"Delete {path.parent} (or the file) to start afresh, or pass another checkpoint directory."
    try:
        raw = read_regular(path)  # a FIFO in its place would hang the run
    except NotRegularFile:
        raise ValueError(
            f"checkpoint {path} is not a regular file (a FIFO, a device or a folder). {advice}"
        ) from None
    try:
        with np.load(io.BytesIO(raw), allow_pickle=False) as data:
            contents = {name: data[name] for name in data.files}
        digest = str(contents.pop("digest")) if "digest" in contents else None
        stored = json.loads(str(contents["fingerprint"]))
        next_start = int(contents["next_start"])
        lengths = {v.shape[0] for k, v in contents.items() if k.startswith("per/")}
        if not (0 < next_start <= int(stored["num_realizations"])) or lengths - {next_start}:
            raise ValueError(f"inconsistent contents (next start {next_start}, arrays of lengths {lengths})")
    except Exception as e:  # zipfile.BadZipFile, EOFError, OSError, KeyError, ValueError, ...
        raise ValueError(
            f"checkpoint {path} is unreadable (truncated or corrupted: {type(e).__name__}: {e}). {advice}"
        ) from e
    if digest is None:
        raise ValueError(
            f"checkpoint {path} has no content digest: it was written by an older jaxroll, or not by "
            f"jaxroll. {advice}"
        )
    if digest != _content_digest(contents):
        raise ValueError(
            f"checkpoint {path} has been changed since jaxroll wrote it (its content digest does not match): a "
            f"checkpoint is never edited, and an edited one would put its numbers into the results. {advice}"
        )
    differ = [k for k in fingerprint if stored.get(k) != fingerprint[k]]
    if differ:
        detail = "; ".join(
            f"{_FINGERPRINT_MEANING[k]} ({k}: {stored.get(k)!r} there, {fingerprint[k]!r} now)"
            for k in differ
        )
        raise ValueError(f"checkpoint {path} belongs to a different run: {detail}. {advice}")
    summed = {k[len("summed/") :]: v for k, v in contents.items() if k.startswith("summed/")}
    per = {k[len("per/") :]: v for k, v in contents.items() if k.startswith("per/")}
    problems = [
        f"{k} holds {v.size - np.isfinite(v).sum()} non-finite value(s)"
        for k, v in summed.items()
        if v.dtype.kind == "f" and not np.isfinite(v).all()
    ]  # counts
    if not problems and consistency is not None:
        problems = consistency(summed, per)
    if problems:
        raise ValueError(
            f"checkpoint {path} is inconsistent ({'; '.join(problems)}; next start {next_start}): its totals do not "
            f"add up to its per-realization records, so it was edited or damaged. {advice}"
        )
    return next_start, summed, per


def _save_checkpoint(path: Path, fingerprint: dict, next_start: int, summed: dict, per: dict) -> None:
    """Write the accumulated state atomically (temporary file in the same folder, fsync, then os.replace), with a
    content digest of its entries (`_content_digest`): an edited or damaged checkpoint is refused on loading. The
    digest detects edits and corruption, not a forger who recomputes it; the observer's consistency checks
    (`AbstractObserver.consistency`) are the second line."""
    arrays = {"fingerprint": np.array(json.dumps(fingerprint)), "next_start": np.array(next_start)}
    arrays.update({f"summed/{k}": np.asarray(v) for k, v in summed.items()})
    arrays.update({f"per/{k}": v[:next_start] for k, v in per.items()})
    arrays["digest"] = np.array(_content_digest(arrays))
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue(), name_errors=True)


#: Peak bytes per realization-step of the histogram observer's chunk, measured (peak RSS, dt = 0.05 s, 3600 s,
#: chunks of 100 and 200: 56 and 52 B; XLA's own estimate 41-46 B) and rounded up; observers state their own
#: `bytes_per_realization` (benchmarks/memory.py).
BYTES_PER_REALIZATION_STEP = 64


#: Realizations per chunk and device when `chunk_size` is None, for observers that keep each realization's history
#: (the amplitude histograms) and for streaming ones (maxima, max roll). On a CPU (each core a device) 500, the size
#: measured best: since the RK4 stages and P are kept once per step, a core's working set of 500 realizations stays
#: in its L1 cache (paper protocol on one core: 1.00 s in chunks of 500, 1.17 s in 250, 1.79 s in 1000; on two,
#: chunks of 1000 beat 5000 by 10 %; docs/numerics.md). On a GPU or TPU wide enough to fill it (one H200,
#: 2026-11-26: 10⁶ × 3600 s of the histogram observer in chunks of 2.5·10⁴ / 5·10⁴ / 10⁵ took 2.7 / 2.1 / 1.6 s,
#: and 1.6 s on an H100 in 10⁵; the streaming observer's chunk of 2.5·10⁵ ran at 3.1–3.8·10¹⁰ realization-steps/s
#: on both, benchmarks/README.md). Either is then cut to the memory budget.
DEFAULT_CHUNK_PER_CPU = (500, 500)
DEFAULT_CHUNK_PER_ACCELERATOR = (100_000, 250_000)


def default_chunk_size(keeps_history: bool, devices=None) -> int:
    """Realizations per chunk for `chunk_size=None` on the mesh of `devices` (as `realization_mesh`):
    `DEFAULT_CHUNK_PER_CPU` (CPU devices) or `DEFAULT_CHUNK_PER_ACCELERATOR` (GPUs/TPUs) × the device count."""
    mesh_devices = list(realization_mesh(devices).devices.flat)
    i = 0 if keeps_history else 1
    per_device = DEFAULT_CHUNK_PER_CPU if mesh_devices[0].platform == "cpu" else DEFAULT_CHUNK_PER_ACCELERATOR
    return per_device[i] * len(mesh_devices)


def _device_free_bytes(device) -> int | None:
    """Free memory of an accelerator device [bytes] (its allocator's limit less what is in use), None if unknown."""
    try:
        stats = device.memory_stats()
    except Exception:  # pragma: no cover  (a backend without memory statistics)
        return None
    if not stats or "bytes_limit" not in stats:
        return None
    return int(stats["bytes_limit"]) - int(stats.get("bytes_in_use", 0))


def default_memory_budget(fraction: float | None = None, devices=None) -> float:
    """The memory a chunk may use [bytes] on the mesh of `devices` (as `realization_mesh`; None: all).

    On GPUs/TPUs, where each device holds its share of the chunk: `fraction` (default 0.9) of the smallest free
    device memory (`memory_stats()`: the allocator's limit less what is in use) × the device count — the
    observers' bounds are ~3× what a chunk takes there (histogram observer: 64 B per realization-step bound,
    21-22 B measured on an H100 and an H200, `benchmarks/gpu.py`), so a chunk uses about a third of it. On a CPU
    (or where a device reports no memory): `fraction` (default 0.25) of the host's available memory
    (MemAvailable of /proc/meminfo, else sysconf)."""
    mesh_devices = list(realization_mesh(devices).devices.flat)
    if mesh_devices[0].platform != "cpu":
        free = [_device_free_bytes(d) for d in mesh_devices]
        if all(f is not None for f in free):
            return (0.9 if fraction is None else fraction) * min(free) * len(mesh_devices)
    fraction = 0.25 if fraction is None else fraction
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return fraction * int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return fraction * os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return fraction * 8 * 2**30


def chunk_size_for_memory(
    chunk_size: int,
    num_steps: int,
    memory_budget: float | None,
    bytes_per_realization: int | None = None,
    devices=None,
) -> int:
    """`chunk_size` if its peak memory fits `memory_budget` [bytes] (None: `default_memory_budget(devices=devices)`)
    at `bytes_per_realization` each (None: num_steps × BYTES_PER_REALIZATION_STEP, the whole-series observers'
    figure); else the largest chunk that fits, rounded down to three significant binary digits (a budget that
    moves by a few per cent between calls then gives the same chunk, and no recompilation); at least 1."""
    budget = default_memory_budget(devices=devices) if memory_budget is None else float(memory_budget)
    if not (budget > 0):
        raise ValueError(f"`memory_budget` must be > 0 [bytes]; got {memory_budget!r}.")
    per = (
        max(num_steps, 1) * BYTES_PER_REALIZATION_STEP
        if bytes_per_realization is None
        else bytes_per_realization
    )
    fit = int(budget // max(per, 1))
    if fit >= chunk_size:
        return int(chunk_size)
    return max(1, _coarse(fit))


def _coarse(n: int) -> int:
    """`n` rounded down to three significant binary digits (…, 48, 56, 64, 80, 96, 112, 128, …): a chunk cut to a
    memory budget that moves a little with what else is in memory keeps its shape, so it is not recompiled."""
    step = 1 << max(n.bit_length() - 3, 0)
    return n // step * step


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
    consistency=None,
):
    """Run `chunk_fn(problem, key, indices, valid, *static) -> (summed, per_realization)` over all
    realizations.

    `summed` (dict of arrays reduced over the chunk's realization axis) is added over chunks;
    `per_realization` (dict of arrays with a leading chunk axis) is placed at the realizations' indices. The
    chunks are balanced (⌈N / chunk_size⌉ chunks of equal size) and the last is padded with invalid realizations
    (`valid` False) so that every chunk has the same shape and compiles once.

    The realization axis of every chunk is sharded over a 1-D mesh of devices (axis `"realizations"`), across
    processes too after `jax.distributed.initialize()`: the chunk is rounded up to a multiple of the device
    count, each device runs `chunk_fn` on its own slice (`jax.shard_map`), `summed` is added across devices
    (`psum`) inside the compiled chunk, and `per_realization` is
    gathered to every process. Realization i uses `fold_in(key, i)` whatever the device, so results do not
    depend on the number of devices, processes or chunks, bit for bit (XLA:CPU with platform-independent math,
    which `import jaxroll` requests, and at least two realizations per device and chunk; a lone realization is
    padded). `summed` entries should be integer-valued (counts), which any reduction order adds
    exactly; float sums belong in `per_realization` (added on the host in index order).

    **Arguments:**

    - `chunk_fn`: the chunk function (jitted once per mesh; `static` entries must be hashable Python values).
    - `problem`, `key`: passed to every chunk (replicated on every device).
    - `num_realizations`, `chunk_size`: realizations in all, and per compiled chunk (memory bound).
    - `progress`: called with the number of realizations done after each chunk, and once after a checkpoint of this
      run has been read (with the realizations it holds).
    - `devices`: None (all devices, `jax.devices()`), an int n (the first n), or a sequence of devices.
    - `checkpoint`: a directory; the accumulated state is saved there (`checkpoint.npz`, atomically) with a
      fingerprint of the run, and a rerun with the same directory resumes where it stopped and gives exactly
      the result of an uninterrupted run. A finished run leaves its final state, so a rerun returns at once.
    - `checkpoint_every`: save every this many chunks; None (default) saves when `CHECKPOINT_SECONDS` (60 s)
      of wall time have passed since the last save, and always after the last chunk.
    - `consistency`: `consistency(summed, per) -> list[str]`, the problems of a checkpoint's totals against its
      per-realization arrays (`AbstractObserver.consistency`); a checkpoint with any is refused.

    **Returns:** `(summed, per_realization)` as host numpy arrays (the same on every process).

    **Raises:** `ValueError` when the checkpoint is unreadable, has been changed since it was written (its content
    digest), is inconsistent (`consistency`) or belongs to a different run (the message says what differs and how
    to proceed).
    """
    if checkpoint_every is not None and not (isinstance(checkpoint_every, int) and checkpoint_every >= 1):
        raise ValueError(f"`checkpoint_every` must be None or an integer >= 1; got {checkpoint_every!r}.")
    mesh = realization_mesh(devices)
    num_devices = mesh.devices.size
    # At least two realizations per device: XLA compiles a batch of one differently (another rounding in float32),
    # so padding a lone realization keeps every trial bit for bit the same whatever the chunking.
    # Balanced chunks: the last one is padded to the chunk's size, so 5000 realizations in chunks of at most 4000
    # run as two of 2500, not two of 4000. Results do not depend on the chunk.
    num_chunks = -(-num_realizations // min(chunk_size, num_realizations))
    per_chunk = -(-num_realizations // num_chunks)
    chunk = max(2, -(-per_chunk // num_devices)) * num_devices
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
            start, summed, saved_per = _load_checkpoint(path, fingerprint, consistency)
            for k, v in saved_per.items():
                per[k] = np.zeros((num_realizations, *v.shape[1:]), v.dtype)
                per[k][:start] = v
        if _spans_processes(mesh):
            from jax.experimental import multihost_utils

            multihost_utils.assert_equal(
                np.array(start),
                "processes read different checkpoints: put the "
                "checkpoint directory on a file system every process shares.",
            )
    if start and progress is not None:
        progress(start)  # the checkpoint belongs to this run: say so before the first chunk
    problem = _replicate(problem, mesh)
    last_save, chunks_since_save = time.monotonic(), 0
    resumed_keys = (set(summed), set(per)) if start else None  # what the checkpoint recorded

    # The program is looked up once for the run (`cached_program`'s `bind`): every chunk differs only in its indices.
    call = fn.bind(problem, key) if hasattr(fn, "bind") else functools.partial(fn, problem, key)

    def dispatch(first):
        idx = np.arange(first, first + chunk)
        valid = idx < num_realizations
        return valid, call(_global_array(idx, sharding), _global_array(valid, sharding), *static)

    # The next chunk is dispatched before this one's results come to the host (JAX runs programs asynchronously,
    # in order), so the devices do not wait for the host's copying, bookkeeping and dispatch between chunks.
    pending = dispatch(start) if start < num_realizations else None
    while pending is not None:
        valid, out = pending
        n = int(valid.sum())
        pending = dispatch(start + n) if start + n < num_realizations else None
        s, p = _to_host(out, mesh)
        if resumed_keys is not None:
            _check_resumed_statistics(path, resumed_keys, (set(s), set(p)))
            resumed_keys = None
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
                if jax.process_index() == 0 or not _spans_processes(mesh):
                    _save_checkpoint(path, fingerprint, start, summed, per)
                last_save, chunks_since_save = time.monotonic(), 0
        if progress is not None:
            progress(start)
    return summed, per


def _check_resumed_statistics(path: Path, saved: tuple[set, set], now: tuple[set, set]) -> None:
    """Refuse to resume when the chunks record other statistics than the checkpoint holds (a checkpoint written by
    an older or newer jaxroll with the same version string): the realizations before it would get zeros for a
    statistic they never recorded."""
    only_saved = sorted(saved[0] - now[0]) + sorted(saved[1] - now[1])
    only_now = sorted(now[0] - saved[0]) + sorted(now[1] - saved[1])
    if only_saved or only_now:
        raise ValueError(
            f"checkpoint {path} records other statistics than this run (only in the checkpoint: "
            f"{', '.join(only_saved) or 'none'}; only in this run: {', '.join(only_now) or 'none'}): it was written "
            f"by another jaxroll. Delete {path.parent} (or the file) to start afresh, or pass another checkpoint "
            "directory."
        )


_COMPILED: dict = {}


def _compiled(fn, mesh: jax.sharding.Mesh | None = None):
    """`fn` run by every device of `mesh` on its own slice of the realization axis (`jax.shard_map`): `summed`
    added over the devices (`psum`: integer-valued counts, exact in any order), `per_realization` left sharded
    along the axis; cached per (function, mesh). In one process, a stored program
    (`jaxroll._compiled.cached_program`), so a warm command neither traces nor lowers the Monte Carlo body (~0.7 s
    for the paper's chunk on a 2-core CPU), also on a mesh of one process's own devices among several; on a mesh
    across processes, `eqx.filter_jit`.

    Each device computes only its own realizations: left to XLA's sharding propagation (a `jit` with output
    shardings), the envelope's FFT was gathered and done in full on every device (2× the work and two
    all-gathers of the chunk's roll history), so the histogram Monte Carlo gained little from a second device."""
    if (fn, mesh) not in _COMPILED:
        if mesh is None or not _spans_processes(mesh):
            compile_ = functools.partial(cached_program, compiler_options=MONTE_CARLO_PROGRAM)
        else:
            compile_ = eqx.filter_jit
        if mesh is None or mesh.devices.size == 1:
            _COMPILED[fn, mesh] = compile_(fn)
        else:
            spec, along = jax.sharding.PartitionSpec(), jax.sharding.PartitionSpec(REALIZATION_AXIS)

            def sharded(problem, key, indices, valid, *static):
                arrays, rest = eqx.partition(problem, eqx.is_array)

                def local(arrays, key, indices, valid):
                    summed, per = fn(eqx.combine(arrays, rest), key, indices, valid, *static)
                    return jax.lax.psum(summed, REALIZATION_AXIS), per

                return jax.shard_map(
                    local,
                    mesh=mesh,
                    in_specs=(spec, spec, along, along),
                    out_specs=(spec, along),
                    check_vma=False,
                )(arrays, key, indices, valid)

            sharded.__module__ = fn.__module__
            sharded.__name__ = sharded.__qualname__ = f"{getattr(fn, '__qualname__', 'chunk_fn')}[sharded]"
            _COMPILED[fn, mesh] = compile_(sharded)
    return _COMPILED[fn, mesh]
