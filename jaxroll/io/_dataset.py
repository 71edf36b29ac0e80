"""Labelled results: the provenance every output records, and netCDF files written completely or not at all.

Every command's numbers also go into an `xarray.Dataset` (named dimensions, `units` and `long_name` attributes on
each variable, the configuration and `provenance()` in the dataset's attributes) written by `write_dataset` with
the h5netcdf engine (netCDF4/HDF5 files; h5py also reads labs' HDF5 tank records, so one dependency serves both;
netCDF4-python would bring a second HDF5 build of its own). `output_dataset` builds a command's dataset from its
JSON payload and its results' `.to_xarray()` (docs/outputs.md).
"""

from __future__ import annotations

import importlib.metadata
import json
import math
import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from .._labels import OUTPUTS, tree_to_dataset

#: The libraries whose versions every output records (the bit-for-bit claims depend on them).
_LIBRARIES = ("jaxroll", "jax", "jaxlib", "equinox", "diffrax", "optimistix", "numpy")


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


def provenance() -> dict[str, str]:
    """What produced a result: `jaxroll_version`, `jax_version`, `jaxlib_version`, …, the JAX `backend` and the
    first device's `device_kind` (e.g. "cpu", "NVIDIA H100 80GB HBM3"), and `x64` ("true"/"false").

    **Returns:** a dict of strings (netCDF attributes and JSON fields alike). Starts JAX's backend if not started.
    """
    import jax

    out = {}
    for lib in _LIBRARIES:
        try:
            out[f"{lib}_version"] = importlib.metadata.version(lib)
        except importlib.metadata.PackageNotFoundError:  # pragma: no cover - a source tree without metadata
            out[f"{lib}_version"] = "unknown"
    out["backend"] = jax.default_backend()
    out["device_kind"] = str(jax.devices()[0].device_kind)
    out["x64"] = "true" if jax.config.jax_enable_x64 else "false"
    return out


def dataset_attrs(config: dict[str, Any] | None = None, **extra: Any) -> dict[str, str]:
    """Dataset attributes: `provenance()`, the configuration as JSON text (`config_json`; netCDF attributes
    cannot hold nested mappings) and `extra` attributes (strings or numbers)."""
    attrs: dict[str, Any] = dict(provenance())
    if config is not None:
        attrs["config_json"] = json.dumps(to_jsonable(config), sort_keys=True)
    for k, v in extra.items():
        attrs[k] = v if isinstance(v, int | float | str) else json.dumps(to_jsonable(v))
    return attrs


#: Top-level JSON fields that are not results: in the dataset's attributes instead (`config_json`, versions).
_NOT_RESULTS = ("config", "jaxroll_version", "warnings")


def output_dataset(command: str, payload: Mapping[str, Any], parts=None, *, warnings=()):
    """The labelled twin of a command's JSON file: its numbers as an `xarray.Dataset` (the variables named like
    the JSON fields, `units`, `long_name` and `json_path` on each; docs/outputs.md), plus `parts`: the result
    objects' own datasets (`.to_xarray()`: per-trial arrays, histogram counts, …) — one dataset, or a dict
    `{prefix: dataset}` whose variables are named `<prefix>_<name>` ("" for none); a list of datasets (maxima of
    groups of N0) is concatenated along `n0` first (NaN where a group has fewer trials). Variables the JSON already
    gives are taken from the JSON; a dimension of a part that the JSON labels differently is renamed
    `<prefix>_<dim>`.

    Attributes: `dataset_attrs(payload["config"])` (the configuration as JSON text, the versions of jaxroll, jax,
    jaxlib, …, the backend and device kind), `command`, `json_file`, the JSON's text fields, the `warnings`.

    **Arguments:** `command`: a key of the layouts (`"pdf"`, `"maxima"`, …, `"calibrate-decay"`); `payload`: the
    dict written as JSON.

    **Raises:** `ValueError` (internal) for a JSON field the command's layout does not describe.
    """
    import xarray as xr

    if command not in OUTPUTS:
        raise ValueError(f"no labelled layout for the output {command!r}; known: {', '.join(OUTPUTS)}.")
    layout = OUTPUTS[command]
    ds = tree_to_dataset({k: v for k, v in payload.items() if k not in _NOT_RESULTS}, layout)
    if parts is not None:
        for prefix, part in (
            parts.items() if isinstance(parts, dict) else [("", parts)]
        ):  # a Dataset is a Mapping
            if isinstance(part, list | tuple):  # the maxima of two groups of N0 (other trial counts)
                part = xr.concat(
                    list(part),
                    dim="n0",
                    data_vars="minimal",
                    coords="minimal",
                    compat="override",
                    join="outer",
                    combine_attrs="drop_conflicts",
                )
            ds = _add_part(ds, part, prefix)
    skipped = {p: "the same numbers as the arrays beside them, one record per point" for p in layout.skip}
    attrs = {
        **ds.attrs,
        **dataset_attrs(
            payload.get("config"),
            command=command.split("-")[0],
            json_file=_JSON_FILES.get(command.split("-")[0], f"{command}.json"),
        ),
    }
    if skipped:
        attrs["json_fields_not_stored"] = json.dumps(skipped)
    if warnings:
        attrs["warnings"] = json.dumps(list(warnings))
    return xr.Dataset(ds.data_vars, coords=ds.coords, attrs=attrs)


