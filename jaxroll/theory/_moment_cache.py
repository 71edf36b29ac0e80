"""Moment method, cache of the generated tables, kept on disk between runs.

Generating the moment equations is pure Python (~0.1–0.3 s per closure order). The tables are cached here, in
memory and, when JAX's persistent compilation cache is on (`jax_compilation_cache_dir`, as the `jaxroll` command
sets it), on disk beside the compiled kernels in `<cache dir>/jaxroll-moment/`: `_Tables` (NumPy arrays and
tuples of integers) as data, never pickled (`jaxroll._compiled.store_data`: an `.npz` entry of JSON and arrays, with
a digest and the versions that wrote it; anything else there is a miss), keyed by the structure of the SDE, the
closure order and `generator_key()`, a hash of the generator's source, so that editing the generator invalidates
them.

The compiled programs that use them (the stationary solve, the theories' laws and summaries) are stored by
`jaxroll._compiled.cached_program`, keyed by a hash of the whole package source.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from .._compiled import cache_subfolder, load_data, store_data

_FORMAT = "2"  # bump to invalidate every cached file


def cache_dir() -> Path | None:
    """`<jax_compilation_cache_dir>/jaxroll-moment`, or None when JAX's persistent cache is off (or in a folder
    others can write to)."""
    return cache_subfolder("jaxroll-moment")


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
    from ._moment_equations import _build_tables, _Tables

    d = cache_dir()
    key = tables_key(structure, order, extra)
    path = None if d is None else d / f"tables-{key}.npz"
    if path is not None:
        tables = load_data(path, key)
        if isinstance(tables, _Tables) and tables.key == (structure, order, extra):
            return tables
    tables = _build_tables(structure, order, extra)
    if path is not None:
        store_data(path, key, tables)
    return tables
