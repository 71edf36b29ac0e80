"""The work units of `longterm`: which cells a part computes (`_responsible_cells`, with the zero-speed mirror
classes `_twin`), a unit's checkpoint file (`_load_unit`, `_save_unit`, named by the hash of its inputs), and the
results gathered across processes (`_gather`)."""

from __future__ import annotations

import hashlib
import json
import warnings
from pathlib import Path

import jax
import numpy as np

from .. import _cache_files as files
from .._atomic import atomic_write_bytes
from ._cells import worker_of


def _hash(spec: dict) -> str:
    return hashlib.sha256(json.dumps(spec, sort_keys=True, default=str).encode()).hexdigest()[:20]


def _load_unit(checkpoint, name: str):
    """The arrays a unit saved under `name` in the `checkpoint` folder, or None: no checkpoint, or none for this unit
    yet, or — with a warning, the unit then computed again — a file that is unreadable, edited (its digest), of
    another unit or other jaxroll/JAX versions, or writable by others (`_cache_files.read_entry`)."""
    if checkpoint is None:
        return None
    path = Path(checkpoint) / f"{name}.npz"
    if not path.exists():
        return None
    if not path.is_file():  # a FIFO there hung the run (issue 45); `_save_unit` replaces it
        warnings.warn(
            f"checkpoint file {path} is not a regular file (a FIFO, a device or a folder); computing that unit "
            "again.",
            stacklevel=3,
        )
        return None
    members = files.read_entry(path, name)
    if members is None:
        warnings.warn(
            f"checkpoint file {path} is unreadable, changed since jaxroll wrote it, written by other jaxroll/JAX "
            "versions or writable by others; computing that unit again.",
            stacklevel=3,
        )
    return members


def _save_unit(checkpoint, name: str, arrays: dict) -> None:
    """Save a unit's arrays as a verified entry (digest, unit name, versions; `_cache_files.entry_bytes`)."""
    if checkpoint is None:
        return
    atomic_write_bytes(Path(checkpoint) / f"{name}.npz", files.entry_bytes(name, arrays), name_errors=True)


def _gather(arrays: dict, mine: np.ndarray) -> dict:
    """Across processes (`jax.distributed`): each entry taken from the process that computed the cell (`mine`,
    over the leading cell axes). One process: unchanged."""
    if jax.process_count() == 1:
        return arrays
    from jax.experimental import multihost_utils

    masks = np.asarray(multihost_utils.process_allgather(mine.astype(np.int8)))
    out = {}
    for k, v in arrays.items():
        allv = np.asarray(multihost_utils.process_allgather(v))
        m = masks.reshape(masks.shape + (1,) * (allv.ndim - masks.ndim)).astype(bool)
        out[k] = (
            np.where(m, allv, 0).sum(axis=0).astype(v.dtype) if v.dtype != bool else (m & allv).any(axis=0)
        )
    return out


def _twin(grid, k: int, u: int) -> int:
    """The heading class whose theory unit computes class `k` at speed `u`: itself, or at zero speed the class
    180° − χ' where the grid has it (with no forward speed the encounter frequency is the wave's, and Grim's
    effective wave depends on the heading through cos²-even terms only, so χ' and 180° − χ' are one problem; the
    class with the smaller heading computes it)."""
    if grid.speeds[u] != 0.0:
        return k
    mirror = round(180.0 - float(grid.classes_deg[k]), 9)
    hit = np.flatnonzero(grid.classes_deg == mirror)
    return int(hit[0]) if hit.size and mirror < grid.classes_deg[k] else k


def _responsible_cells(grid, units, cells_mask, workers, i_part, n_proc) -> np.ndarray:
    """Cells of `cells_mask` in theory units this part (any of its processes) is responsible for (with the
    classes a unit computes as well, `_twin`)."""
    out = np.zeros(cells_mask.shape, bool)
    ours = {(i_part - 1) * n_proc + q for q in range(n_proc)}
    for j, (s, k, u) in enumerate(units):
        if worker_of(j, workers) in ours:
            for k2 in range(cells_mask.shape[1]):
                if _twin(grid, k2, u) == k:
                    out[s, k2, u] = cells_mask[s, k2, u]
    return out
