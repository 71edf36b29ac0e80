"""Wave scatter diagrams: occurrences of sea states by significant wave height H_s and zero-upcrossing period T_z.

The file layout is that of IACS Rec. 34 and DNV-RP-C205 tables: a first row `hs_m,<Tz1>,<Tz2>,…` (T_z [s] of the
columns), then one row per H_s [m] with its counts (any non-negative numbers; they are normalised). Lines starting
with `#` and blank lines are comments. IACS Rec. 34 (North Atlantic) is shipped (`rec34_scatter`).

Every problem with a file is a `ScatterError` (a `ValueError`) whose message names the file and the line.
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path

import numpy as np

#: T01/T_z = π^{1/4}/Γ(3/4) = 1.0864 for the ITTC (two-parameter Bretschneider) spectrum A ω⁻⁵ exp(−B ω⁻⁴):
#: m_n ∝ B^{n/4} Γ(1 − n/4), so T01 = 2π m0/m1 and T_z = 2π (m0/m2)^{1/2} give T01/T_z = Γ(1/2)^{1/2}/Γ(3/4)
#: (tests/test_longterm.py checks it against the moments of `jaxroll.ITTC` by quadrature).
T01_OVER_TZ = math.pi**0.25 / math.gamma(0.75)

#: The zero-upcrossing periods [s] a scatter file may hold: the ITTC spectrum of wind seas and swell describes
#: T_z from about 1 s (a wavelength of 1.6 m) to well under 30 s; a number outside is almost surely a unit error
#: (minutes, a frequency) or a peak period table beyond any sea.
TZ_RANGE = (1.0, 30.0)
#: Significant wave heights [m] a scatter file may hold (the largest ever measured are about 20 m).
HS_MAX = 30.0
#: The steepest sea state a file may give a non-zero count: significant steepness S = 2π H_s/(g T_z²) below 1/5.
#: Real seas stay below about 1/10 (DNV-RP-C205: 1/10 at T_z ≤ 6 s to 1/15 at T_z ≥ 12 s), but the class centres of
#: a coarse table reach further (IACS Rec. 34: H_s 9.5 m at T_z 6.5 s, S = 0.144); 1/5 refuses only what no sea
#: can be: H_s in feet read as metres, or H_s and T_z swapped.
MAX_STEEPNESS = 1.0 / 5.0
GRAVITY = 9.80665

REC34 = "rec34"
_PACKAGED = {REC34: "rec34.csv"}


class ScatterError(ValueError):
    """A scatter-diagram file that cannot be used; the message names the file and the line."""


@dataclasses.dataclass(frozen=True)
class ScatterDiagram:
    """Occurrences of sea states: `counts[i, j]` of H_s = `hs[i]` [m] and T_z = `tz[j]` [s] (class centres, both
    increasing). `name`: "rec34" or the file's name; `source`: where it was read (the file path, or the packaged
    table's citation)."""

    hs: np.ndarray
    tz: np.ndarray
    counts: np.ndarray
    name: str
    source: str

    @property
    def t01(self) -> np.ndarray:
        """Mean periods T01 = 1.0864 T_z [s] of the columns (ITTC spectrum, `T01_OVER_TZ`)."""
        return T01_OVER_TZ * self.tz

    @property
    def probability(self) -> np.ndarray:
        """Occurrence probabilities [-], summing to 1."""
        c = self.counts / self.counts.max()  # (counts of 1e308 would sum to inf, and every probability to 0)
        return c / c.sum()

    @property
    def total(self) -> float:
        """The sum of the occurrences (the table's total count, e.g. 100 000 for Rec. 34) [-]."""
        return float(self.counts.sum())


