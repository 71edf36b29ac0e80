"""jaxroll's files in the on-disk cache: data only, verified when read, in a folder only the user can write.

What jaxroll keeps beside JAX's compilation cache (`<cache>/jaxroll-programs/`, `<cache>/jaxroll-moment/`) was
pickled until 0.2: a file planted there ran arbitrary code when read. An entry is now a NumPy `.npz` archive read
with `allow_pickle=False` — arrays of numbers and bytes, nothing that runs:

- `__meta__`: JSON (UTF-8 bytes) with the format, the entry's key, the versions of jaxroll, JAX and jaxlib that
  wrote it, and the SHA-256 of every other member (name, dtype, shape, bytes);
- the members themselves: e.g. the `jax.export` serialization of a program as it is (`uint8`), and a Python
  structure (a program's output skeleton, the moment method's tables) as JSON (`encode`/`decode`) plus its arrays.

`decode` rebuilds only a closed set of types: None, bool, int, float, str, tuple, list, dict, NumPy arrays and
scalars (no object dtype), and instances of classes already imported from jaxroll or the libraries it builds on
(equinox, optimistix, lineax, diffrax) that are equinox Modules or dataclasses, made as unpickling makes them
(`cls.__new__(cls)` and their fields set, no `__init__`, no `__setstate__`). A class is never imported by name. A
class that is kept by a key (as it pickles: `MomentEquations`, by its tables' key) says so with
`__jaxroll_cache_key__()` and rebuilds itself with the classmethod `__jaxroll_from_cache_key__(key)`; a class that
pickles in another way of its own is not stored.

`read_entry` treats anything unreadable as a miss (returns None, no message): a missing, truncated or corrupt file,
another format, key or version, a digest that does not match, a file not owned by the user or writable by others,
anything but a regular file (a FIFO there hung the command, issue 45).

`unsafe_reason(folder)` says why a cache folder must not be used: it, or a folder above it, can be written by
another user (group- or world-writable without the sticky bit, or owned by someone other than the user or root),
so that someone else could put files there that JAX would load as compiled code (docs/scaling.md, "The
compilation cache and what it trusts").
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib.metadata
import io
import itertools
import json
import os
import stat
import sys
from pathlib import Path

import numpy as np

from ._atomic import read_regular

FORMAT = "jaxroll-cache 2"
_TRUSTED = (
    "jaxroll",
    "equinox",
    "optimistix",
    "lineax",
    "diffrax",
)  # where the classes of a decoded object live


# ------------------------------------------------------------------------------------------------------------
# The folder
# ------------------------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=16)
def unsafe_reason(folder: str) -> str | None:
    """Why `folder` must not hold a cache that is loaded and run (None: it may). It is created (mode 0700) where
    missing, so that nobody else can create it first. Every folder from it up to the root must be owned by the user
    or root; none may be writable by its group or others, except, above the folder, one with the sticky bit (/tmp),
    in which nobody else can rename or remove what is the user's. POSIX only (None elsewhere)."""
    if os.name != "posix":  # pragma: no cover
        return None
    try:
        os.makedirs(folder, mode=0o700, exist_ok=True)
    except OSError as e:
        return f"it cannot be created ({e.strerror})"
    uid = os.geteuid()
    real = Path(os.path.realpath(folder))
    for i, d in enumerate([real, *real.parents]):
        try:
            st = os.stat(d)
        except OSError as e:
            return f"{d} cannot be read ({e.strerror})"
        if st.st_uid not in (uid, 0):
            return f"{d} belongs to another user (uid {st.st_uid})"
        if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH) and not (i > 0 and st.st_mode & stat.S_ISVTX):
            who = "every user" if st.st_mode & stat.S_IWOTH else "its group"
            return f"{d} is writable by {who} (mode {stat.S_IMODE(st.st_mode):o})"
    return None


@functools.lru_cache(maxsize=16)
def unusable_reason(folder: str) -> str | None:
    """Why `folder` cannot hold a cache at all (None: it can): it cannot be created (a file stands there or above
    it, a read-only file system, a permission), or no file can be written in it. The real reason, from the
    operating system (a file in its place was reported as a folder others could write to, issue 45)."""
    import errno
    import tempfile

    try:
        os.makedirs(folder, mode=0o700, exist_ok=True)
    except FileExistsError:
        return f"{folder} is a file, not a folder"
    except NotADirectoryError:
        return f"a file stands where a folder above {folder} should be"
    except OSError as e:
        return f"it cannot be created ({e.strerror or e})"
    if not os.path.isdir(folder):
        return f"{folder} is a file, not a folder"
    try:
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".jaxroll-probe-")
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        why = "it is on a read-only file system" if e.errno == errno.EROFS else (e.strerror or str(e))
        return f"no file can be written in it ({why})"
    return None


def own_folder(folder: Path) -> bool:
    """Create `folder` (mode 0700) where missing; whether it is the user's and no one else can write to it."""
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        st = os.stat(folder)
    except OSError:
        return False
    return st.st_uid == os.geteuid() and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


