"""What produced a result (versions, backend, device) and JSON-ready values: every output records them."""

from __future__ import annotations

import importlib.metadata
import json
import math
from typing import Any

import numpy as np

#: The libraries whose versions every output records (the bit-for-bit claims depend on them).
_LIBRARIES = ("jaxroll", "jax", "jaxlib", "equinox", "diffrax", "optimistix", "numpy")


def to_jsonable(obj: Any) -> Any:
    """Arrays → lists, NaN/inf → null, numpy/JAX scalars → Python numbers."""
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
        return obj if math.isfinite(obj) else None
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
