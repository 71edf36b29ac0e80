"""A result's JSON-shaped numbers as an `xarray.Dataset`: one rule, a layout per output.

The rule (docs/outputs.md): a JSON field `a/b/c` becomes the variable `a_b_c`; a mapping whose keys are labels
(estimators, theories, N0, percentiles, …) or a list of records becomes a **dimension** instead of a name part,
its keys the coordinate (numbers where the keys are numbers: "50" → 50); number arrays get the dimensions the layout names. Every variable carries `units`,
`long_name` and `json_path` (where its numbers are in the JSON, `{dim}` for a labelled level). Text goes into
the dataset's attributes (a text under labelled levels as a JSON object keyed by the labels). Booleans stay
booleans (`write_dataset` stores them as int8), a missing number (JSON `null`) is NaN.

Nothing here is numerics: the layouts are data, and xarray is imported only when a dataset is built.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import json
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ._cf import cf_dataset
from ._units import GLOSSARY, long_name_from_path, udunits, units_from_name


@dataclasses.dataclass(frozen=True)
class Layout:
    """How one output's JSON-shaped tree maps onto labelled arrays. Paths are `/`-joined JSON keys; patterns
    match one key per `*` (shell-style within a key).

    - `labels`: pattern of a mapping (or list of records) → the dimension its keys (indices) label; a name in
      parentheses, `"(n0)"`, leaves the container's own name out of the variable names (`per_n0/{n0}/mean_deg`
      → `mean_deg`).
    - `arrays`: pattern of a number array → its dimensions (a trailing axis of 2 of an interval, `*_ci95`,
      `*_ci`, is `bound` without being named).
    - `names`: path pattern → variable name, replacing the rule's.
    - `units`, `long_names`: variable name (or path pattern) → `units` / `long_name`; else from the name
      (`units_from_name`, the glossary).
    - `coords`: dimension → units and long name of its coordinate (`(units, long_name)`).
    - `centres`: coordinate name → the variable of bin edges whose midpoints it holds.
    - `index`: dimension → the labels of its coordinate, where the JSON has none (a matrix's parameters).
    - `text`: path patterns stored as JSON text attributes whatever they hold; `skip`: paths not stored.
    """

    labels: Mapping[str, str] = dataclasses.field(default_factory=dict)
    arrays: Mapping[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)
    names: Mapping[str, str] = dataclasses.field(default_factory=dict)
    units: Mapping[str, str] = dataclasses.field(default_factory=dict)
    long_names: Mapping[str, str] = dataclasses.field(default_factory=dict)
    coords: Mapping[str, tuple[str, str]] = dataclasses.field(default_factory=dict)
    centres: Mapping[str, str] = dataclasses.field(default_factory=dict)
    index: Mapping[str, tuple] = dataclasses.field(default_factory=dict)
    text: tuple[str, ...] = ()
    skip: tuple[str, ...] = ()

    def __add__(self, other: Layout) -> Layout:
        """The two layouts together (`other` wins where both say something)."""
        merged = {}
        for f in dataclasses.fields(self):
            a, b = getattr(self, f.name), getattr(other, f.name)
            merged[f.name] = (a + tuple(x for x in b if x not in a)) if isinstance(a, tuple) else {**a, **b}
        return Layout(**merged)

    def under(self, prefix: str) -> Layout:
        """This layout for the same tree placed under `prefix` (a path, e.g. `"direct"`)."""
        move = lambda d: {f"{prefix}/{k}": v for k, v in d.items()}  # noqa: E731
        return dataclasses.replace(
            self, labels=move(self.labels), arrays=move(self.arrays), names=move(self.names),
            text=tuple(f"{prefix}/{p}" for p in self.text), skip=tuple(f"{prefix}/{p}" for p in self.skip),
        )  # fmt: skip


def _matches(pattern: str, path: tuple[str, ...]) -> bool:
    parts = pattern.split("/")
    return len(parts) == len(path) and all(
        fnmatch.fnmatchcase(k, p) for k, p in zip(path, parts, strict=True)
    )


def _find(patterns: Mapping[str, Any] | tuple[str, ...], path: tuple[str, ...]):
    items = patterns.items() if isinstance(patterns, Mapping) else ((p, True) for p in patterns)
    for pattern, value in items:
        if _matches(pattern, path):
            return value
    return None


def _label(key: str):
    """A label as a coordinate value: numbers for numeric keys ("50" → 50, "12.5" → 12.5), else the text."""
    try:
        number = float(key)
    except ValueError:
        return key
    return int(number) if number.is_integer() and "." not in key and "e" not in key.lower() else number


def _is_number(x) -> bool:
    return isinstance(x, bool | int | float | np.number | np.bool_) and not isinstance(x, str)


def _array(node) -> np.ndarray | None:
    """A number array from a list/array leaf (None → NaN), or None when it is not one."""
    try:
        arr = np.asarray(node)
    except ValueError:  # ragged
        return None
    if arr.dtype.kind in "biuf":
        return arr
    if arr.dtype.kind == "O":
        flat = arr.ravel()
        if all(v is None or _is_number(v) for v in flat):
            return np.array([np.nan if v is None else v for v in flat], dtype=float).reshape(arr.shape)
    return None


@dataclasses.dataclass
class _Entry:
    name: str
    path: tuple[str, ...]  # with "{dim}" at labelled levels
    label_dims: tuple[str, ...]
    array_dims: tuple[str, ...] = ()
    values: dict = dataclasses.field(default_factory=dict)  # label tuple → value
    unit_texts: set = dataclasses.field(default_factory=set)  # the `unit` texts beside its numbers


class _Builder:
    def __init__(self, layout: Layout):
        self.layout = layout
        self.entries: dict[str, _Entry] = {}
        self.text: dict[str, Any] = {}
        self.labels: dict[str, dict] = {}  # dim → {label key: coordinate value} in order of appearance
        self.index_dims: set[str] = set()

    def walk(self, node, path, name, labels, json_path, unit=None) -> None:
        lay = self.layout
        if path and _find(lay.skip, path):
            return
        if path and _find(lay.text, path):
            self.add_text(name, labels, _plain(node), True)
            return
        dim = _find(lay.labels, path) if path else None
        if dim is not None and node is None:  # a null labelled level (no amplitude: no quantiles): NaN there
            return
        if dim is not None:
            keep = not dim.startswith("(")
            dim = dim.strip("()")
            base = name if keep else name[:-1]
            if not isinstance(node, Mapping):
                self.index_dims.add(dim)
            keyed = node.items() if isinstance(node, Mapping) else ((str(i), v) for i, v in enumerate(node))
            seen = self.labels.setdefault(dim, {})
            for key, child in keyed:
                seen.setdefault(str(key), int(key) if dim in self.index_dims else _label(str(key)))
                self.walk(
                    child, (*path, str(key)), base, (*labels, (dim, str(key))), (*json_path, f"{{{dim}}}")
                )
            return
        if isinstance(node, Mapping):
            # an estimate {value, std_error, ci95, unit}: its numbers are in `unit`
            own = node.get("unit") if isinstance(node.get("unit"), str) else None
            for key, child in node.items():
                self.walk(child, (*path, str(key)), (*name, str(key)), labels, (*json_path, str(key)), own)
            return
        self.leaf(node, path, name, labels, json_path, unit)

    def leaf(self, node, path, name, labels, json_path, unit) -> None:
        lay = self.layout
        if hasattr(node, "__array__") and np.ndim(node) == 0:  # a 0-d (numpy or JAX) array: a number
            node = np.asarray(node).item()
        var = _find(lay.names, path) or "_".join(name)
        if isinstance(node, str):
            self.add_text(var, labels, node)
            return
        array_dims = _find(lay.arrays, path) if node is None or not _is_number(node) else None
        if isinstance(node, list | tuple | np.ndarray) or hasattr(node, "__array__"):
            if isinstance(node, list | tuple) and all(isinstance(v, str) for v in node):
                if (
                    array_dims is None or labels
                ):  # text; a coordinate of labels when the layout names its dims
                    self.add_text(var, labels, list(node), True)
                    return
                arr = np.asarray(node, dtype=str)
            else:
                arr = _array(node)
            if arr is None:
                raise ValueError(
                    f"labelled results: {'/'.join(path)} is neither numbers nor text; give the layout a "
                    "`labels` entry for it (a list of records), or store it as `text`."
                )
            if (
                array_dims is None
                and arr.ndim >= 1
                and arr.shape[-1] == 2
                and path[-1].removesuffix("_deg").endswith(("ci95", "_ci"))
            ):
                array_dims = (*(f"{var}_axis{i}" for i in range(arr.ndim - 1)), "bound")
                self.labels.setdefault("bound", {"lower": "lower", "upper": "upper"})
            if array_dims is None or len(array_dims) != arr.ndim:
                raise ValueError(
                    f"labelled results: the array {'/'.join(path)} (shape {arr.shape}) has no dimension "
                    f"names in the layout (`arrays`); got {array_dims}."
                )
            node = arr
        elif not (node is None or _is_number(node)):
            raise ValueError(f"labelled results: {'/'.join(path)} holds a {type(node).__name__}.")
        dims = tuple(d for d, _ in labels)
        entry = self.entries.get(var)
        if entry is None:
            entry = self.entries[var] = _Entry(var, json_path, dims, tuple(array_dims or ()))
        elif entry.path != json_path or entry.label_dims != dims:
            raise ValueError(
                f"labelled results: two fields map to the variable {var!r}: "
                f"{'/'.join(entry.path)} and {'/'.join(json_path)}; name one in the layout (`names`)."
            )
        if array_dims is not None and not entry.array_dims:
            entry.array_dims = tuple(array_dims)
        entry.values[tuple(k for _, k in labels)] = node
        if unit is not None:
            entry.unit_texts.add(unit)

    def add_text(self, name, labels, value, as_json: bool = False) -> None:
        key = name if isinstance(name, str) else "_".join(name)
        if not labels:
            self.text[key] = json.dumps(value) if as_json else value
            return
        tree = self.text.setdefault(key, {})
        if not isinstance(tree, dict):
            raise ValueError(f"labelled results: the text {key!r} is both plain and labelled.")
        for _, k in labels[:-1]:
            tree = tree.setdefault(k, {})
        tree[labels[-1][1]] = value


def _plain(node):
    if isinstance(node, Mapping):
        return {str(k): _plain(v) for k, v in node.items()}
    if isinstance(node, list | tuple):
        return [_plain(v) for v in node]
    if hasattr(node, "__array__"):
        return _plain(np.asarray(node).tolist())
    if isinstance(node, np.generic):
        return node.item()
    if isinstance(node, float) and not np.isfinite(node):
        return None
    return node


def _units(layout: Layout, entry: _Entry) -> str | None:
    for key in (entry.name, "/".join(entry.path)):
        found = _find(layout.units, tuple(key.split("/"))) if "/" in key else layout.units.get(key)
        if found is not None:
            return found
    for pattern, value in layout.units.items():  # patterns on names ("*_rms")
        if "/" not in pattern and fnmatch.fnmatchcase(entry.name, pattern):
            return value
    if len(entry.unit_texts) > 1:
        raise ValueError(
            f"labelled results: {'/'.join(entry.path)} has a unit per label ({sorted(entry.unit_texts)}); "
            "give the layout its `units` text."
        )
    if entry.unit_texts:
        return udunits(next(iter(entry.unit_texts)))
    leaf = next((p for p in reversed(entry.path) if not p.startswith("{")), entry.name)
    return units_from_name(leaf) or units_from_name(entry.name)


def _long_name(layout: Layout, e: _Entry) -> str:
    """The layout's long name for the variable (its name, its path, a pattern of its name), else one made from
    its path."""
    if e.name in layout.long_names:
        return layout.long_names[e.name]
    for pattern, value in layout.long_names.items():
        if ("/" in pattern and _matches(pattern, e.path)) or (
            "/" not in pattern and fnmatch.fnmatchcase(e.name, pattern)
        ):
            return value
    return long_name_from_path(tuple(p for p in e.path if not p.startswith("{")))


def tree_to_dataset(tree: Mapping, layout: Layout, *, attrs: Mapping[str, Any] | None = None):
    """An `xarray.Dataset` of the numbers in `tree` (a result's JSON-shaped summary: nested dicts, lists, arrays,
    numbers, text) by the rule of this module and `layout`.

    **Raises:** `ValueError` for a field the layout does not cover: an array without dimension names, a number
    without a unit (neither in its name nor in the layout), two fields with one name.
    """
    import xarray as xr

    b = _Builder(layout)
    b.walk(tree, (), (), (), ())
    coords: dict[str, Any] = {}
    for dim, seen in b.labels.items():
        if not seen:  # an empty mapping (no theory asked for): no dimension
            continue
        values = list(seen.values())
        unit, long_name = layout.coords.get(dim, (None, None))
        kind = "index" if dim in b.index_dims else "label"
        attrs_dim = {"long_name": long_name or GLOSSARY.get(dim, dim.replace("_", " "))}
        if all(isinstance(v, int | float) for v in values):
            attrs_dim["units"] = unit or "1"
        if kind == "index":
            attrs_dim["long_name"] = long_name or f"index of the {dim.replace('_', ' ')}"
        coords[dim] = xr.Variable((dim,), np.asarray(values) if values else np.zeros(0, int), attrs_dim)
    sizes = {d: c.size for d, c in coords.items()}
    for e in b.entries.values():
        for v in e.values.values():
            if isinstance(v, np.ndarray):
                for d, n in zip(e.array_dims, v.shape, strict=True):
                    if sizes.setdefault(d, n) != n:
                        raise ValueError(
                            f"labelled results: dimension {d!r} is {sizes[d]} long elsewhere but {n} in "
                            f"{'/'.join(e.path)}."
                        )
    for name, edges in layout.centres.items():  # bin centres: before the variables, which may be on them
        if edges in b.entries and b.entries[edges].values.get(()) is not None:
            v = np.asarray(b.entries[edges].values[()], dtype=float)
            coords[name] = xr.Variable(
                (name,),
                (v[1:] + v[:-1]) / 2,
                {"units": _units(layout, b.entries[edges]), "long_name": f"bin centres of {edges}"},
            )
            sizes[name] = v.size - 1
    variables: dict[str, Any] = {}
    for e in b.entries.values():
        unit = _units(layout, e)
        present = [v for v in e.values.values() if v is not None]
        kinds = {np.asarray(v).dtype.kind for v in present}
        if kinds == {"U"}:  # labels (a coordinate), no unit
            (v,) = present
            variables[e.name] = xr.Variable(
                e.array_dims, v, {"long_name": _long_name(layout, e), "json_path": "/".join(e.path)}
            )
            continue
        if unit is None and present and kinds <= {"b"}:
            unit = "1"
        if unit is None:
            if not present:  # a null text field (e.g. `reason: null`): nothing to store
                continue
            raise ValueError(
                f"labelled results: no unit for {'/'.join(e.path)} (variable {e.name!r}); give it in "
                "the layout (`units`) or name the field with its unit (`_deg`, `_s`, `_m`, …)."
            )
        if any(d not in sizes for d in e.array_dims):  # an array that is null throughout: nothing to store
            continue
        shape_a = tuple(sizes[d] for d in e.array_dims)
        missing = len(present) < len(e.values) or len(e.values) < int(
            np.prod([sizes[d] for d in e.label_dims])
        )
        if kinds <= {"b"} and not missing:
            dtype, fill = bool, False
        elif kinds <= {"b", "i", "u"} and not missing:
            dtype, fill = np.int64, 0
        else:
            dtype, fill = float, np.nan
        shape = tuple(sizes[d] for d in e.label_dims) + shape_a
        data = np.full(shape, fill, dtype=dtype)
        index = [{k: i for i, k in enumerate(b.labels[d])} for d in e.label_dims]
        for key, v in e.values.items():
            if v is None:
                continue
            at = tuple(ix[k] for ix, k in zip(index, key, strict=True))
            data[at] = np.asarray(v, dtype=float if dtype is float else None)
        long_name = _long_name(layout, e)
        variables[e.name] = xr.Variable(
            (*e.label_dims, *e.array_dims),
            data,
            {"units": unit, "long_name": long_name, "json_path": "/".join(e.path)},
        )
    for dim, labels in layout.index.items():
        if dim in sizes and dim not in coords and dim not in variables:
            coords[dim] = xr.Variable(
                (dim,), np.asarray(labels), {"long_name": GLOSSARY.get(dim, dim.replace("_", " "))}
            )
    for name, (unit, long_name) in layout.coords.items():
        if name in variables:
            variables[name].attrs.update(
                {"long_name": long_name, **({} if unit is None else {"units": unit})}
            )
    text = {k: (v if isinstance(v, str) else json.dumps(v)) for k, v in b.text.items()}
    return cf_dataset(xr.Dataset(variables, coords=coords, attrs={**text, **(attrs or {})}))


def labelled_values(
    pairs: Mapping[str, tuple],
    attrs: Mapping[str, Any] | None = None,
    coords: Mapping[str, tuple] | None = None,
):
    """A dataset from `{name: (dims, values, units, long_name)}` (and coordinates the same way): the hand-made
    part of a result's dataset (per-trial arrays, histograms, tables). A unit of None: labels (text), no unit."""
    import xarray as xr

    make: Callable = lambda d: {  # noqa: E731
        k: xr.Variable(dims, np.asarray(v), {"long_name": ln, **({} if u is None else {"units": u})})
        for k, (dims, v, u, ln) in d.items()
    }
    return cf_dataset(xr.Dataset(make(pairs), coords=make(coords or {}), attrs=dict(attrs or {})))


def merge(*datasets):
    """The datasets as one (their coordinates must agree exactly; attributes kept where they do not conflict)."""
    import xarray as xr

    return xr.merge(list(datasets), join="exact", compat="no_conflicts", combine_attrs="drop_conflicts")


def config_attrs(config: Mapping[str, Any]) -> dict[str, str]:
    """A result's `config` as a dataset attribute: `{"config_json": JSON text}` (attributes hold no mappings)."""
    return {"config_json": json.dumps(to_jsonable(dict(config)), sort_keys=True)}


def to_jsonable(obj: Any) -> Any:
    """Arrays → lists, NaN/inf → null, −0 → 0, numpy/JAX scalars → Python numbers."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [to_jsonable(v) for v in obj]
    if hasattr(obj, "__array__") and not isinstance(obj, str | bytes):
        arr = np.asarray(obj)
        if arr.ndim == 0:
            return to_jsonable(arr.item())
        return to_jsonable(arr.tolist())
    if isinstance(obj, float):
        return obj + 0.0 if math.isfinite(obj) else None  # (+ 0.0: no "-0.0" where nothing is exceeded)
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    return obj
