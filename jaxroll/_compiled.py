"""Concrete or traced: stored programs (trace once, then load) and checks that raise early.

`require(value, bad, message)`: a check that raises `ValueError` at once on concrete values (no compiled
host-callback kernel, a clear error on the command line) and attaches `eqx.error_if` under tracing.

`cached_program`: compiled programs kept between runs, so a warm run does no Python tracing.

JAX's persistent compilation cache (`jax_compilation_cache_dir`, which the `jaxroll` command turns on) skips XLA's
compilation on a warm run, but not the Python tracing and lowering that come before it: 0.05–1 s per program
(the optimistix filter fit alone ~0.7 s), which is most of a warm command's set-up. `cached_program` removes it:
the first call with a given static configuration and argument shapes exports the program (`jax.export`, StableHLO)
and keeps it on disk beside JAX's cache, in `<cache dir>/jaxroll-programs/`; a later process deserializes it and
calls it, and XLA's cache supplies the compiled kernel.

Keys: the function's name, its static arguments (non-array leaves, as for `eqx.filter_jit`), the shapes and dtypes
of its array arguments, and `package_key()` — a hash of jaxroll's whole source, the versions of JAX and its
libraries, the backend and the float64 flag —, so editing any module invalidates every program.

Only concrete calls are cached; under `jax.jit`, `jax.grad` or `jax.vmap` (or with the persistent cache off) the
function is traced as usual — it is the same function. A program that cannot be exported (e.g. one with a host
callback such as `eqx.error_if`'s) is simply run through `eqx.filter_jit`, and remembered as such.
Arguments laid out over several devices (the Monte Carlo's realization axis) are keyed by their layout too.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import os
import pathlib
import pickle
import re
import tempfile
from collections.abc import Callable
from typing import Any

import equinox as eqx
import jax
import numpy as np

_FORMAT = "1"  # bump to invalidate every stored program
_PACKAGE = pathlib.Path(__file__).resolve().parent


def cache_dir() -> pathlib.Path | None:
    """`<jax_compilation_cache_dir>/jaxroll-programs`, or None when JAX's persistent cache is off."""
    base = jax.config.jax_compilation_cache_dir
    return pathlib.Path(base) / "jaxroll-programs" if base else None


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


def require(value, bad, message: str):
    """`value`, after raising `ValueError(message)` where `bad` holds (concrete values), or with `eqx.error_if`
    attached (traced values). The return value must be used: it carries the run-time check when tracing."""
    if isinstance(bad, jax.core.Tracer) or isinstance(value, jax.core.Tracer):
        return eqx.error_if(value, bad, message)
    if bool(np.any(np.asarray(bad))):
        raise ValueError(message)
    return value


def _read(path: pathlib.Path) -> bytes | None:
    try:
        return path.read_bytes()
    except OSError:
        return None


def write_atomic(path: pathlib.Path, data: bytes) -> None:
    """Write `data` to `path` through a temporary file renamed into place; a cache that cannot be written is not
    an error (the program is simply traced again next time)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except OSError:
        pass


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


_LOADED: dict[str, Any] = {}  # key -> (jitted exported call, output skeleton) | None (not exportable)


def cached_program(fn: Callable) -> Callable:
    """Decorate a pure function of pytrees so that a concrete call runs a stored, compiled program.

    `fn(*args)`: array leaves are inputs, every other leaf is static configuration (as for `eqx.filter_jit`; it
    must be picklable); returns a pytree. Traced calls and calls with JAX's persistent cache off go to
    `eqx.filter_jit(fn)`.
    """
    jitted = eqx.filter_jit(fn)
    name = f"{fn.__module__}.{fn.__qualname__}"

    @functools.wraps(fn)
    def wrapper(*args):
        d = cache_dir()
        if d is None or not is_concrete(args):
            return jitted(*args)
        dynamic, static = eqx.partition(args, eqx.is_array)
        leaves, in_tree = jax.tree.flatten(dynamic)
        try:
            static_bytes = pickle.dumps(static, protocol=4) + str(in_tree).encode()
        except Exception:  # an unpicklable static argument: no stored program
            return jitted(*args)
        key = _sha(package_key(), name, static_bytes, [(x.shape, str(x.dtype), getattr(x, "weak_type", False),
                                                       _placement(x)) for x in leaves])
        entry = _LOADED.get(key, False)
        if entry is False:
            entry = _load_or_export(d / f"{key}.bin", fn, leaves, in_tree, static)
            _LOADED[key] = entry
        if entry is None:
            return jitted(*args)
        call, skeleton = entry
        outputs = call(*leaves)
        return jax.tree.map(lambda s: outputs[s.index] if isinstance(s, _Slot) else s, skeleton,
                            is_leaf=lambda x: isinstance(x, _Slot))

    wrapper.jitted = jitted
    return wrapper


def _load_or_export(path: pathlib.Path, fn, leaves, in_tree, static):
    blob = _read(path)
    if blob is not None:
        try:
            payload = pickle.loads(blob)
            if payload is None:
                return None  # stored as not exportable
            exp_bytes, skeleton = payload
            return jax.jit(jax.export.deserialize(bytearray(exp_bytes)).call), skeleton
        except Exception:  # corrupt or foreign file: export afresh and overwrite it
            pass
    box = {}

    def flat(*xs):
        out = fn(*eqx.combine(jax.tree.unflatten(in_tree, list(xs)), static))
        out_dyn, out_static = eqx.partition(out, eqx.is_array)
        out_leaves, out_tree = jax.tree.flatten(out_dyn)
        slots = jax.tree.unflatten(out_tree, [_Slot(i) for i in range(len(out_leaves))])
        box["skeleton"] = eqx.combine(slots, out_static, is_leaf=lambda x: isinstance(x, _Slot))
        return out_leaves

    try:
        exp = _export(flat, leaves)
        data = pickle.dumps((bytes(exp.serialize()), box["skeleton"]), protocol=4)
        pickle.loads(data)  # the skeleton must come back (an output that cannot is run the usual way)
    except Exception:  # host callbacks, unpicklable outputs, `flatbuffers` missing: run it the usual way
        write_atomic(path, pickle.dumps(None))
        return None
    write_atomic(path, data)
    return jax.jit(exp.call), box["skeleton"]