def _number(text: str, where: str, what: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ScatterError(
            f"{where}: {what} {text.strip()!r} is not a number. A scatter file has the layout "
            "'hs_m,<Tz1>,<Tz2>,…' then one row per H_s: 'H_s,count,count,…' (no sum row or column, no text)."
        ) from None


def parse_scatter(text: str, source: str) -> ScatterDiagram:
    """A `ScatterDiagram` from the text of a scatter file; `source` names it in messages (`FILE:LINE: …`).

    **Raises:** `ScatterError` for a wrong layout (header, ragged rows, text), a T_z or H_s outside the sensible
    range (`TZ_RANGE`, (0, `HS_MAX`]), a sea state steeper than 1/5 with a non-zero count, negative, NaN or
    infinite counts, duplicate H_s rows or T_z columns, or counts that are all zero.
    """
    rows = [(n, line.strip()) for n, line in enumerate(text.splitlines(), 1)]
    rows = [(n, line) for n, line in rows if line and not line.startswith("#")]
    layout = "the first row must be 'hs_m,<Tz1>,<Tz2>,…' (T_z [s] of each column), then one row per H_s [m]"
    if not rows:
        raise ScatterError(f"{source}: no data ({layout}).")
    n0, header = rows[0]
    fields = [f.strip() for f in header.split(",")]
    if fields[0].lower() != "hs_m" or len(fields) < 2:
        raise ScatterError(f"{source}:{n0}: {layout}; got {header[:80]!r}.")
    tz = np.array([_number(f, f"{source}:{n0}", "the T_z") for f in fields[1:]])
    lo, hi = TZ_RANGE
    for t in tz:
        if not (lo <= t <= hi):
            raise ScatterError(
                f"{source}:{n0}: T_z = {t:g} s is outside the sensible range [{lo:g}, {hi:g}] s of the ITTC "
                "spectrum (zero-upcrossing periods in seconds; T01 = 1.0864 T_z is computed from them)."
            )
    if len(set(tz.tolist())) != tz.size:
        dup = sorted({t for t in tz.tolist() if tz.tolist().count(t) > 1})
        raise ScatterError(
            f"{source}:{n0}: T_z {', '.join(f'{t:g}' for t in dup)} s appears in more than one column."
        )
    if len(rows) < 2:
        raise ScatterError(f"{source}: no H_s row after the header ({layout}).")
    hs, counts, lines = [], [], {}
    for n, line in rows[1:]:
        parts = [f.strip() for f in line.split(",")]
        where = f"{source}:{n}"
        if len(parts) != tz.size + 1:
            raise ScatterError(
                f"{where}: {len(parts)} fields, but the header has {tz.size + 1} (hs_m and {tz.size} T_z): {layout}."
            )
        h = _number(parts[0], where, "the H_s")
        if not (0 < h <= HS_MAX):
            raise ScatterError(
                f"{where}: H_s = {h:g} m is outside (0, {HS_MAX:g}] m (significant wave heights in metres)."
            )
        if h in lines:
            raise ScatterError(
                f"{where}: H_s = {h:g} m repeats the row of line {lines[h]}; give each H_s once."
            )
        lines[h] = n
        row = np.array([_number(f, where, "the count") for f in parts[1:]])
        for t, c in zip(tz, row, strict=True):
            if not math.isfinite(c):
                raise ScatterError(
                    f"{where}: the count of T_z = {t:g} s is {c}; counts must be finite numbers >= 0."
                )
            if c < 0:
                raise ScatterError(
                    f"{where}: the count of T_z = {t:g} s is negative ({c:g}); counts must be >= 0."
                )
            steepness = 2 * math.pi * h / (GRAVITY * t * t)
            if c > 0 and steepness >= MAX_STEEPNESS:
                raise ScatterError(
                    f"{where}: H_s = {h:g} m with T_z = {t:g} s has a count ({c:g}) but is steeper than any sea "
                    f"(2π H_s/(g T_z²) = {steepness:.3f} >= 1/5): a T_z outside the sensible range of the "
                    "spectrum for this H_s (a unit error, or H_s and T_z swapped?)."
                )
        hs.append(h)
        counts.append(row)
    counts = np.array(counts)
    with np.errstate(over="ignore"):
        finite_sum = np.isfinite(counts.sum())
    if not finite_sum:
        raise ScatterError(
            f"{source}: the counts sum to more than the largest number ({counts.max():g} the largest count): give "
            "counts of a sensible size (they are normalised, so any common scale works)."
        )
    if not counts.sum() > 0:
        raise ScatterError(
            f"{source}: every count is zero: the scatter diagram gives no sea state any weight."
        )
    i, j = np.argsort(hs), np.argsort(tz)
    return ScatterDiagram(np.asarray(hs)[i], tz[j], counts[np.ix_(i, j)], Path(source).stem, source)


def read_scatter(path: str | os.PathLike) -> ScatterDiagram:
    """Read a scatter-diagram CSV file (module docstring: `hs_m,<Tz…>` then a row per H_s).

    **Raises:** `ScatterError` (a `ValueError`) naming the file and line; `FileNotFoundError`.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"scatter file {str(path)!r} not found (or not a file).")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as e:
        raise ScatterError(f"{path}: not a text (UTF-8) file: {e}.") from None
    return parse_scatter(text, str(path))


def rec34_scatter() -> ScatterDiagram:
    """IACS Rec. 34 (Rev.1, Corr. Nov. 2001) standard wave data, North Atlantic: 100 000 occurrences over H_s 0.5 …
    16.5 m × T_z 1.5 … 18.5 s (the packaged `jaxroll/data/scatter/rec34.csv`, whose header cites the source)."""
    path = Path(__file__).resolve().parents[1] / "data" / "scatter" / _PACKAGED[REC34]
    d = parse_scatter(path.read_text(encoding="utf-8"), str(path))
    return dataclasses.replace(
        d, name=REC34, source="IACS Recommendation No. 34 (Rev.1, Corr. Nov. 2001), Table 1"
    )


def scatter_diagram(name_or_path: str | os.PathLike | ScatterDiagram) -> ScatterDiagram:
    """`rec34` (the packaged IACS Rec. 34 table), a scatter CSV file, or a `ScatterDiagram` (returned as is)."""
    if isinstance(name_or_path, ScatterDiagram):
        return name_or_path
    if not isinstance(name_or_path, str | os.PathLike):
        raise ValueError(
            f"`scatter` must be 'rec34', the path of a scatter CSV file or a ScatterDiagram; got "
            f"{name_or_path!r} ({type(name_or_path).__name__})."
        )
    if str(name_or_path).lower() == REC34:
        return rec34_scatter()
    return read_scatter(name_or_path)
