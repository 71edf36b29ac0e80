"""Moment method, caches: the generated tables and the compiled stationary solve, kept on disk between runs.

Two things cost time before any number comes out of the moment method: generating the moment equations (pure
Python, ~0.1–0.3 s per closure order) and tracing + lowering the stationary solve (diffrax + optimistix, several
seconds of Python per closure order even when XLA's persistent cache already holds the compiled kernel). Both
are cached here, in memory and, when JAX's persistent compilation cache is on (`jax_compilation_cache_dir`, as
the `jaxroll` command sets it), on disk beside the compiled kernels in `<cache dir>/jaxroll-moment/`:

- the tables (`_Tables`, pickled NumPy arrays), keyed by the structure of the SDE, the closure order and
  `generator_key()`, a hash of the generator's source, so that editing the generator invalidates them;
- the stationary solve as a serialized `jax.export.Exported` (StableHLO), keyed by the same plus the solver's
  source, the library versions and the argument shapes: a new process deserializes and calls it, with no
  Python tracing; XLA's own cache then supplies the compiled kernel.

Only calls with concrete (untraced) inputs use the exported solve; under `jax.grad`, `jax.vmap` or `jax.jit`
the solve is traced as usual (it is the same function).
"""

from __future__ import annotations

import functools
import hashlib
import importlib.metadata
import inspect
import os
import pickle
import tempfile
from pathlib import Path

import jax
import numpy as np

_FORMAT = "1"  # bump to invalidate every cached file


def cache_dir() -> Path | None:
    """`<jax_compilation_cache_dir>/jaxroll-moment`, or None when JAX's persistent cache is off."""
    base = jax.config.jax_compilation_cache_dir
    if not base:
        return None
    return Path(base) / "jaxroll-moment"


def _sha(*parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(repr(p).encode())
        h.update(b"\0")
    return h.hexdigest()[:32]


def _generator_sources() -> tuple[str, ...]:
    from . import _moment_equations as me

    return tuple(
        inspect.getsource(f)
        for f in (me._compositions, me._recursion_terms, me._build_tables, me._extra_monomials, me._Tables)
    )


@functools.lru_cache(maxsize=1)
def generator_key() -> str:
    """Hash of the moment-equation generator's source (changes whenever the generator is edited)."""
    return _sha(_FORMAT, *_generator_sources())


@functools.lru_cache(maxsize=1)
def solver_key() -> str:
    """Hash of everything an exported solve depends on: generator and solver source, library versions, x64."""
    from . import _moment_equations as me, _moment_solver as ms

    versions = []
    for lib in ("jax", "jaxlib", "equinox", "diffrax", "optimistix", "lineax"):
        try:
            versions.append(importlib.metadata.version(lib))
        except importlib.metadata.PackageNotFoundError:  # pragma: no cover
            versions.append(None)
    return _sha(
        generator_key(),
        inspect.getsource(ms),
        inspect.getsource(me),
        versions,
        bool(jax.config.jax_enable_x64),
        jax.default_backend(),
    )


def _read(path: Path):
    try:
        return path.read_bytes()
    except OSError:
        return None


def _write(path: Path, data: bytes) -> None:
    """Atomic write (a temporary file renamed into place); a cache that cannot be written is not an error."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except OSError:
        pass


# ------------------------------------------------------------------------------------------------------------
# Tables
# ------------------------------------------------------------------------------------------------------------


def tables_key(structure, order: int, extra) -> str:
    """Disk key of the tables of one SDE structure, closure order and extra monomials."""
    return _sha(generator_key(), structure, order, extra)


@functools.lru_cache(maxsize=64)
def cached_tables(structure, order: int, extra):
    """`_build_tables(structure, order, extra)`, from memory, from disk, or freshly generated (then stored)."""
    from ._moment_equations import _build_tables

    d = cache_dir()
    path = None if d is None else d / f"tables-{tables_key(structure, order, extra)}.pkl"
    if path is not None:
        blob = _read(path)
        if blob is not None:
            try:
                return pickle.loads(blob)
            except Exception:  # a corrupt or foreign file: regenerate and overwrite it
                pass
    tables = _build_tables(structure, order, extra)
    if path is not None:
        _write(path, pickle.dumps(tables, protocol=pickle.HIGHEST_PROTOCOL))
    return tables


# ------------------------------------------------------------------------------------------------------------
# The stationary solve, exported
# ------------------------------------------------------------------------------------------------------------


def is_concrete(tree) -> bool:
    """True when no leaf of `tree` is a JAX tracer (not under jit, grad or vmap)."""
    return not any(isinstance(x, jax.core.Tracer) for x in jax.tree.leaves(tree))


_EXPORTED: dict[str, object] = {}


def exported_call(key_parts, fn, args):
    """`fn(*args)` (arrays in, a tuple of arrays out) through a disk-cached `jax.export` of `jax.jit(fn)`.

    `key_parts` must identify `fn`'s static configuration; the shapes and dtypes of `args` are added here.
    """
    leaves = jax.tree.leaves(args)
    key = _sha(solver_key(), key_parts, [(np.shape(x), str(np.asarray(x).dtype)) for x in leaves])
    call = _EXPORTED.get(key)
    if call is None:
        d = cache_dir()
        path = None if d is None else d / f"solve-{key}.bin"
        exp = None
        if path is not None:
            blob = _read(path)
            if blob is not None:
                try:
                    exp = jax.export.deserialize(bytearray(blob))
                except Exception:  # corrupt, foreign, or `flatbuffers` missing: export afresh
                    exp = None
        if exp is None:
            exp = jax.export.export(jax.jit(fn))(*args)
            if path is not None:
                try:
                    _write(path, bytes(exp.serialize()))
                except ImportError:  # serialization needs the `flatbuffers` package: keep it in memory only
                    pass
        call = jax.jit(exp.call)
        _EXPORTED[key] = call
    return call(*args)