# ------------------------------------------------------------------------------------------------------------
# Entries
# ------------------------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=1)
def versions() -> dict[str, str | None]:
    """The versions an entry must have been written by: jaxroll, JAX, jaxlib."""
    out = {}
    for lib in ("jaxroll", "jax", "jaxlib"):
        try:
            out[lib] = importlib.metadata.version(lib)
        except importlib.metadata.PackageNotFoundError:  # pragma: no cover
            out[lib] = None
    return out


def _digest(members: dict[str, np.ndarray]) -> str:
    h = hashlib.sha256()
    for name in sorted(members):
        a = np.ascontiguousarray(members[name])
        h.update(f"{name}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def text_member(text: str) -> np.ndarray:
    """`text` as a member (UTF-8 bytes in a uint8 array)."""
    return np.frombuffer(text.encode(), dtype=np.uint8)


def member_text(a: np.ndarray) -> str:
    return np.asarray(a, dtype=np.uint8).tobytes().decode()


def entry_bytes(key: str, members: dict[str, np.ndarray]) -> bytes:
    """An entry: `members` (arrays of numbers or bytes, no object dtype) and their meta data, as `.npz` bytes."""
    meta = {"format": FORMAT, "key": key, "versions": versions(), "sha256": _digest(members)}
    buf = io.BytesIO()
    np.savez(buf, __meta__=text_member(json.dumps(meta)), **members)
    return buf.getvalue()


def read_entry(path: Path, key: str) -> dict[str, np.ndarray] | None:
    """The members of the entry at `path`, or None (a miss) where it is missing, unreadable, corrupt, of another
    format, key or version, does not match its digest, or could have been written by someone else."""
    try:
        st = os.stat(path)
        if os.name == "posix" and (st.st_uid != os.geteuid() or st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)):
            return None
        data = read_regular(path)  # a regular file only (a FIFO would hang the command)
        if os.name == "posix" and os.stat(path).st_ino != st.st_ino:
            return None  # replaced between the checks and the reading
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            members = {name: npz[name] for name in npz.files}
        meta = json.loads(member_text(members.pop("__meta__")))
        if (meta.get("format"), meta.get("key"), meta.get("versions")) != (FORMAT, key, versions()):
            return None
        if meta.get("sha256") != _digest(members):
            return None
        return members
    except (
        Exception
    ):  # anything unreadable is a miss (OSError, ValueError from a pickled or broken member, …)
        return None


# ------------------------------------------------------------------------------------------------------------
# Python structures as JSON and arrays
# ------------------------------------------------------------------------------------------------------------


class Unencodable(TypeError):
    """A structure holds an object `encode` does not store (a function, an object dtype, a foreign class)."""


def _class_name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def _trusted_module(name: str) -> bool:
    return name.split(".")[0] in _TRUSTED


@functools.lru_cache(maxsize=256)
def _storable_class(cls: type) -> bool:
    import equinox as eqx

    return (
        _trusted_module(cls.__module__)
        and "<locals>" not in cls.__qualname__
        and (issubclass(cls, eqx.Module) or dataclasses.is_dataclass(cls) or _is_enumeration(cls))
    )


def _is_enumeration(cls) -> bool:
    import equinox as eqx

    return isinstance(cls, type) and issubclass(cls, eqx.Enumeration)


def encode(obj, leaf=None) -> tuple[str, dict[str, np.ndarray]]:
    """`obj` as (JSON text, arrays); `leaf(x)` may return a JSON-able stand-in for `x` (a placeholder), else None.
    Raises `Unencodable` where `obj` holds something `decode` would not rebuild."""
    arrays: dict[str, np.ndarray] = {}
    seen: dict[
        int, int
    ] = {}  # id of an instance or array -> its reference number (shared objects stay shared)
    keep = []  # the objects whose ids are in `seen` stay alive
    numbers = itertools.count()

    def store(a: np.ndarray) -> int:
        n = next(numbers)
        arrays[f"a{n}"] = a
        return n

    def enc(x):
        if leaf is not None and (stand_in := leaf(x)) is not None:
            return {"leaf": stand_in}
        if x is None or isinstance(x, (bool, str)) or type(x) in (int, float):
            return x
        if type(x) is tuple:
            if all(type(v) is int for v in x):
                return {"ti": list(x)}
            if (
                rows := _int_rows(list(x))
            ) is not None:  # the moment tables' monomials: thousands, as an array
                return {"tti": store(rows)}
            return {"t": [enc(v) for v in x]}
        if type(x) is list:
            return {"l": [enc(v) for v in x]}
        if type(x) is dict:
            keys, values = _int_rows(list(x)), _int_rows([(v,) for v in x.values()])
            if keys is not None and values is not None:  # the tables' index {monomial: position}
                return {"dti": [store(keys), store(values)]}
            return {"d": [[enc(k), enc(v)] for k, v in x.items()]}
        if id(x) in seen:
            return {"ref": seen[id(x)]}
        if isinstance(x, np.ndarray) and type(x) is np.ndarray:
            if x.dtype.hasobject:
                raise Unencodable("an array of Python objects")
            seen[id(x)] = n = store(x)
            keep.append(x)
            return {"a": n}
        if isinstance(x, np.generic):
            if x.dtype.hasobject:
                raise Unencodable("a NumPy object scalar")
            return {"n": [x.dtype.str, x.item()]}
        if isinstance(x, type):
            if not _storable_class(x):
                raise Unencodable(f"class {_class_name(x)}")
            return {"c": _class_name(x)}
        cls = type(x)
        if not _storable_class(cls) or not hasattr(x, "__dict__"):
            raise Unencodable(f"an object of type {_class_name(cls)}")
        if hasattr(cls, "__jaxroll_cache_key__"):  # stored by a key, rebuilt by the class from it
            return {"k": _class_name(cls), "v": enc(x.__jaxroll_cache_key__())}
        if not (
            cls.__reduce__ is object.__reduce__
            and cls.__reduce_ex__ is object.__reduce_ex__
            and cls.__getstate__ is object.__getstate__
            and not hasattr(cls, "__setstate__")
        ):
            raise Unencodable(f"{_class_name(cls)} pickles in a way of its own")
        seen[id(x)] = n = next(numbers)
        keep.append(x)
        return {"o": _class_name(cls), "id": n, "f": [[k, enc(v)] for k, v in vars(x).items()]}

    return json.dumps(enc(obj), allow_nan=True), arrays


