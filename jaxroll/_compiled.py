"""Concrete or traced: stored programs (trace once, then load) and checks that raise early.

`require(value, bad, message)`: a check that raises `ValueError` at once on concrete values (no compiled
host-callback kernel, a clear error on the command line) and attaches `eqx.error_if` under tracing.

`cached_program`: compiled programs kept between runs, so a warm run does no Python tracing.

JAX's persistent compilation cache (`jax_compilation_cache_dir`, which the `jaxroll` command turns on) skips XLA's
compilation on a warm run, but not the Python tracing and lowering that come before it: 0.05–1 s per program
(the optimistix filter fit alone ~0.7 s), which is most of a warm command's set-up. `cached_program` removes it:
the first call with a given static configuration and argument shapes exports the program (`jax.export`, StableHLO)
and keeps it on disk beside JAX's cache, in `<cache dir>/jaxroll-programs/`; a later process deserializes it and
calls it, and XLA's cache supplies the compiled kernel. A stored program is data, never pickled
(`jaxroll._cache_files`): an `.npz` entry holding the `jax.export` bytes as they are and the output's skeleton as
JSON (its static parts: equinox Modules of jaxroll and the libraries it builds on, numbers, strings, NumPy arrays),
with a digest and the versions that wrote it; anything else found there is a miss. The folder is used only where
no one else can write to it (`cache_subfolder`; docs/scaling.md, "The compilation cache and what it trusts").

Keys: the function's name, its static arguments (non-array leaves, as for `eqx.filter_jit`), the shapes and dtypes
of its array arguments, and `package_key()` — a hash of jaxroll's whole source, the versions of JAX and its
libraries, the backend and the float64 flag —, so editing any module invalidates every program.

Only concrete calls are cached; under `jax.jit`, `jax.grad` or `jax.vmap` (or with the persistent cache off) the
function is traced as usual — it is the same function. A program that cannot be exported (e.g. one with a host
callback such as `eqx.error_if`'s) is simply run through `eqx.filter_jit`, and remembered as such.
Arguments laid out over several devices (the Monte Carlo's realization axis) are keyed by their layout too.

Compilation is most of a cold run: on the CPU a program may name XLA options (`SMALL_PROGRAM`, `SOLVER_PROGRAM`,
`MONTE_CARLO_PROGRAM`), used for the stored program and, with the persistent cache off, for the same program
traced in this process — both give the same bits (`compiled_with`: the same for a program run once, not stored). `prepare` traces and compiles a program ahead, from arguments of the same kind (the
moment method's, for the filter fit's form while the fit is made: `jaxroll.theory.iter_theory_summaries`).
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import os
import pathlib
import pickle
import re
import threading
import warnings
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _cache_files as files
from ._atomic import atomic_write_bytes
from ._config import require_float64

_FORMAT = "2"  # bump to invalidate every stored program
_PACKAGE = pathlib.Path(__file__).resolve().parent


def enable_compilation_cache(path: str | os.PathLike | None = None) -> pathlib.Path | None:
    """Keep compiled programs on disk between Python sessions, as the `jaxroll` command does: JAX's persistent
    compilation cache in `path` (default: `JAXROLL_CACHE_DIR`, else `~/.cache/jaxroll/xla`; an empty
    `JAXROLL_CACHE_DIR` leaves it off), every compilation kept, and jaxroll's stored programs beside it
    (`cache_dir()`), so that a new session loads what an earlier one compiled instead of tracing and compiling it
    again (the README's example: 18 s in every new session without it; with it 19 s the first time, then
    3.4–4.1 s). Call it before the first computation. A folder that others can write to (it, or one above it) is
    refused with a warning: JAX runs the compiled code it finds there (docs/scaling.md, "The compilation cache and
    what it trusts"). **Returns:** the folder, or None when left off or refused."""
    if path is None:
        path = os.environ.get(
            "JAXROLL_CACHE_DIR", os.path.join(os.path.expanduser("~"), ".cache", "jaxroll", "xla")
        )
    if not str(path):
        return None
    problem = files.unusable_reason(os.path.abspath(path))
    if problem is not None:  # nothing can be kept there: say why (not a matter of who else could write)
        warnings.warn(
            f"the compilation cache {str(path)!r} is not used: {problem}. Every program is compiled afresh "
            "(slower). Set JAXROLL_CACHE_DIR to a folder you can write (or to an empty string to leave the "
            "cache off).",
            stacklevel=2,
        )
        return None
    reason = files.unsafe_reason(os.path.abspath(path))
    if reason is not None:  # JAX would load compiled code that someone else may have put there
        warnings.warn(
            f"the compilation cache {str(path)!r} is not used: {reason}, so others could plant "
            "compiled code there, which JAX and jaxroll would run. Every program is compiled afresh "
            "(slower). Use a folder only you can write: 'chmod go-w' the folder named, or set "
            "JAXROLL_CACHE_DIR to a folder of your own.",
            stacklevel=2,
        )
        return None
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    return pathlib.Path(path)


def cache_dir() -> pathlib.Path | None:
    """`<jax_compilation_cache_dir>/jaxroll-programs`, or None when JAX's persistent cache is off (or in a folder
    others can write to)."""
    return cache_subfolder("jaxroll-programs")


_REFUSED: set[str] = set()  # the folders a warning has named


def cache_subfolder(name: str) -> pathlib.Path | None:
    """`<jax_compilation_cache_dir>/NAME` (created, mode 0700), where jaxroll keeps its own files; None when JAX's
    persistent cache is off, or where that folder, or one above it, can be written by someone else (said once, in a
    warning): jaxroll's files are data and verified, but whoever writes there chooses the programs run."""
    base = jax.config.jax_compilation_cache_dir
    if not base:
        return None
    folder = os.path.join(os.path.abspath(base), name)
    problem = files.unusable_reason(folder)
    reason = None if problem else files.unsafe_reason(folder)
    if problem is None and reason is None:
        return pathlib.Path(folder)
    if base not in _REFUSED:  # said once for the folder
        _REFUSED.add(base)
        warnings.warn(
            f"jaxroll keeps no programs or tables in {base!r}: {problem}. Use a compilation cache you can write "
            "(JAXROLL_CACHE_DIR, jaxroll.enable_compilation_cache)."
            if problem
            else f"jaxroll keeps no programs or tables in {base!r}: {reason}, so others could plant files "
            "there. Use a compilation cache only you can write (JAXROLL_CACHE_DIR, "
            "jaxroll.enable_compilation_cache).",
            stacklevel=3,
        )
    return None


def _sha(*parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else repr(p).encode())
        h.update(b"\0")
    return h.hexdigest()[:32]


@functools.lru_cache(maxsize=1)
def package_key() -> str:
    """Hash of jaxroll's source files, the library versions, the backend and x64 (any edit invalidates)."""
    sources = [p.read_bytes() for p in sorted(_PACKAGE.rglob("*.py"))]
    versions = []
    for lib in ("jax", "jaxlib", "equinox", "diffrax", "optimistix", "lineax"):
        try:
            versions.append(importlib.metadata.version(lib))
        except importlib.metadata.PackageNotFoundError:  # pragma: no cover
            versions.append(None)
    return _sha(_FORMAT, *sources, versions, jax.default_backend(), bool(jax.config.jax_enable_x64))


def is_concrete(tree) -> bool:
    """True when no leaf of `tree` is a JAX tracer (not under jit, grad or vmap)."""
    return not any(isinstance(x, jax.core.Tracer) for x in jax.tree.leaves(tree))


def as_float(value):
    """`jnp.asarray(value, dtype=float)`; a concrete value is converted by NumPy and placed with `jax.device_put`,
    which compiles nothing (`jnp.asarray` compiles a conversion or staging program per shape and dtype, ~10 ms
    each on a cold run, in every command's set-up); traced values as `jnp.asarray`."""
    if isinstance(value, jax.core.Tracer):
        return jnp.asarray(value, dtype=float)
    return jax.device_put(np.asarray(value, dtype=float))


def array_module(value):
    """`np` for a concrete value (its checks computed on the host, without compiling an eager XLA program for each
    comparison), `jnp` for a traced one."""
    return jnp if isinstance(value, jax.core.Tracer) else np


def require(value, bad, message: str):
    """`value`, after raising `ValueError(message)` where `bad` holds (concrete values), or with `eqx.error_if`
    attached (traced values). The return value must be used: it carries the run-time check when tracing."""
    if isinstance(bad, jax.core.Tracer) or isinstance(value, jax.core.Tracer):
        return eqx.error_if(value, bad, message)
    if bool(np.any(np.asarray(bad))):
        raise ValueError(message)
    return value


def write_atomic(path: pathlib.Path, data: bytes) -> None:
    """Write `data` to `path` (mode 0600) through a temporary file renamed into place; a cache that cannot be
    written is not an error (the program is simply traced again next time)."""
    try:
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        atomic_write_bytes(path, data, mode=0o600)
    except OSError:
        pass


def store_data(path: pathlib.Path, key: str, obj) -> None:
    """Keep `obj` (a structure of numbers, strings, tuples, dicts, NumPy arrays and jaxroll's data classes) at
    `path` as a cache entry under `key`: data, not a pickle (`_cache_files`). Nothing is stored where `obj` holds
    anything else or the folder cannot be written."""
    try:
        text, arrays = files.encode(obj)
    except files.Unencodable:
        return
    write_atomic(path, files.entry_bytes(key, {"data": files.text_member(text), **arrays}))


def load_data(path: pathlib.Path, key: str):
    """The structure `store_data` kept at `path` under `key`, or None where there is none, or it cannot be read back
    as such (corrupt, foreign, other versions, a digest that does not match, a file others could write)."""
    members = files.read_entry(path, key)
    if members is None or "data" not in members:
        return None
    try:
        return files.decode(files.member_text(members.pop("data")), members)
    except Exception:
        return None


def _export(flat_fn, leaves):
    """`jax.export` of `jax.jit(flat_fn)`, allowing the LAPACK/FFI custom calls JAX itself emits: the stored
    program is keyed by the exact JAX version, so their cross-version compatibility does not matter here."""
    checks: list = []
    for _ in range(8):
        try:
            return jax.export.export(jax.jit(flat_fn), disabled_checks=checks)(*leaves)
        except ValueError as e:
            targets = set(re.findall(r"custom_call @(\w+)", str(e)))
            if not targets or "custom calls" not in str(e):
                raise
            checks += [jax.export.DisabledSafetyCheck.custom_call(t) for t in sorted(targets)]
    raise ValueError("too many custom calls to allow")


def _placement(x) -> str:
    """How an argument is laid out over devices (a program exported for one layout runs only with it)."""
    sharding = getattr(x, "sharding", None)
    if isinstance(sharding, jax.sharding.NamedSharding):
        return f"{dict(sharding.mesh.shape)} {sharding.spec} {sharding.mesh.devices.flat[0].platform}"
    return "one device" if sharding is None or len(sharding.device_set) == 1 else repr(sharding)


class _Slot:
    """Placeholder for the i-th array output in a stored program's output skeleton."""

    def __init__(self, index: int):
        self.index = index


class _Stored:
    """A program in this process: its call on the array leaves (exported, or traced where the persistent cache is
    off), its output skeleton (in `box`, filled when traced), and the call compiled (once)."""

    def __init__(self, exported: Callable, box: dict):
        self.exported, self.box, self.compiled = exported, box, None
        self.from_disk = False  # read from the cache (not exported by this process)

    @property
    def skeleton(self):
        return self.box["skeleton"]

    def outputs(self, arrays):
        """The call's output pytree from its array outputs (the skeleton's `_Slot`s filled in)."""
        return jax.tree.map(
            lambda s: arrays[s.index] if isinstance(s, _Slot) else s,
            self.skeleton,
            is_leaf=lambda x: isinstance(x, _Slot),
        )


_LOADED: dict[str, _Stored | None] = {}  # key -> the program, or None (not exportable: run the usual way)
_LOCKS: dict[str, threading.Lock] = {}  # key -> held while that program is loaded or exported, and compiled
_LOCKS_GUARD = threading.Lock()

#: XLA options (CPU) for programs that run for milliseconds — the set-up's, Roberts', ESAM's: no LLVM optimisation
#: and XLA's older loop emitters, so that compiling them, the whole of their cost on a cold run, is 25–40 % faster.
SMALL_PROGRAM = {"xla_backend_optimization_level": 0, "xla_cpu_use_fusion_emitters": False}
#: XLA options (CPU) for solvers that run for a fraction of a second (the moment method, the envelope FPK): the
#: older loop emitters and LLVM's level 1 (compiling 20–25 % faster, running ≈ 10 % slower; the moment method's
#: numbers are the same bits as at the default level; docs/theory.md, "Speed").
SOLVER_PROGRAM = {"xla_backend_optimization_level": 1, "xla_cpu_use_fusion_emitters": False}
#: XLA options (CPU) for the Monte Carlo chunk: LLVM's level 1 compiles it 8–12 % faster than the default level
#: and runs it as fast or faster (the paper protocol 0.63–0.65 s against 0.68–0.72 s, session 12), with the same
#: bits (histograms, sums and maxima compared); XLA's fusion emitters stay on (off: 2.7× slower to run). Vectors of
#: 512 bits where the CPU has them (AVX-512; XLA's default prefers 256): the time loop, compiled as one function
#: (`import jaxroll`'s small-loop option), runs the paper protocol 0.46–0.49 → 0.42–0.45 s, the same bits (no
#: reassociation: only the vector width changes); a CPU without them keeps its own width.
MONTE_CARLO_PROGRAM = {"xla_backend_optimization_level": 1, "xla_cpu_prefer_vector_width": 512}


def cached_program(fn: Callable | None = None, *, compiler_options: dict | None = None) -> Callable:
    """Decorate a pure function of pytrees so that a concrete call runs a stored, compiled program.

    `fn(*args)`: array leaves are inputs, every other leaf is static configuration (as for `eqx.filter_jit`; it
    must be picklable); returns a pytree. Traced calls go to `eqx.filter_jit(fn)`, and so do calls with JAX's
    persistent cache off unless the program has `compiler_options` (`SMALL_PROGRAM`, `SOLVER_PROGRAM`): XLA options
    it is compiled with on the CPU, stored or (cache off) traced in this process, so that both give the same bits
    (left out where this JAX or XLA does not take them).

    `wrapper.prepare(*args, compile=True)` loads or exports the program for `args` (only their shapes, dtypes,
    placement and static parts matter) and compiles it, without running it: a later call with arguments of the
    same kind runs it at once (a call made meanwhile waits for it instead of tracing it a second time).
    `compile=False` stops after the export, the part that holds Python's GIL.
    """
    if fn is None:
        return functools.partial(cached_program, compiler_options=compiler_options)
    jitted = eqx.filter_jit(fn)
    name = f"{fn.__module__}.{fn.__qualname__}"

    def entry_for(args, compile=True):
        """(`_Stored`, leaves) for concrete `args`, the program loaded or exported on first use and compiled unless
        `compile=False`; None where there is no stored program."""
        d = cache_dir()
        options = _on_cpu(compiler_options)
        if (d is None and not options) or not is_concrete(args):
            return None
        dynamic, static = eqx.partition(args, eqx.is_array)
        leaves, in_tree = jax.tree.flatten(dynamic)
        try:
            static_bytes = pickle.dumps(static, protocol=4) + str(in_tree).encode()
        except Exception:  # an unpicklable static argument: no stored program
            return None
        key = _sha(
            package_key(),
            name,
            options,
            static_bytes,
            [(x.shape, str(x.dtype), getattr(x, "weak_type", False), _placement(x)) for x in leaves],
        )
        with _LOCKS_GUARD:
            lock = _LOCKS.setdefault(key, threading.Lock())
        with lock:
            stored = _LOADED.get(key, False)
            if (
                stored is False
            ):  # with the cache off, the same program is traced and compiled with the same options
                stored = _LOADED[key] = (
                    _Stored(*_flat(fn, in_tree, static))
                    if d is None
                    else _load_or_export(d / f"{key}.npz", key, fn, leaves, in_tree, static)
                )
            if stored is not None and compile and stored.compiled is None:
                try:
                    stored.compiled = _compiled(stored.exported, leaves, options)
                except Exception:
                    if not stored.from_disk:
                        raise
                    # a stored program that does not compile for these arguments: a miss, exported afresh
                    stored = _LOADED[key] = _export_and_store(
                        d / f"{key}.npz", key, fn, leaves, in_tree, static
                    )
                    if stored is not None:
                        stored.compiled = _compiled(stored.exported, leaves, options)
        return None if stored is None else (stored, leaves)

    @functools.wraps(fn)
    def wrapper(*args):
        if not jax.config.jax_enable_x64:  # a safety net: the public entry points check first, by their names
            require_float64(name)
        found = entry_for(args)
        if found is None:
            return jitted(*args)
        stored, leaves = found
        return stored.outputs(stored.compiled(*leaves))

    def prepare(*args, compile: bool = True) -> None:
        entry_for(args, compile)

    def bind(*fixed) -> Callable:
        """`lambda *rest: wrapper(*fixed, *rest)` with the stored program looked up once: a later call whose `rest`
        has arrays of the same kind (shapes, dtypes, placement) and the same static objects runs it after
        flattening `rest` alone. For a run of calls that differ only in some arrays' values (the Monte Carlo's
        chunks): the lookup — flattening, pickling and hashing every argument, ~1.5 ms a call — took host time
        from the devices at every chunk (the paper protocol 0.47 → 0.44 s on a 2-core CPU with `bind`)."""
        memo: dict = {}

        def call(*rest):
            dynamic, static = eqx.partition(rest, eqx.is_array)
            leaves, tree = jax.tree.flatten(dynamic)
            kind = (
                tree,
                tuple(map(id, jax.tree.leaves(static))),
                tuple(
                    (x.shape, x.dtype, getattr(x, "weak_type", False), getattr(x, "sharding", None))
                    for x in leaves
                ),
            )
            if memo.get("kind") != kind:
                if not jax.config.jax_enable_x64:
                    require_float64(name)
                found = entry_for((*fixed, *rest))
                if found is None:
                    return jitted(*fixed, *rest)
                memo["stored"], all_leaves = found
                memo["fixed"], memo["kind"] = all_leaves[: len(all_leaves) - len(leaves)], kind
                memo["static"] = static  # the objects whose ids are in `kind` stay alive
            return memo["stored"].outputs(memo["stored"].compiled(*memo["fixed"], *leaves))

        return call

    wrapper.jitted = jitted
    wrapper.prepare = prepare
    wrapper.bind = bind
    return wrapper


def _on_cpu(options: dict | None) -> dict | None:
    """The XLA `options` where they apply (the CPU), None elsewhere."""
    return options if jax.default_backend() == "cpu" else None


@functools.cache
def _accepted(options: tuple) -> bool:
    """Whether this JAX and XLA compile with `options` (a tuple of items)."""
    try:
        jax.jit(lambda x: x + 1, compiler_options=dict(options)).lower(np.float32(0)).compile()
        return True
    except Exception:
        return False


def filter_jit(fn: Callable | None = None, *, compiler_options: dict | None = SOLVER_PROGRAM) -> Callable:
    """`eqx.filter_jit(fn)` compiled with XLA `compiler_options` on the CPU (default `SOLVER_PROGRAM`), XLA's
    defaults elsewhere or where this JAX or XLA refuses the options; called with traced arguments (under `jit`,
    `grad`, `vmap`) it is `eqx.filter_jit(fn)`, traced into the enclosing program as usual.

    How the library jits its laws, extremes, theories, hydrostatics, fits and single time series: programs that run
    for milliseconds to seconds and whose compilation is most of a first call, which `SOLVER_PROGRAM` shortens
    (`fit_decay_ode` 7.7 → 5.5 s, `fit_roll_kalman` 19.6 → 16.2 s on a first call) without slowing the run
    (docs/architecture.md, "Compiler options"). Only the Monte Carlo chunk keeps XLA's fusion emitters
    (`MONTE_CARLO_PROGRAM`): without them it runs 2.7× slower.
    """
    if fn is None:
        return functools.partial(filter_jit, compiler_options=compiler_options)
    plain = eqx.filter_jit(fn)
    tuned = eqx.filter_jit(fn, compiler_options=compiler_options) if compiler_options else plain
    items = tuple(sorted((compiler_options or {}).items()))
    name = f"{fn.__module__}.{fn.__qualname__}"

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        if not jax.config.jax_enable_x64:  # a safety net: the public entry points check first, by their names
            require_float64(name)
        if (
            compiler_options
            and _on_cpu(compiler_options)
            and is_concrete((args, kwargs))
            and _accepted(items)
        ):
            try:
                return tuned(*args, **kwargs)
            except ValueError as e:  # inside another trace after all (a tracer in a closure)
                if "top-level" not in str(e):
                    raise
        return plain(*args, **kwargs)

    return wrapper


def compiled_with(call: Callable, args, compiler_options: dict | None) -> Callable:
    """`jax.jit(call)` compiled for `args` with XLA `compiler_options` (`SOLVER_PROGRAM`, …) on the CPU, as
    `cached_program`'s programs are, for a program that is run once and not stored (its compilation is most of its
    cost); without them on other backends or where this JAX or XLA refuses them."""
    return _compiled(call, args, _on_cpu(compiler_options))


def _compiled(call: Callable, leaves, options: dict | None) -> Callable:
    """`jax.jit(call)` compiled for `leaves` (its later calls with arguments like them reuse the compilation),
    with XLA `options`, or without them where this JAX or XLA refuses them."""
    if options:
        try:
            jitted = jax.jit(call, compiler_options=options)
            jitted.lower(*leaves).compile()
            return jitted
        except Exception:  # an option this version does not know (an error of the program recurs below)
            pass
    jitted = jax.jit(call)
    jitted.lower(*leaves).compile()
    return jitted


def _flat(fn, in_tree, static):
    """`fn` as a function of its array leaves returning its output's array leaves, and the box its output skeleton
    (the static outputs, with `_Slot`s for the arrays) is put in when it is traced."""
    box = {}

    def flat(*xs):
        out = fn(*eqx.combine(jax.tree.unflatten(in_tree, list(xs)), static))
        out_dyn, out_static = eqx.partition(out, eqx.is_array)
        out_leaves, out_tree = jax.tree.flatten(out_dyn)
        slots = jax.tree.unflatten(out_tree, [_Slot(i) for i in range(len(out_leaves))])
        box["skeleton"] = eqx.combine(slots, out_static, is_leaf=lambda x: isinstance(x, _Slot))
        return out_leaves

    return flat, box


def _load_or_export(path: pathlib.Path, key: str, fn, leaves, in_tree, static) -> _Stored | None:
    """The program stored at `path` (an entry of `_cache_files`: the export's bytes and the output skeleton), or,
    where there is none (or it is unreadable, foreign, of other versions or not what its digest says), the program
    exported now and stored there; None where it cannot be exported (stored as such: run the usual way)."""
    members = files.read_entry(path, key)
    if members is not None:
        try:
            if "exported" not in members:
                return None  # stored as not exportable
            slots: list[int] = []
            skeleton = files.decode(
                files.member_text(members["skeleton"]),
                members,
                leaf=lambda i: slots.append(int(i)) or _Slot(slots[-1]),
            )
            exported = jax.export.deserialize(bytearray(members["exported"].tobytes()))
            if sorted(slots) != list(range(len(exported.out_avals))):
                raise ValueError("the skeleton does not match the program's outputs")
            # another program under this key (its digest recomputed) is a miss, not an error at the call (issue 45)
            if [(tuple(a.shape), np.dtype(a.dtype)) for a in exported.in_avals] != [
                (tuple(x.shape), np.dtype(x.dtype)) for x in leaves
            ]:
                raise ValueError("the program takes other arguments")
            stored = _Stored(exported.call, {"skeleton": skeleton})
            stored.from_disk = True
            return stored
        except Exception:  # not what jaxroll writes: export afresh and overwrite it
            pass
    return _export_and_store(path, key, fn, leaves, in_tree, static)


def _export_and_store(path: pathlib.Path, key: str, fn, leaves, in_tree, static) -> _Stored | None:
    """The program exported now and stored at `path` (None, stored as such, where it cannot be exported)."""
    flat, box = _flat(fn, in_tree, static)
    try:
        exp = _export(flat, leaves)
        text, arrays = files.encode(box["skeleton"], leaf=lambda x: x.index if isinstance(x, _Slot) else None)
        files.decode(text, arrays, leaf=_Slot)  # the skeleton must come back (else: run the usual way)
        members = {
            "exported": np.frombuffer(bytes(exp.serialize()), np.uint8),
            "skeleton": files.text_member(text),
            **arrays,
        }
    except (
        Exception
    ):  # host callbacks, outputs that are not data, `flatbuffers` missing: run it the usual way
        write_atomic(path, files.entry_bytes(key, {}))
        return None
    write_atomic(path, files.entry_bytes(key, members))
    return _Stored(exp.call, box)
