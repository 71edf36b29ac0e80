"""Labelled results: results as `xarray.Dataset`s with named dimensions, units and long names (infrastructure every
stage may use: no numerics; xarray is imported only when a dataset is built)."""

from ._cf import (
    CONVENTIONS as CONVENTIONS,
    cf_dataset as cf_dataset,
    udunits as udunits,
    with_inputs as with_inputs,
)
from ._layouts import OUTPUTS as OUTPUTS
from ._tree import (
    Layout as Layout,
    config_attrs as config_attrs,
    labelled_values as labelled_values,
    merge as merge,
    to_jsonable as to_jsonable,
    tree_to_dataset as tree_to_dataset,
)
