"""What a Monte Carlo returns: reduced statistics on the host (numpy), one type per observer.

Every result counts its capsized realizations (`CapsizeCounts`): they are kept out of the amplitude statistics,
never dropped silently, and reported next to them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..extremes._risk import wilson_interval as _wilson
from ..laws._abstract import QUANTILE_LEVELS, SAMPLING, check_estimator
from ..laws._tabulated import TabulatedAmplitudeLaw, law_from_histogram


def wilson_interval(successes, trials, confidence: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """`jaxroll.wilson_interval` as numpy arrays: `(lower, upper)` of a binomial proportion."""
    lo, hi = _wilson(successes, trials, confidence)
    return np.asarray(lo), np.asarray(hi)


def quantiles_with_capsizes_deg(values_deg: np.ndarray, capsized: np.ndarray, levels=QUANTILE_LEVELS) -> dict:
    """Quantiles [deg] ({"50": …}) of per-trial values in which a capsized trial counts as beyond the angle of
    vanishing stability (+inf): `None` where a level falls among the capsizes (or no trial is given)."""
    x = np.sort(np.where(capsized, np.inf, values_deg))
    out = {}
    for q in levels:
        with np.errstate(invalid="ignore"):  # inf - inf between two capsizes
            value = float(np.quantile(x, q)) if x.size else float("nan")
        out[f"{100 * q:g}"] = value if np.isfinite(value) else None
    return out


def _realizations(result) -> dict:
    """The `realization` coordinate (index in the Monte Carlo's order) of a result's per-trial arrays."""
    n = np.asarray(result.capsized).shape[-1]
    return {
        "realization": (
            ("realization",),
            np.arange(n),
            "1",
            "realization (trial) index, in the Monte Carlo's order",
        )
    }


def _per_trial(result, dims=("realization",)) -> dict:
    """`capsized` and `capsize_time_s` per realization (`dims`), for `labelled_values`."""
    shape = tuple(len(result.n0) for _ in dims[:-1]) + (result.n_realizations,)
    return {
        "capsized": (
            dims,
            np.broadcast_to(result.capsized, shape),
            "1",
            "whether the realization capsized (|φ| beyond the angle of vanishing stability, or diverged)",
        ),
        "capsize_time_s": (
            dims,
            np.broadcast_to(result.capsize_time, shape),
            "s",
            "time of the capsize (inf: did not capsize)",
        ),
    }


class CapsizeCounts:
    """Capsize counts of a Monte Carlo result with a per-realization boolean array `capsized`."""

    capsized: np.ndarray

    @property
    def n_realizations(self) -> int:
        """Realizations run [-]."""
        return int(self.capsized.size)

    @property
    def n_capsized(self) -> int:
        """Realizations that capsized (|φ| beyond the angle of vanishing stability, or diverged) [-]."""
        return int(self.capsized.sum())

    @property
    def capsize_probability(self) -> float:
        """Fraction of realizations that capsized [-]."""
        return self.n_capsized / max(self.n_realizations, 1)

    def capsize_interval(self, confidence: float = 0.95) -> tuple[float, float]:
        """Wilson interval of the capsize probability [-]."""
        lo, hi = wilson_interval(self.n_capsized, self.n_realizations, confidence)
        return float(lo), float(hi)


_KEYS = {"zero_crossing": "zc", "envelope": "env"}

#: The roll is not stationary over a run when its mean envelope amplitude changes between the two halves of the
#: kept window by more than this fraction of the first half's and by more than `STATIONARITY_SE` standard errors
#: (`AmplitudeStatistics.stationarity`). Measured on the default ship (2000 trials, 3600 s from φ0 = 5°, the
#: halves of 500–3600 s): −60 % at H1/3 = 3 m (the roll dies out, slowly), −19 % at 4 m, −4 % at 5 m, −1 % at 6 m,
#: −0.6 % at 7 m; with no discard (10⁴ trials) −8 % at 5 m, 0.0 % at 6 m, +2.7 % at 7 m.
STATIONARITY_TOLERANCE = 0.10
STATIONARITY_SE = 3.0


def _spread_sparse_bins(counts: np.ndarray, min_count: int) -> np.ndarray:
    """Histogram counts with the sparse tail evened out: from the last occupied bin towards 0, neighbouring bins are
    grouped until each group holds at least `min_count` counts (the lowest group, if short, joins the one above it),
    and each group's count is spread evenly over its bins; empty bins beyond the last occupied one stay empty
    (nothing was seen there). The bins keep their edges, so the law's density and its masses stay consistent."""
    counts = np.asarray(counts, dtype=float)
    if min_count <= 1 or not counts.any():
        return counts
    last = int(np.nonzero(counts)[0][-1])
    groups, total, top = [], 0.0, last + 1  # (first, stop) index ranges, from the top down
    for i in range(last, -1, -1):
        total += counts[i]
        if total >= min_count:
            groups.append((i, top))
            total, top = 0.0, i
    if (
        top > 0
    ):  # the lowest bins hold fewer than min_count: they join the group above them (or form the only one)
        groups[-1:] = [(0, groups[-1][1])] if groups else [(0, top)]
    out = counts.copy()
    for a, b in groups:
        out[a:b] = counts[a:b].sum() / (b - a)
    return out


@dataclass
class AmplitudeStatistics(CapsizeCounts):
    """Reduced Monte Carlo statistics of roll amplitudes (host numpy arrays).

    `counts_*` are histograms on the fine grid `edges_deg` [deg] (the last bin also holds the amplitudes beyond the
    grid, counted separately in `beyond_grid`); per-realization arrays are in realization order. Capsized
    realizations are excluded from every amplitude statistic and counted in `capsized`.
    """

    edges_deg: np.ndarray
    counts_zero_crossing: np.ndarray
    counts_envelope: np.ndarray
    capsized: np.ndarray
    capsize_time: np.ndarray
    per_realization: dict[str, np.ndarray] = field(default_factory=dict)
    config: dict = field(default_factory=dict)

    def _repr_html_(self) -> str:
        """Jupyter's view: counts, capsizes, and each estimator's mean and quantiles [deg]."""
        from .._display import fmt_interval, html_table

        est = ("zero_crossing", "envelope")
        q = {e: np.rad2deg(self.quantiles(e)) for e in est}
        rows = [
            ("amplitudes", *(self.n_amplitudes(e) for e in est), "-"),
            ("mean amplitude", *(np.rad2deg(self.mean(e)) for e in est), "deg"),
        ]
        rows += [
            (f"{100 * level:g} % quantile", *(q[e][i] for e in est), "deg")
            for i, level in enumerate(QUANTILE_LEVELS)
        ]
        c = self.config
        note = (
            f"{self.n_realizations} realizations"
            + (f" of {c['duration_s']:g} s (dt {c['dt_s']:g} s)" if "duration_s" in c and "dt_s" in c else "")
            + f"; {self.n_capsized} capsized, P = {self.capsize_probability:.4g} "
            f"(95 % {fmt_interval(*self.capsize_interval())}); amplitude statistics conditional on no capsize."
        )
        return html_table(
            "Monte Carlo amplitude statistics",
            rows,
            header=("", "zero-crossing (per half cycle)", "envelope (per time sample)", "unit"),
            note=note,
        )

    def _counts(self, estimator: str) -> np.ndarray:
        check_estimator(estimator)
        return self.counts_zero_crossing if estimator == "zero_crossing" else self.counts_envelope

    def n_amplitudes(self, estimator: str) -> int:
        """Amplitudes counted (zero-crossing: half cycles; envelope: time samples) [-]."""
        return int(self._counts(estimator).sum())

    def mean(self, estimator: str) -> float:
        """Mean amplitude [rad] (exact: from per-realization sums, not the histogram); NaN when none."""
        key = _KEYS[check_estimator(estimator)]
        n = self.per_realization[f"n_{key}"].sum()
        return float(self.per_realization[f"sum_{key}"].sum() / n) if n else float("nan")

    def moment(self, estimator: str, order: int = 2) -> float:
        """E[Aⁿ] [rad^n] for n = 1, 2 (exact, from per-realization sums); NaN when there is no amplitude."""
        key = _KEYS[check_estimator(estimator)]
        n = self.per_realization[f"n_{key}"].sum()
        name = {1: "sum", 2: "sumsq"}[order]
        return float(self.per_realization[f"{name}_{key}"].sum() / n) if n else float("nan")

    def law(
        self, estimator: str = "zero_crossing", *, pool: int = 1, min_count: int = 1
    ) -> TabulatedAmplitudeLaw:
        """The amplitude law of the histogram (radians), labelled with what it is a law of.

        `pool` merges that many fine bins (0.05° each; e.g. 20 → 1° bins): the maximum-value formulas amplify
        histogram noise. `min_count` then groups neighbouring bins, from the last occupied one down, until each
        group holds at least that many amplitudes, and spreads each group's count evenly over its bins: a law whose
        tail has no empty bin, so that P*(A_M), which follows the density at its 1 − 1/N0 quantile, has no zeros inside the data
        (`jaxroll maxima` uses 1° bins and 10 amplitudes). Zero-crossing amplitudes give the per-half-cycle law the
        maxima and risk formulas need.

        **Raises:** `ValueError` when no amplitude survived (all capsized, or too short a run).
        """
        counts = self._counts(estimator)
        if counts.size % pool:
            raise ValueError(f"`pool` must divide the {counts.size} fine bins; got {pool}.")
        if not (isinstance(min_count, int) and min_count >= 1):
            raise ValueError(f"`min_count` must be an integer >= 1; got {min_count!r}.")
        counts = _spread_sparse_bins(counts.reshape(-1, pool).sum(1), min_count)
        return law_from_histogram(
            counts,
            np.deg2rad(self.edges_deg[::pool]),
            estimator=estimator,
            n_samples=int(round(counts.sum())),
        )

    def quantiles(self, estimator: str, levels=QUANTILE_LEVELS) -> np.ndarray:
        """Quantiles [rad] of the amplitude (linear within the fine bins, ±half a fine bin); NaN when none."""
        counts = self._counts(estimator)
        if counts.sum() == 0:
            return np.full(len(levels), np.nan)
        cdf = np.concatenate([[0.0], np.cumsum(counts)]) / counts.sum()
        return np.deg2rad(np.interp(np.asarray(levels, dtype=float), cdf, self.edges_deg))

    def pdf_per_degree(self, estimator: str, bins_deg: np.ndarray) -> np.ndarray:
        """Density per degree on `bins_deg` [deg] (edges that are a subset of the fine edges), integrating to 1
        over the grid (zero everywhere when there is no amplitude)."""
        counts = self._counts(estimator)
        cum = np.concatenate([[0.0], np.cumsum(counts)])
        bins_deg = np.asarray(bins_deg, dtype=float)
        idx = np.searchsorted(self.edges_deg, bins_deg - 1e-9 * (self.edges_deg[1] - self.edges_deg[0]))
        if not np.allclose(self.edges_deg[np.clip(idx, 0, self.edges_deg.size - 1)], bins_deg, atol=1e-9):
            raise ValueError("`bins_deg` must be edges of the fine histogram grid (multiples of its width).")
        return np.diff(cum[idx]) / max(counts.sum(), 1) / np.diff(bins_deg)

    def summary(self, bins_deg) -> dict:
        """The amplitude statistics as plain numbers on `bins_deg` (the `pdf.json` fields; angles in degrees).

        Every amplitude statistic is conditional on no capsize (capsized realizations are counted, not used).
        An estimator with no amplitude (all realizations capsized, a run shorter than a roll period, or a roll
        that never left zero) gets None for its PDF, mean, quantiles and `mass_beyond_grid`, and `reason` says
        why (None when every statistic is present). `mass_beyond_grid` is the fraction of amplitudes beyond the
        last edge of `bins_deg` (the PDF integrates to 1 minus it).
        """
        bins_deg = np.asarray(bins_deg, dtype=float)
        out: dict = {"bins_deg": bins_deg}
        n = {e: self.n_amplitudes(e) for e in SAMPLING}
        empty = [e for e in SAMPLING if n[e] == 0]
        for est in SAMPLING:
            out[f"pdf_{est}"] = None if n[est] == 0 else self.pdf_per_degree(est, bins_deg)
        out["amplitude_sampling"] = dict(SAMPLING)
        # the envelope's samples: φ recorded every `record_interval_s` (docs/numerics.md; absent: every time step)
        out["envelope_sample_interval_s"] = self.config.get("record_interval_s", self.config.get("dt_s"))
        out["n_amplitudes"] = n
        out["mean_amplitude_deg"] = {
            e: None if n[e] == 0 else float(np.rad2deg(self.mean(e))) for e in SAMPLING
        }
        out["quantiles_deg"] = {
            e: None
            if n[e] == 0
            else {
                f"{round(q * 100):d}": float(v)
                for q, v in zip(QUANTILE_LEVELS, np.rad2deg(self.quantiles(e)), strict=True)
            }
            for e in SAMPLING
        }
        out["mass_beyond_grid"] = {
            e: None if n[e] == 0 else self._mass_beyond(e, float(bins_deg[-1])) for e in SAMPLING
        }
        out["n_realizations"] = self.n_realizations
        out["n_capsized"] = self.n_capsized
        out["n_survivors"] = self.n_realizations - self.n_capsized
        out["capsize_probability"] = self.capsize_probability
        out["conditional_on_no_capsize"] = True
        out["roll_moments"] = self.phi_moments()
        out["stationarity"] = self.stationarity()
        out["reason"] = self._empty_reason(empty)
        return out

    def _mass_beyond(self, estimator: str, edge_deg: float) -> float:
        """Fraction of the amplitudes beyond `edge_deg` [deg] (a fine-grid edge; the last fine bin also holds the
        amplitudes beyond the fine grid)."""
        counts = self._counts(estimator)
        i = int(np.searchsorted(self.edges_deg, edge_deg - 1e-9 * (self.edges_deg[1] - self.edges_deg[0])))
        return float(counts[i:].sum() / counts.sum())

    def _empty_reason(self, empty: list[str]) -> str | None:
        """Why the estimators in `empty` have no amplitude (None when none is empty)."""
        if not empty:
            return None
        which = " and ".join(e.replace("_", "-") for e in empty)
        if self.n_capsized == self.n_realizations:
            why = f"all {self.n_realizations} realizations capsized"
        else:
            why = (
                "the surviving realizations produced none after the discard: the run (duration − discard) is "
                "shorter than a roll period, or the roll never left zero (φ0 = 0 in calm water)"
            )
        return f"no {which} amplitude: {why}; the statistics are null, not estimated"

    def stationarity(self) -> dict:
        """Whether the roll is stationary over the kept window, from the mean envelope amplitude over its first and
        second halves [deg] (exact per-realization sums): `relative_change` (second − first, over the first),
        `change_in_standard_errors` (from the spread of the per-realization differences; None where the trials
        are all alike, as in an unexcited decay from the same φ0), and
        `stationary` — False when the change exceeds `STATIONARITY_TOLERANCE` (10 %) and `STATIONARITY_SE` (3)
        standard errors: the statistics then depend on the initial roll and the duration (`note` says what to do).
        `stationary` is None when it cannot be told (fewer than two surviving realizations, or no amplitude)."""
        pr = self.per_realization
        keep = pr["n_env"] > 0
        out = {
            "mean_envelope_first_half_deg": None,
            "mean_envelope_second_half_deg": None,
            "relative_change": None,
            "change_in_standard_errors": None,
            "stationary": None,
            "note": None,
        }
        if "sum_env_first_half" not in pr or keep.sum() < 2:
            return out
        n, s = pr["n_env"][keep], pr["sum_env"][keep]
        n1, s1 = n // 2, pr["sum_env_first_half"][keep]  # the observer's first half: n // 2 samples
        n2, s2 = n - n1, s - s1
        if n1.min() == 0 or s.sum() == 0:
            return out
        m1, m2 = s1.sum() / n1.sum(), s2.sum() / n2.sum()
        d = s2 / n2 - s1 / n1  # per realization
        se = d.std(ddof=1) / np.sqrt(d.size)
        change = (m2 - m1) / m1
        # no spread (identical trials, e.g. an unexcited decay from the same φ0): any change is exact
        z = (m2 - m1) / se if se > 1e-12 * abs(m1) else None
        significant = abs(m2 - m1) > 0 if z is None else abs(z) > STATIONARITY_SE
        stationary = not (abs(change) > STATIONARITY_TOLERANCE and significant)
        out.update(
            mean_envelope_first_half_deg=float(np.rad2deg(m1)),
            mean_envelope_second_half_deg=float(np.rad2deg(m2)),
            relative_change=float(change),
            change_in_standard_errors=None if z is None else float(z),
            stationary=stationary,
        )
        if not stationary:
            a = float(self.config.get("discard_s", 0.0))
            b = float(self.config.get("duration_s", float("nan")))
            sig = "every trial alike" if z is None else f"{abs(z):.3g} standard errors"
            out["note"] = (
                f"the roll is not stationary over the run: the mean envelope amplitude goes from "
                f"{np.rad2deg(m1):.3g}° ({a:g}–{(a + b) / 2:g} s) to {np.rad2deg(m2):.3g}° ({(a + b) / 2:g}–{b:g} s), "
                f"{100 * change:+.0f} % ({sig}), so these statistics depend on the initial roll and the duration. "
                + (
                    "Falling: the roll may be dying out (below the parametric-roll threshold: the theories say "
                    "whether) or still settling from the initial roll; "
                    if change < 0
                    else "Rising: the roll is still building up; "
                )
                + "lengthen the duration and the discard (--duration, --discard) to see where it settles."
            )
        return out

    def phi_moments(self) -> dict[str, float]:
        """Time-sampled E[φ²] [rad²] and E[φ⁴] [rad⁴] over surviving realizations (after the discard)."""
        pr = self.per_realization
        n = pr["n_samples"].sum()
        if n == 0:
            return {"E_phi2": float("nan"), "E_phi4": float("nan")}
        return {"E_phi2": float(pr["sum_phi2"].sum() / n), "E_phi4": float(pr["sum_phi4"].sum() / n)}

    def to_xarray(self, bins_deg=None):
        """The statistics as an `xarray.Dataset` (docs/outputs.md): the `summary(bins_deg)` fields (pdf.json's
        names; PDFs on `amplitude_deg`, the centres of `bins_deg`, by default 1° bins over the fine grid), the
        histogram `counts_zero_crossing`, `counts_envelope` on the fine grid (`fine_amplitude_deg`), and per
        realization `capsized`, `capsize_time_s` (inf: did not capsize) and the exact sums behind the means."""
        from .._labels import config_attrs, labelled_values, merge, tree_to_dataset
        from .._labels._layouts import AMPLITUDES

        edges = np.asarray(self.edges_deg, dtype=float)
        if bins_deg is None:
            bins_deg = edges[:: max(1, int(round(1.0 / (edges[1] - edges[0]))))]
        ds = tree_to_dataset(self.summary(bins_deg), AMPLITUDES)
        pr = self.per_realization
        r, fine = ("realization",), ("fine_amplitude_deg",)
        sums = {  # observer key → (name, unit, long name)
            "n_zc": ("n_zero_crossing", "1", "zero-crossing amplitudes after the discard"),
            "sum_zc": ("sum_zero_crossing_rad", "rad", "sum of the zero-crossing amplitudes"),
            "sumsq_zc": ("sumsq_zero_crossing_rad2", "rad2", "sum of the squared zero-crossing amplitudes"),
            "n_env": ("n_envelope", "1", "envelope samples after the discard"),
            "sum_env": ("sum_envelope_rad", "rad", "sum of the envelope samples"),
            "sum_env_first_half": (
                "sum_envelope_first_half_rad",
                "rad",
                "sum of the envelope samples of the first half of the kept window",
            ),
            "sumsq_env": ("sumsq_envelope_rad2", "rad2", "sum of the squared envelope samples"),
            "n_samples": ("n_samples", "1", "φ samples after the discard"),
            "sum_phi2": ("sum_phi2_rad2", "rad2", "sum of φ² over the samples"),
            "sum_phi4": ("sum_phi4_rad4", "rad4", "sum of φ⁴ over the samples"),
            "max_env": (
                "max_envelope_deg",
                "degree",
                "largest envelope amplitude (largest roll) after the discard",
            ),
        }
        per = {
            name: (r, np.rad2deg(pr[k]) if unit == "degree" else pr[k], unit, f"per realization: {long}")
            for k, (name, unit, long) in sums.items()
            if k in pr
        }
        hist = "amplitudes per fine bin (the last bin also holds those beyond the grid)"
        return merge(
            ds,
            labelled_values(
                {
                    "counts_zero_crossing": (fine, self.counts_zero_crossing, "1", f"zero-crossing {hist}"),
                    "counts_envelope": (fine, self.counts_envelope, "1", f"envelope {hist}"),
                    **_per_trial(self),
                    **per,
                },
                coords={
                    "fine_amplitude_deg": (
                        fine,
                        (edges[1:] + edges[:-1]) / 2,
                        "degree",
                        "centres of the fine bins",
                    ),
                    **_realizations(self),
                },
                attrs=config_attrs(self.config),
            ),
        )


@dataclass
class MaximaStatistics(CapsizeCounts):
    """Monte Carlo maxima of the first N0 zero-crossing amplitudes per trial (angles in degrees).

    `maxima_deg[i, j]` is trial i's maximum over its first `n0[j]` amplitudes after the discard, NaN where the
    trial capsized or ended before reaching n0[j] amplitudes (counted in `n_capsized_before`, `n_incomplete`).
    A capsize before the n0[j]-th amplitude is a maximum beyond the angle of vanishing stability: `summary`,
    `exceedance_probability` count it (a defective distribution), never drop it.
    `count` is the number of amplitudes each trial contributed (at most max(n0)). A trial stops once it has
    max(n0) amplitudes, so `capsized` means capsized before that.
    """

    n0: tuple[int, ...]
    maxima_deg: np.ndarray
    capsized: np.ndarray
    capsize_time: np.ndarray
    count: np.ndarray
    config: dict = field(default_factory=dict)

    def _repr_html_(self) -> str:
        """Jupyter's view: per N0, the trials known, the capsizes before N0 and the maximum's mean and quantiles
        [deg] (a quantile among the capsizes is shown as "capsize")."""
        from .._display import fmt, html_table

        rows = []
        for j, n0 in enumerate(self.n0):
            s = self.summary(j, np.array([0.0, 90.0]))
            quantiles = [fmt(v) if v is not None else "capsize" for v in s["quantiles_deg"].values()]
            rows.append(
                (
                    n0,
                    s["n_known"],
                    s["n_capsized_before"],
                    s["capsize_probability"],
                    s["mean_deg_given_no_capsize"],
                    *quantiles,
                )
            )
        return html_table(
            "Monte Carlo maxima of the first N0 amplitudes",
            rows,
            header=(
                "N0",
                "trials known",
                "capsized before N0",
                "P(capsize)",
                "mean given no capsize [deg]",
                *(f"{100 * q:g} % [deg]" for q in QUANTILE_LEVELS),
            ),
            note=f"{self.n_realizations} trials; a capsize before N0 is a maximum beyond the angle of vanishing "
            "stability (counted in every probability).",
        )

    def valid(self, j: int) -> np.ndarray:
        """Trials whose maximum over their first n0[j] amplitudes is known."""
        return np.isfinite(self.maxima_deg[:, j])

    def n_capsized_before(self, j: int) -> int:
        """Trials that capsized before their n0[j]-th amplitude."""
        return int(np.sum(self.capsized & ~self.valid(j)))

    def n_incomplete(self, j: int) -> int:
        """Trials that neither capsized nor reached n0[j] amplitudes (increase `duration`)."""
        return int(np.sum(~self.capsized & ~self.valid(j)))

    def n_known(self, j: int) -> int:
        """Trials whose maximum over n0[j] amplitudes is known: a finite maximum, or a capsize before (a maximum
        beyond the angle of vanishing stability)."""
        return int(np.sum(self.valid(j))) + self.n_capsized_before(j)

    def exceedance_probability(self, j: int, angle_deg: float) -> float:
        """P(max of the first n0[j] amplitudes > `angle_deg`, or a capsize before them) [-], over the known
        trials: the capsizes are the largest maxima and are counted, not dropped."""
        n = self.n_known(j)
        exceeded = np.sum(self.maxima_deg[self.valid(j), j] > angle_deg) + self.n_capsized_before(j)
        return float(exceeded / n) if n else float("nan")

    def summary(self, j: int, bins_deg: np.ndarray, levels=QUANTILE_LEVELS) -> dict:
        """JSON-ready statistics of the maximum over the first n0[j] amplitudes, as a *defective* distribution.

        A trial that capsized before its n0[j]-th amplitude has a maximum beyond the angle of vanishing stability:
        it is counted in every probability (`capsize_probability` is the missing mass). So the histogram density
        [1/deg] integrates to 1 - capsize_probability; a quantile at a level above 1 - capsize_probability is
        `None` ("capsize"); the mean is `None` when any trial capsized (infinite), with the survivors' mean beside
        it. Incomplete trials (neither capsized nor reached n0[j] amplitudes) are unknown and left out.
        """
        n_cap, n_known = self.n_capsized_before(j), self.n_known(j)
        x = self.maxima_deg[self.valid(j), j]
        hist = np.histogram(x, bins=bins_deg)[0] / (max(n_known, 1) * np.diff(bins_deg))
        p_cap = n_cap / n_known if n_known else float("nan")
        lo, hi = wilson_interval(n_cap, max(n_known, 1))
        known = self.valid(j) | self.capsized
        quantiles = quantiles_with_capsizes_deg(self.maxima_deg[known, j], ~self.valid(j)[known], levels)
        reasons = {
            key: "no trial reached N0 amplitudes"
            if not n_known
            else f"beyond the angle of vanishing stability: P(capsize before N0) = {p_cap:.3g} exceeds 1 - {q:g}"
            for q, (key, value) in zip(levels, quantiles.items(), strict=True)
            if value is None
        }
        mean = float(x.mean()) if (x.size and not n_cap) else None
        out = {
            "n_trials": int(self.maxima_deg.shape[0]),
            "n_known": n_known,
            "n_valid": int(x.size),
            "n_capsized": n_cap,
            "n_capsized_before": n_cap,
            "n_incomplete": self.n_incomplete(j),
            "capsize_probability": p_cap,
            "capsize_probability_ci95": [float(lo), float(hi)],
            "histogram_pdf_per_deg": hist,
            "histogram_mass": float(np.sum(hist * np.diff(bins_deg))),
            "beyond_bins": int(np.sum(x > bins_deg[-1])),
            "mean_deg": mean,
            "mean_deg_given_no_capsize": float(x.mean()) if x.size else None,
            "quantiles_deg": quantiles,
        }
        if mean is None:
            out["mean_reason"] = (
                "infinite: trials capsized before N0 (their maximum is beyond the angle of "
                "vanishing stability); see mean_deg_given_no_capsize"
                if n_cap
                else "no trial reached N0 amplitudes"
            )
        if reasons:
            out["quantiles_reason"] = reasons
        return out

    def to_xarray(self, bins_deg=None):
        """The maxima as an `xarray.Dataset` (docs/outputs.md): `summary(j, bins_deg)` for every N0 (maxima.json's
        `per_n0` fields, on the dimension `n0`; default 1° bins to 90°) and per trial `maxima_deg` (NaN: the trial
        capsized or ended before N0 amplitudes), `capsized`, `capsize_time_s` and `amplitude_count` (amplitudes the trial
        contributed), all on (`n0`, `realization`) so that runs with other N0 concatenate along `n0`."""
        from .._labels import config_attrs, labelled_values, merge, tree_to_dataset
        from .._labels._layouts import MAXIMA_SUMMARY

        bins = np.arange(0.0, 90.0 + 1e-9, 1.0) if bins_deg is None else np.asarray(bins_deg, dtype=float)
        tree = {"bins_deg": bins, "per_n0": {str(n): self.summary(j, bins) for j, n in enumerate(self.n0)}}
        ds = tree_to_dataset(tree, MAXIMA_SUMMARY)
        dims = ("n0", "realization")
        n = (len(self.n0), self.n_realizations)
        return merge(
            ds,
            labelled_values(
                {
                    "maxima_deg": (
                        dims,
                        np.asarray(self.maxima_deg).T,
                        "degree",
                        "largest of the trial's first N0 zero-crossing amplitudes (NaN: capsized or ended "
                        "before N0 amplitudes)",
                    ),
                    **_per_trial(self, dims),
                    "amplitude_count": (
                        dims,
                        np.broadcast_to(self.count, n),
                        "1",
                        "zero-crossing amplitudes the trial recorded (at most max(N0) of its run)",
                    ),
                },
                coords=_realizations(self),
                attrs=config_attrs(self.config),
            ),
        )


@dataclass
class MaxRollStatistics(CapsizeCounts):
    """Per-trial largest roll and capsizes (host numpy arrays; realization order).

    `max_abs_phi_deg` is the largest |φ| after the discard (for a capsized trial, up to its capsize). A trial
    exceeds an angle when that maximum is larger or when it capsized.
    """

    max_abs_phi_deg: np.ndarray
    capsized: np.ndarray
    capsize_time: np.ndarray
    angle_deg: float
    n_exceeded: int
    config: dict = field(default_factory=dict)

    def _repr_html_(self) -> str:
        """Jupyter's view: exceedance and capsize probabilities with their intervals, largest-roll quantiles."""
        from .._display import fmt, fmt_interval, html_table

        quantiles = self.largest_roll_quantiles_deg()
        rows = [
            (
                f"P(max |φ| > {self.angle_deg:g}°, or capsize)",
                self.exceedance_probability(),
                fmt_interval(*self.exceedance_interval()),
                "-",
            ),
            ("P(capsize)", self.capsize_probability, fmt_interval(*self.capsize_interval()), "-"),
        ] + [
            (f"largest roll, {k} % quantile", fmt(v) if v is not None else "capsize", "", "deg")
            for k, v in quantiles.items()
        ]
        c = self.config
        note = f"{self.n_realizations} realizations" + (
            f" of {c['duration_s']:g} s" if "duration_s" in c else ""
        )
        return html_table(
            "Monte Carlo largest roll", rows, header=("", "value", "95 % interval", "unit"), note=note
        )

    def exceedances(self, angle_deg: float | None = None) -> int:
        """Trials with max |φ| > `angle_deg` [deg] (default: the run's angle) or capsized."""
        if angle_deg is None:
            return self.n_exceeded
        return int(np.sum(self.capsized | (self.max_abs_phi_deg > angle_deg)))

    def exceedance_probability(self, angle_deg: float | None = None) -> float:
        """P(max |φ| > angle within the duration) per trial [-]."""
        return self.exceedances(angle_deg) / self.n_realizations

    def exceedance_interval(
        self, angle_deg: float | None = None, confidence: float = 0.95
    ) -> tuple[float, float]:
        """Wilson interval of `exceedance_probability` [-]."""
        lo, hi = wilson_interval(self.exceedances(angle_deg), self.n_realizations, confidence)
        return float(lo), float(hi)

    def largest_roll_quantiles_deg(self, levels=QUANTILE_LEVELS) -> dict:
        """Quantiles [deg] of the per-trial largest |φ|, a capsized trial counting as beyond the angle of vanishing
        stability (`None` where a level falls among the capsizes)."""
        return quantiles_with_capsizes_deg(self.max_abs_phi_deg, self.capsized, levels)

    def to_xarray(self):
        """The result as an `xarray.Dataset` (docs/outputs.md): per trial `max_abs_phi_deg` (the largest roll),
        `capsized`, `capsize_time_s`; the exceedance and capsize probabilities with 95 % Wilson intervals
        (`bound`), and `largest_roll_quantiles_deg` (NaN: among the capsizes)."""
        from .._labels import config_attrs, labelled_values, merge, tree_to_dataset
        from .._labels._layouts import MAX_ROLL

        tree = {
            "angle_deg": self.angle_deg,
            "n_realizations": self.n_realizations,
            "n_capsized": self.n_capsized,
            "n_exceeded": self.n_exceeded,
            "probability": self.exceedance_probability(),
            "probability_ci95": list(self.exceedance_interval()),
            "capsize_probability": self.capsize_probability,
            "capsize_probability_ci95": list(self.capsize_interval()),
            "largest_roll_quantiles_deg": self.largest_roll_quantiles_deg(),
        }
        return merge(
            tree_to_dataset(tree, MAX_ROLL),
            labelled_values(
                {
                    "max_abs_phi_deg": (
                        ("realization",),
                        self.max_abs_phi_deg,
                        "degree",
                        "largest |φ| of the trial after the discard (up to its capsize)",
                    ),
                    **_per_trial(self),
                },
                coords=_realizations(self),
                attrs=config_attrs(self.config),
            ),
        )


@dataclass
class SweepResult:
    """Probabilities on the grid, arrays shaped (heading, speed, H1/3, T01) in the order of `grid`'s axes."""

    grid: dict
    n_realizations: int
    angle_deg: float
    confidence: float
    n_capsized: np.ndarray
    n_exceeded: np.ndarray

    def _repr_html_(self) -> str:
        """Jupyter's view: one row per grid point, the capsize and exceedance probabilities with their intervals."""
        from .._display import fmt_interval, html_table

        p_cap, p_exc = self.capsize_probability, self.exceedance_probability
        ci_cap, ci_exc = self.capsize_interval(), self.exceedance_interval()
        rows = []
        for index in np.ndindex(*p_cap.shape):
            point = [values[i] for values, i in zip(self.grid.values(), index, strict=True)]
            rows.append(
                (
                    *point,
                    p_cap[index],
                    fmt_interval(*ci_cap[index]),
                    p_exc[index],
                    fmt_interval(*ci_exc[index]),
                )
            )
        return html_table(
            "Sweep: capsize and exceedance probabilities",
            rows,
            header=(
                "heading",
                "speed [m/s]",
                "H1/3 [m]",
                "T01 [s]",
                "P(capsize)",
                f"{self.confidence:.0%} interval",
                f"P(roll > {self.angle_deg:g}°)",
                f"{self.confidence:.0%} interval",
            ),
            note=f"{self.n_realizations} realizations per grid point (common random numbers).",
        )

    @property
    def capsize_probability(self) -> np.ndarray:
        """Per grid point [-]."""
        return self.n_capsized / self.n_realizations

    @property
    def exceedance_probability(self) -> np.ndarray:
        """Per grid point: P(max |φ| > angle or capsize within the duration) [-]."""
        return self.n_exceeded / self.n_realizations

    def capsize_interval(self) -> np.ndarray:
        """Wilson interval, shape (..., 2)."""
        return np.stack(wilson_interval(self.n_capsized, self.n_realizations, self.confidence), -1)

    def exceedance_interval(self) -> np.ndarray:
        """Wilson interval, shape (..., 2)."""
        return np.stack(wilson_interval(self.n_exceeded, self.n_realizations, self.confidence), -1)

    def to_xarray(self):
        """The sweep as an `xarray.Dataset` on (`heading`, `speed_m_s`, `hs_m`, `t01_s`) (sweep.json's names;
        `heading_deg` beside the heading labels): counts, probabilities and their Wilson intervals (`bound`).
        Sweeps of other grids combine with `xarray.merge` or `xarray.concat`."""
        from .._labels import tree_to_dataset
        from .._labels._layouts import SWEEP
        from ..sea._spectra import heading_angle

        def degrees(label: str) -> float:
            return float(label[:-3]) if label.endswith("deg") else float(np.rad2deg(heading_angle(label)))

        tree = {
            "grid": {"axes": list(self.grid), **self.grid},
            "heading_deg": [degrees(h) for h in self.grid["heading"]],
            "n_realizations": self.n_realizations,
            "angle_deg": self.angle_deg,
            "confidence": self.confidence,
            "n_capsized": self.n_capsized,
            "n_exceeded": self.n_exceeded,
            "capsize_probability": self.capsize_probability,
            "capsize_ci": self.capsize_interval(),
            "exceedance_probability": self.exceedance_probability,
            "exceedance_ci": self.exceedance_interval(),
        }
        return tree_to_dataset(tree, SWEEP)
