"""A decay record as a lab hands it over, made ready for a fit: the part analysed (from the release, found
automatically, or from a given start; to a given stop), the roll offset, and a check of the angle unit.

Times given by the user are in **model-scale seconds of the record's own time column** (as in the file), like
`Record.window` and the `--window` of the other calibrations (docs/calibration.md, "Records as labs hand them
over").

Release: a decay test starts with the model at rest (upright, or held at its heel), is heeled by hand and let go;
the largest deviation from the record's median is the release (or the end of the plateau where the model was held
there), and everything before it is not a decay.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..io._records import Record, RecordError
from ._inputs import _noise_std, check_roll_unit, roll_offset


@dataclasses.dataclass(frozen=True)
class DecaySegment:
    """The analysed part of one decay record.

    - `record`: the record as given; `analysed`: from `start` to the stop, the roll as measured [rad].
    - `start_model_s`: the first analysed sample [s, model scale, the record's time]; `released`: True when it is
      the release found in the record (False: a start given by the user).
    - `stop_model_s`: the last analysed sample [s, model scale].
    - `offset`: first estimate of the roll offset [rad] (the level the decay settles about).
    - `peak`: |φ(start) − offset| [rad].
    """

    record: Record
    analysed: Record
    start_model_s: float
    stop_model_s: float
    released: bool
    offset: float
    peak: float

    def config(self) -> dict:
        """JSON-ready: where the analysis starts and stops [s, model scale] and why."""
        return {
            "source": self.record.source,
            "start_model_s": self.start_model_s,
            "stop_model_s": self.stop_model_s,
            "start_from": "release found" if self.released else "start given",
        }


def find_release(record: Record) -> int:
    """Index of the release of a decay record: the last sample of the largest deviation from the record's median
    (the end of the plateau when the model was held heeled; within 5 noise std or 0.2 % of the peak)."""
    phi = np.asarray(record.roll, dtype=float)
    d = np.abs(phi - np.median(phi))
    i = int(np.argmax(d))
    threshold = d[i] - max(5 * _noise_std(phi), 0.002 * d[i])
    below = np.nonzero(d[i:] < threshold)[0]
    return i + int(below[0]) - 1 if below.size else i


def _slice(record: Record, a: int, b: int) -> Record:
    return dataclasses.replace(
        record,
        time=record.time[a:b],
        channels={k: v[a:b] for k, v in record.channels.items()},
        lines=None if record.lines is None else record.lines[a:b],
    )


def _index(record: Record, t_model: float, name: str) -> int:
    record.check_model_time(t_model, name)
    tm = record.model_time
    tol = 0.5 / float(record.meta["sampling_hz"])
    return int(np.clip(np.searchsorted(tm, t_model - tol), 0, tm.size - 1))


def decay_segment(
    record: Record, *, start_model_s: float | None = None, stop_model_s: float | None = None
) -> DecaySegment:
    """The analysed part of a decay record: from `start_model_s` [s, model scale, the record's time] if given,
    else from the release found in the record (`find_release`), to `stop_model_s` (default: the end).

    **Raises:** `RecordError` for a start or stop outside the record, a stop before the start, or fewer than 16
    samples between them."""
    n = record.time.size
    stop = n if stop_model_s is None else _index(record, stop_model_s, "stop") + 1
    if start_model_s is not None:
        start = _index(record, start_model_s, "start")
        released = False
    else:
        start = find_release(_slice(record, 0, stop))
        released = True
    if stop - start < 16:
        raise RecordError(
            f"{record.source}: the analysis from {record.model_time[min(start, n - 1)]:.3f} s to "
            f"{record.model_time[stop - 1]:.3f} s (model scale) leaves {max(stop - start, 0)} samples; at least 16 "
            "are needed (check --start/--stop)."
        )
    analysed = _slice(record, start, stop)
    offset = roll_offset(analysed.roll)
    return DecaySegment(
        record,
        analysed,
        float(record.model_time[start]),
        float(record.model_time[stop - 1]),
        released,
        offset,
        abs(float(analysed.roll[0]) - offset),
    )


def check_angle_unit(segment: DecaySegment) -> str | None:
    """A warning (also returned) when the decay's amplitude says the roll unit is wrong (`check_roll_unit`)."""
    return check_roll_unit(segment.peak, segment.record.source, "the decay starts at", "decay test")
