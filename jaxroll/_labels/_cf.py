"""Labelled results as the CF conventions and the tools that read them expect: one UDUNITS unit style, CF standard
names where CF has one, and a command's inputs as coordinates (docs/outputs.md, "As CF tools read them").

No numerics; xarray is imported only when a dataset is built.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

from ._units import udunits

#: The CF version the files follow (global attribute `Conventions`). 1.10 (2022): its standard-name table has every
#: name below, and nothing jaxroll writes needs a later version's features.
CONVENTIONS = "CF-1.10"

#: Variable or coordinate name → CF standard name (CF standard-name table): the sea state, the ship's speed through
#: the water, the water's density, and the Monte Carlo's trials (CF's `realization`: a member of an ensemble).
STANDARD_NAMES = {
    "hs": "sea_surface_wave_significant_height",
    "hs_m": "sea_surface_wave_significant_height",
    "t01": "sea_surface_wave_mean_period_from_variance_spectral_density_first_frequency_moment",
    "t01_s": "sea_surface_wave_mean_period_from_variance_spectral_density_first_frequency_moment",
    "tz": "sea_surface_wave_mean_period_from_variance_spectral_density_second_frequency_moment",
    "speed": "platform_speed_wrt_sea_water",
    "speed_m_s": "platform_speed_wrt_sea_water",
    "water_density_kg_m3": "sea_water_density",
    "realization": "realization",
}


def _is_mixed(units: str) -> bool:
    return units.startswith("mixed")


def cf_dataset(ds):
    """`ds` with CF attributes on every variable: `units` in UDUNITS form (`udunits`); a variable whose labels
    have different units (`"mixed: …"`) gets no `units` but that text as its `comment`, and its `unit`-coordinate
    labels in UDUNITS form too; a `standard_name` where `STANDARD_NAMES` has one. The dataset is changed in place
    and returned."""
    import numpy as np

    for name, var in ds.variables.items():
        units = var.attrs.get("units")
        if isinstance(units, str):
            if _is_mixed(units):
                del var.attrs["units"]
                var.attrs["comment"] = "units: " + units
            else:
                var.attrs["units"] = udunits(units)
        if (name == "unit" or str(name).endswith("_unit")) and var.dtype.kind in "UO":  # each label's unit
            labels = [udunits(str(u)) for u in var.values.ravel()]
            var.values = np.asarray(labels, dtype=object).reshape(var.shape)
        if name in STANDARD_NAMES and var.dtype.kind in "fiu":
            var.attrs.setdefault("standard_name", STANDARD_NAMES[name])
    return ds


#: A command's inputs that become coordinates: (dimension name, where in the JSON's `config`, units, long name).
INPUTS = (
    ("hs_m", ("sea", "hs_m"), "m", "significant wave height H1/3 (input)"),
    ("t01_s", ("sea", "t01_s"), "s", "mean wave period T01 (input)"),
    ("heading_deg", ("heading_deg",), "degree", "heading χ: 0 following, 90 beam, 180 head (input)"),
    ("speed_m_s", ("speed_m_s",), "m s-1", "ship speed U (input)"),
    ("seed", ("seed",), "1", "random seed of the Monte Carlo (input)"),
    ("ship", ("ship", "name"), None, "ship (its name; its coefficients in run_config)"),
)


def _lookup(config: Mapping[str, Any], path: tuple[str, ...]):
    node: Any = config
    for key in path:
        if not isinstance(node, Mapping) or key not in node:
            return None
        node = node[key]
    return node


def with_inputs(ds, config: Mapping[str, Any] | None):
    """`ds` with the run's inputs as length-1 dimensions on every data variable (`hs_m`, `t01_s`, `heading_deg`,
    `speed_m_s`, `seed`, `ship`: those its `config` gives as a number, or for `ship` a name, and that `ds` does not
    already have), so that `xarray.combine_by_coords` lays runs of other inputs side by side, and the
    configuration as the text variable `run_config` on them, so that every run's configuration survives
    `xarray.concat`/`combine_by_coords`. The dimensions' names are in the attribute `input_dims`."""
    import numpy as np
    import xarray as xr

    from ._tree import to_jsonable

    if config is None:
        return ds
    dims, coords = [], {}
    for dim, path, units, long_name in INPUTS:
        value = _lookup(config, path)
        if dim in ds.variables or dim in ds.dims:
            continue
        if dim == "ship":
            if not isinstance(value, str):
                continue
            data = np.array([value], dtype=object)
        elif isinstance(value, bool) or not isinstance(value, int | float):
            continue
        else:
            data = np.array([value])
        attrs = {"long_name": long_name, **({} if units is None else {"units": units})}
        if dim in STANDARD_NAMES:
            attrs["standard_name"] = STANDARD_NAMES[dim]
        dims.append(dim)
        coords[dim] = xr.Variable((dim,), data, attrs)
    out = ds.expand_dims({d: 1 for d in dims}) if dims else ds.copy()
    out = out.assign_coords({d: coords[d] for d in dims})
    text = json.dumps(to_jsonable(dict(config)), sort_keys=True)
    out["run_config"] = xr.Variable(
        tuple(dims),
        np.full((1,) * len(dims), text, dtype=object),
        {"long_name": "the run's configuration as JSON text (the attribute config_json, kept per run)"},
    )
    out.attrs["input_dims"] = " ".join(dims)
    return out
