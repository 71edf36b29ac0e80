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


#: The measured wave's 4σ against the header's H1/3, per sea state: beyond a factor of `WAVE_HEIGHT_REFUSE` either
#: way the records are refused (no tank misses its sea state by that much; a unit slip does: ×1000 for a column in
#: mm labelled m, ×λ for full-scale values in a model-scale file), beyond `WAVE_HEIGHT_WARN` a warning (tank seas
#: come within 5-10 % of the target; the pooled 4σ of one 270 s record scatters by ~5 %).
WAVE_HEIGHT_REFUSE = 3.0
WAVE_HEIGHT_WARN = 1.25


def _likely_slip(ratio: float, scale: float) -> str:
    """The unit slip whose factor is within 30 % of `ratio` (measured / header), in words, or ''."""
    candidates = (
        (1e3, "a wave column in mm labelled m (set its unit to mm in `units`)"),
        (1e-3, "a wave column in m labelled mm (set its unit to m in `units`)"),
        (10.0, "a wave column in cm labelled mm, or H1/3 in the header at model scale"),
        (
            scale,
            f"full-scale wave values in a model-scale file (scale λ = {scale:g}): the loader multiplies by λ",
        ),
        (1 / scale, f"a header H1/3 at model scale (λ = {scale:g}): `wave_height_full_m` is full scale"),
    )
    for factor, words in candidates:
        if factor != 1 and abs(math.log(ratio / factor)) < math.log(1.3):
            return f"; likely {words}"
    return ""


def check_wave_heights(
    records: Sequence[Record], window_model_s: tuple[float, float] | None = None, *, warn: bool = True
) -> list[dict]:
    """Compare each sea state's header H1/3 with 4σ of its records' measured wave (full scale), pooled over the
    records of the sea state within `window_model_s` [s, model scale] (default the paper's 70–340 s; a record that
    does not cover it is taken whole), each about its own mean.

    **Returns:** one dict per sea state: `hs_header_m`, `hs_measured_m` (4σ), `ratio`, `n_records`.

    **Raises:** `RecordError` when the two differ by more than a factor `WAVE_HEIGHT_REFUSE` (a unit slip; the
    message gives both numbers and the slip that fits). A `UserWarning` beyond `WAVE_HEIGHT_WARN` (with `warn`).
    """
    import warnings

    lo, hi = PAPER_WINDOW_MODEL_S if window_model_s is None else window_model_s
    groups: dict[tuple[float, float], list[Record]] = {}
    for r in records:
        if "wave" in r.channels:
            groups.setdefault(r.sea_state, []).append(r)
    out = []
    for (hs, t01), recs in groups.items():
        squares, count = 0.0, 0
        for r in recs:
            t = r.model_time
            tol = 0.5 / float(r.meta["sampling_hz"])
            keep = (
                (t >= lo - tol) & (t <= hi + tol) if (t[0] <= lo + tol and t[-1] >= hi - tol) else slice(None)
            )
            w = np.asarray(r.wave)[keep]
            squares += float(np.sum((w - w.mean()) ** 2))
            count += w.size
        measured = 4 * math.sqrt(squares / max(count, 1))
        ratio = measured / hs
        where = recs[0].source + (
            f" (and {len(recs) - 1} other record(s) of this sea state)" if len(recs) > 1 else ""
        )
        text = (
            f"{where}: 4σ of the measured wave is {measured:.4g} m (full scale) but the header says H1/3 = {hs:g} m "
            f"(T01 = {t01:g} s): {ratio:.3g} × the header's"
        )
        if not 1 / WAVE_HEIGHT_REFUSE <= ratio <= WAVE_HEIGHT_REFUSE:
            raise RecordError(
                f"{text}{_likely_slip(ratio, recs[0].scale)}. No tank misses its sea state by that much; check the "
                "wave column's unit in `units` and the header's `wave_height_full_m` (docs/records.md)."
            )
        if warn and not 1 / WAVE_HEIGHT_WARN <= ratio <= WAVE_HEIGHT_WARN:
            warnings.warn(
                f"{text}. This warning appears because the measured sea differs from the header's by more than "
                f"{WAVE_HEIGHT_WARN - 1:.0%}: the fit uses the header's sea state where it simulates the sea "
                "(--estimator pdf) and the measured wave elsewhere; check `wave_height_full_m`.",
                stacklevel=3,
            )
        out.append(
            {
                "hs_header_m": hs,
                "t01_s": t01,
                "hs_measured_m": measured,
                "ratio": ratio,
                "n_records": len(recs),
            }
        )
    return out
