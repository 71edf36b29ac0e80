"""Moment method, cache of the generated tables, kept on disk between runs.

Generating the moment equations is pure Python (~0.1–0.3 s per closure order). The tables are cached here, in
memory and, when JAX's persistent compilation cache is on (`jax_compilation_cache_dir`, as the `jaxroll` command
sets it), on disk beside the compiled kernels in `<cache dir>/jaxroll-moment/`: pickled `_Tables` (NumPy arrays),
keyed by the structure of the SDE, the closure order and `generator_key()`, a hash of the generator's source, so
that editing the generator invalidates them.

The compiled programs that use them (the stationary solve, the theories' laws and summaries) are stored by
`jaxroll._compiled.cached_program`, keyed by a hash of the whole package source.
"""

from __future__ import annotations

import functools
import hashlib
import pickle
from pathlib import Path

import jax

from .._compiled import _read, write_atomic

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
    """The generator's source: the whole of `_moment_equations.py` (read as a file: `inspect.getsource` of its
    functions took 0.1 s per process)."""
    from . import _moment_equations as me

    return (Path(me.__file__).read_text(encoding="utf-8"),)


@functools.lru_cache(maxsize=1)
def generator_key() -> str:
    """Hash of the moment-equation generator's source (changes whenever the generator is edited)."""
    return _sha(_FORMAT, *_generator_sources())


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
        write_atomic(path, pickle.dumps(tables, protocol=pickle.HIGHEST_PROTOCOL))
    return tables