_JSON_FILES = {"calibrate": "calibration.json"}


#: Dimensions that mean the same in every part of a dataset (when their labels agree).
_SHARED_DIMS = ("estimator", "percentile", "bound", "n0", "theory", "parameter", "parameter_2", "bins_deg")


def _add_part(ds, part, prefix: str):
    """`ds` with the variables of `part` it does not have, named `<prefix>_<name>`; a dimension of the part is
    renamed `<prefix>_<dim>` unless `ds` has it with the same labels and it means the same everywhere."""
    import numpy as np
    import xarray as xr

    def same(dim) -> bool:
        return (
            dim in ds.dims
            and ds.sizes[dim] == part.sizes[dim]
            and (
                dim not in ds.coords
                or dim not in part.coords
                or np.array_equal(ds[dim].values, part[dim].values)
            )
        )

    lead = prefix or "part"
    rename = {
        d: f"{lead}_{d}"
        for d in part.dims
        if not same(d) and (d in ds.dims or (prefix and d not in _SHARED_DIMS))
    }
    part = part.rename(rename)
    names = {n: (f"{prefix}_{n}" if prefix else n) for n in part.data_vars}
    new = [names[n] for n in part.data_vars if names[n] not in ds.variables]
    part = part.rename({k: v for k, v in names.items() if k != v})[new]
    for name in part.variables:  # a part's own JSON paths are not the command's JSON's
        part[name].attrs.pop("json_path", None)
    return xr.merge([ds, part], join="exact", compat="override", combine_attrs="override")


def write_dataset(path: str | os.PathLike, dataset) -> None:
    """Write an `xarray.Dataset` to `path` (netCDF4/HDF5 via h5netcdf) completely or not at all: into a temporary
    file in the same folder, renamed into place once it is whole. Boolean variables are stored as int8 with a
    `dtype: bool` attribute (netCDF has no boolean type)."""
    from .._atomic import atomic_write

    ds = dataset.copy()
    for name, var in ds.variables.items():
        if var.dtype == bool:
            ds[name] = var.astype("int8")
            ds[name].attrs.update({**var.attrs, "dtype": "bool"})
    atomic_write(path, lambda tmp: ds.to_netcdf(tmp, engine="h5netcdf"))


def read_dataset(path: str | os.PathLike):
    """Open a netCDF file written by `write_dataset` as an `xarray.Dataset` (loaded into memory, file closed),
    with the boolean variables restored."""
    import xarray as xr

    with xr.open_dataset(path, engine="h5netcdf") as ds:
        ds = ds.load()
    for name, var in ds.variables.items():
        if var.attrs.get("dtype") == "bool":
            attrs = {k: v for k, v in var.attrs.items() if k != "dtype"}
            ds[name] = var.astype(bool)
            ds[name].attrs.update(attrs)
    return ds