def _int_rows(items: list) -> np.ndarray | None:
    """`items`, 8 or more tuples of integers of one length (or none), as a 2-D int64 array; else None."""
    if len(items) < 8 or any(type(t) is not tuple for t in items):
        return None
    width = len(items[0])
    if any(len(t) != width or any(type(v) is not int for v in t) for t in items):
        return None
    try:
        return np.array(items, dtype=np.int64).reshape(len(items), width)
    except OverflowError:
        return None


def _rows(a: np.ndarray) -> list[tuple[int, ...]]:
    if a.ndim != 2 or a.dtype != np.int64:
        raise ValueError("not a table of integers")
    return [tuple(r) for r in a.tolist()]


def _find_class(name: str) -> type:
    """The class `module:qualname`, from a module already imported (never importing one) of a trusted package."""
    module, _, qualname = name.partition(":")
    if not _trusted_module(module) or module not in sys.modules or "<locals>" in qualname:
        raise ValueError(f"class {name!r} is not one a cache entry may name")
    obj = sys.modules[module]
    for part in qualname.split("."):
        obj = getattr(obj, part)
    if not isinstance(obj, type) or not _storable_class(obj):
        raise ValueError(f"{name!r} is not a class a cache entry may name")
    return obj


def decode(text: str, arrays: dict[str, np.ndarray], leaf=None):
    """The structure `encode` gave (`leaf(stand_in)` rebuilds a placeholder). Raises ValueError (or KeyError,
    TypeError) on anything else."""
    refs: dict[int, object] = {}

    def dec(x):
        if x is None or isinstance(x, (bool, int, float, str)):
            return x
        if not isinstance(x, dict) or len(x) not in (1, 2, 3):
            raise ValueError("not a cache structure")
        if "k" in x:
            return _find_class(str(x["k"])).__jaxroll_from_cache_key__(dec(x["v"]))
        if "ti" in x:
            ints = tuple(x["ti"])
            if not all(type(v) is int for v in ints):
                raise ValueError("not a tuple of integers")
            return ints
        if "tti" in x:
            return tuple(_rows(arrays[f"a{int(x['tti'])}"]))
        if "dti" in x:
            keys, values = (_rows(arrays[f"a{int(n)}"]) for n in x["dti"])
            if len(keys) != len(values):
                raise ValueError("a table of keys and values of different lengths")
            return {k: v for k, (v,) in zip(keys, values)}
        if "t" in x:
            return tuple(dec(v) for v in x["t"])
        if "l" in x:
            return [dec(v) for v in x["l"]]
        if "d" in x:
            return {dec(k): dec(v) for k, v in x["d"]}
        if "leaf" in x:
            if leaf is None:
                raise ValueError("a placeholder without a rebuild")
            return leaf(x["leaf"])
        if "ref" in x:
            return refs[int(x["ref"])]
        if "a" in x:
            n = int(x["a"])
            a = arrays[f"a{n}"]
            if a.dtype.hasobject:
                raise ValueError("an array of Python objects")
            refs[n] = a
            return a
        if "n" in x:
            dtype, value = x["n"]
            dt = np.dtype(str(dtype))
            if dt.hasobject:
                raise ValueError("a NumPy object scalar")
            return dt.type(value)
        if "c" in x:
            return _find_class(str(x["c"]))
        if "o" in x:
            cls = _find_class(str(x["o"]))
            obj = cls.__new__(cls)
            refs[int(x["id"])] = obj
            fields = {str(k): dec(v) for k, v in x["f"]}
            obj.__dict__.update(fields)  # as unpickling does: no __init__, no __setattr__
            return obj
        raise ValueError("not a cache structure")

    return dec(json.loads(text))
