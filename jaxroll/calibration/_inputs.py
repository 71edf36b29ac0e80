"""What every calibration fit does with its records first: a list of records of one kind, the paper's analysis
window, the sensor noise of a record, and records as labs hand them over — the rest before the test, a roll
offset, an angle unit that the amplitudes contradict (`lab_records`; a decay's own release: `_decay_inputs`)."""

from __future__ import annotations

import dataclasses
import math
import warnings
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


def _offset_terms(phi: np.ndarray) -> np.ndarray:
    """(φ_n + 2φ_{n+1} + φ_{n+2})/4 over the extremes of φ between hysteresis crossings [rad] (each cancels an
    amplitude that grows or decays linearly); empty when there are fewer than three extremes."""
    x = phi - float(np.median(phi))
    h = max(3 * _noise_std(phi), 0.02 * float(np.max(np.abs(x))))
    s = np.sign(x[0]) or 1.0
    idx = []
    best = 0
    for i, v in enumerate(x):  # extremes between hysteresis crossings
        if s * v < -h:
            idx.append(best)
            s, best = -s, i
        elif s * v > s * x[best]:
            best = i
    ext = phi[idx]
    return (ext[:-2] + 2 * ext[1:-1] + ext[2:]) / 4 if ext.size >= 3 else np.zeros(0)


def roll_offset(phi: np.ndarray) -> float:
    """The level a roll oscillates about [rad] (a model heeled by a fraction of a degree): the median of
    (φ_n + 2φ_{n+1} + φ_{n+2})/4 over its extremes (`_offset_terms`), or the median of φ when there are fewer than
    three extremes."""
    phi = np.asarray(phi, dtype=float)
    terms = _offset_terms(phi)
    return float(np.median(terms)) if terms.size else float(np.median(phi))


def check_roll_unit(peak: float, source: str, subject: str, test: str) -> str | None:
    """A warning (also returned) when a roll amplitude `peak` [rad] says the angle unit is wrong: tank tests roll
    from a few degrees to a few tens, so a peak under 1° that would be 2–60° read as radians is radians labelled
    degrees, and one over 45° probably degrees labelled radians (beyond 90° the loaders refuse it). `subject`
    ("the decay starts at", "the roll reaches") and `test` ("decay test") word the message."""
    deg = math.degrees(peak)
    message = None
    if deg < 1.0 and 2.0 <= math.degrees(deg) <= 60.0:
        message = (
            f"{source}: {subject} only {deg:.3g}°; if the roll column is in radians labelled degrees it would be "
            f"{math.degrees(deg):.3g}°, a usual {test} — check the roll unit (CLI --units roll=rad or --units-file)."
        )
    elif deg > 45.0:
        message = (
            f"{source}: {subject} {deg:.3g}°, beyond any {test}; if the roll column is in degrees labelled radians "
            f"it would be {math.radians(deg):.3g}° — check the roll unit (CLI --units roll=deg)."
        )
    if message:
        warnings.warn(message, stacklevel=3)
    return message


def waves_arrive(record: Record) -> int:
    """Index of the first sample after the rest at the start of a captive or free-running record (the tank calm
    before the waves reach the probe): the first where the wave (without one, the roll) leaves its median by more
    than 5 noise std and 0.2 of its std. 0 or a few samples for a record in waves from its start."""
    x = np.asarray(record.wave if "wave" in record.channels else record.roll, dtype=float)
    above = np.nonzero(np.abs(x - np.median(x)) > max(5 * _noise_std(x), 0.2 * float(np.std(x))))[0]
    return int(above[0]) if above.size else 0


def lab_records(records: Sequence[Record], windows_model_s) -> list[Record]:
    """Captive and free-running records as labs hand them over, made ready for a fit (a decay's: `decay_segment`),
    each within its analysis window (`windows_model_s`: one (start, stop) [s, model scale, the record's own time]
    or one per record):

    - the rest before the waves reach the probe found (`waves_arrive`): a `UserWarning` when the window starts
      more than a wave period inside it (the calm part would enter the statistics);
    - roll records: the roll offset removed where it is significant (`roll_offset` over the window after the
      rest, beyond 3 standard errors; what was removed in `meta["roll_offset_deg"]`, else 0) and the angle unit checked against the largest roll excursion of all
      the records (`check_roll_unit`: one record below the parametric-roll threshold may roll under 1°, a test's
      set of records does not).

    **Returns:** the records (roll about its offset); the others unchanged."""
    out, peaks = [], []
    for k, r in enumerate(records):
        lo, hi = windows_model_s if np.ndim(windows_model_s) == 1 else windows_model_s[k]
        t = r.model_time
        t_arrive = float(t[waves_arrive(r)])
        period = r.wave_period / math.sqrt(r.scale) if "wave_period_full_s" in r.meta else 0.0
        if t_arrive - t[0] > period and lo < t_arrive - period:
            warnings.warn(
                f"{r.source}: the tank is calm until {t_arrive:.1f} s (model scale), when the waves reach the probe; "
                f"the analysis window starts at {lo:g} s, inside that rest: give a later --start (or --window; "
                "every time in model-scale seconds of the record's own time).",
                stacklevel=3,
            )
        if "roll" not in r.channels:
            out.append(r)
            continue
        keep = (t >= max(lo, t_arrive)) & (t <= hi)
        phi = np.asarray(r.roll, dtype=float)
        terms = _offset_terms(phi[keep]) if keep.sum() > 16 else np.zeros(0)
        offset = float(np.median(terms)) if terms.size > 8 else 0.0
        # removed where it is significant: > 3 standard errors of the median (neighbouring terms share extremes)
        se = 1.2533 * float(np.std(terms)) / math.sqrt(terms.size / 2) if terms.size > 8 else math.inf
        offset = offset if abs(offset) > 3 * se else 0.0
        peaks.append((float(np.max(np.abs(phi[keep] - offset), initial=0.0)), r.source))
        out.append(
            dataclasses.replace(
                r,
                channels={**r.channels, "roll": phi - offset},
                meta={**r.meta, "roll_offset_deg": math.degrees(offset)},
            )
        )
    if (
        peaks
    ):  # one unit for a test's records: one below the parametric-roll threshold may roll under 1°, not all
        subject = "the roll reaches" if len(peaks) == 1 else "the largest roll of the records reaches"
        check_roll_unit(*max(peaks), subject, "tank test")
    return out
