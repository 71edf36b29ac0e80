"""What every calibration fit does with its records first: a list of records of one kind, the paper's analysis
window, the sensor noise of a record."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..io._records import Record, RecordError

#: The paper's analysis window of the irregular-wave tank tests [s, model scale, from the wave maker's start].
PAPER_WINDOW_MODEL_S = (70.0, 340.0)


def _as_list(records) -> list[Record]:
    if isinstance(records, Record):
        return [records]
    records = list(records)
    if not records:
        raise ValueError("no records given.")
    return records


def _check_kind(records: Sequence[Record], kind: str) -> None:
    for r in records:
        if r.kind != kind:
            raise RecordError(f"{r.source}: a {kind} record is needed here; this is a {r.kind} record.")


def _noise_std(x: np.ndarray, order: int = 6) -> float:
    """Std of white measurement noise on a smooth, well-sampled series: the robust (MAD) std of its
    `order`-th difference divided by √C(2·order, order). A sinusoid sampled 20 times per period contributes
    (2π/20)⁶ ≈ 1e-3 of its amplitude to the sixth difference, so the signal does not leak into it."""
    d = np.diff(np.asarray(x, dtype=float), n=order)
    mad = np.median(np.abs(d - np.median(d)))
    return float(1.482602 * mad / math.sqrt(math.comb(2 * order, order)))
