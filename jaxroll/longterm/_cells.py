"""The cells of a long-term assessment and their weights.

A cell is (H_s, T_z, heading χ, speed U, loading condition). Its weight is the product of the scatter diagram's
occurrence probability and the heading, speed and loading probabilities (each normalised), so the weights sum to 1.

What is computed is a *computation cell* (ship, heading class, speed, H_s, T_z): headings χ and 360° − χ form one
class (port and starboard: the 1-DOF roll model of long-crested waves depends on the heading only through cos χ,
so the two are the same problem, bit for bit), computed once at the class heading χ' = min(χ, 360° − χ) in
[0°, 180°]. Beam seas (χ' = 90°) have no parametric excitation in this model (Grim's effective wave vanishes): their
probability is 0 exactly and costs nothing.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import os
from collections.abc import Sequence

import numpy as np

from ._scatter import ScatterDiagram

BEAM_DEG = 90.0
#: Cell seeds: s_c = SEED_STRIDE·seed + c + 1 for the computation cell of global index c, so that the cells of one
#: run never share a seed and `jaxroll risk --seed s_c − 1` (whose direct estimate uses `jax.random.key(seed + 1)`)
#: reproduces cell c trial for trial.
SEED_STRIDE = 1_000_000
#: The largest `seed`: s_c = SEED_STRIDE·seed + c + 1 stays within int64 (and `jax.random.key`) for any grid.
MAX_SEED = 10**12 - 1
#: The fastest speed a long-term cell may have, as a Froude number U/√(g L): displacement ships sail below about
#: 0.4 and fast craft reach 1; a speed above is a unit slip (knots, km/h) or a typo, and its encounter spectrum
#: would carry no parametric excitation (P = 0 without a word, issue 45).
MAX_FROUDE = 1.0
GRAVITY = 9.80665


#: Hours in a year: the default `hours_per_year` (a ship at sea all year: the conservative end).
HOURS_PER_YEAR = 8766.0


def _real(value, name: str) -> float:
    """`value` as a float: a Python or NumPy real number (not a bool). **Raises:** `ValueError` naming `name`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"`{name}` must be a number; got {value!r} ({type(value).__name__}).")
    return float(value)


def _integer(value, name: str) -> int:
    """`value` as an int: a Python or NumPy integer (not a bool). **Raises:** `ValueError` naming `name`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"`{name}` must be an integer; got {value!r} ({type(value).__name__}).")
    return int(value)


def check_types(ships: list, checkpoint) -> None:
    """`ships` are `Ship`s and `checkpoint` a path or None. **Raises:** `ValueError` naming the argument."""
    from ..ship import Ship

    for s in ships:
        if not isinstance(s, Ship):
            raise ValueError(
                f"`ships` must be a Ship or a sequence of Ships (e.g. jaxroll.c11_representative(), "
                f"jaxroll.load_ship(path)); got {s!r} ({type(s).__name__})."
            )
    if not (checkpoint is None or isinstance(checkpoint, str | os.PathLike)):
        raise ValueError(
            f"`checkpoint` must be the path of a folder (or None); got {checkpoint!r} ({type(checkpoint).__name__})."
        )


def check_exposure(exposure: float, hours_per_year: float, option=("`exposure`", "`hours_per_year`")) -> None:
    """An exposure [s] within a year of `hours_per_year` hours at sea, itself at most a year (`HOURS_PER_YEAR`).
    **Raises:** `ValueError` naming the options (`option`: their names)."""
    if hours_per_year > HOURS_PER_YEAR:
        raise ValueError(
            f"{option[1]} must be at most {HOURS_PER_YEAR:g} h (a year: 365.25 days at sea); got {hours_per_year:g}."
        )
    if exposure / 3600.0 > hours_per_year:
        raise ValueError(
            f"{option[0]} ({exposure / 3600.0:g} h) is longer than the {hours_per_year:g} h at sea per year "
            f"({option[1]}): the per-year values need at least one exposure a year."
        )


def canonical_heading_deg(chi_rad: float) -> float:
    """A heading χ [rad] in degrees rounded to 1e-9° (so that `math.radians` of it gives back the very float the
    command line gives for the same degrees: `--heading 150` and χ = radians(150) are one problem, bit for bit)."""
    d = round(math.degrees(float(chi_rad)), 9) % 360.0
    return 0.0 if d == 360.0 else d + 0.0


def heading_class_deg(deg: float) -> float:
    """The class heading χ' = min(χ, 360° − χ) [deg] in [0°, 180°] of a heading χ [deg] in [0°, 360°)."""
    return deg if deg <= 180.0 else round(360.0 - deg, 9)


def normalised_weights(weights, n: int, name: str) -> np.ndarray:
    """`weights` (None: uniform) as probabilities of `n` values. **Raises:** `ValueError` naming `name` for a wrong
    length, negative or non-finite weights, or weights summing to zero."""
    if weights is None:
        return np.full(n, 1.0 / n)
    w = np.asarray(weights, dtype=float).reshape(-1)
    if w.size != n:
        raise ValueError(f"`{name}` has {w.size} weights for {n} values; give one weight per value.")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError(f"`{name}` must be finite and >= 0; got {w.tolist()}.")
    if not w.max() > 0:
        raise ValueError(f"`{name}` sum to zero; at least one value needs a positive weight.")
    w = w / w.max()  # (weights of 1e308 would sum to inf, and every weight to 0)
    return w / w.sum()


def check_speeds(speeds, ships, option: str = "`speeds`") -> None:
    """Refuse a speed [m/s] whose Froude number U/√(g Lpp) exceeds `MAX_FROUDE` for a ship (a unit slip).
    **Raises:** `ValueError` naming `option`, the speed, the ship and the largest speed accepted."""
    for ship in ships:
        lpp = float(ship.lpp)
        top = MAX_FROUDE * math.sqrt(GRAVITY * lpp)
        for u in np.atleast_1d(np.asarray(speeds, dtype=float)):
            if u > top:
                raise ValueError(
                    f"{option}: U = {u:g} m/s is a Froude number of {u / math.sqrt(GRAVITY * lpp):.3g} for "
                    f"{ship.name} (Lpp = {lpp:g} m), faster than any ship (at most Fn = {MAX_FROUDE:g}, "
                    f"{top:.4g} m/s); speeds are in m/s (1 kn = 0.5144 m/s)."
                )


@dataclasses.dataclass(frozen=True)
class CellGrid:
    """The cells: the scatter diagram's (H_s, T_z) × headings × speeds × ships, with their weights.

    `headings_deg` [deg] in [0, 360) as given (canonical, `canonical_heading_deg`); `classes_deg` the distinct class
    headings in order of first appearance and `heading_class` the class of each heading; `speeds` [m/s]. Weights are
    normalised (`ship_weights`, `heading_weights`, `speed_weights`, and the scatter's `probability`).
    """

    scatter: ScatterDiagram
    ships: tuple
    ship_names: tuple[str, ...]
    ship_weights: np.ndarray
    headings_deg: np.ndarray
    heading_weights: np.ndarray
    heading_class: np.ndarray
    classes_deg: np.ndarray
    speeds: np.ndarray
    speed_weights: np.ndarray

    @property
    def weight(self) -> np.ndarray:
        """w [-] of every cell, dims (hs, tz, heading, speed, ship); sums to 1."""
        p = self.scatter.probability
        return (
            p[:, :, None, None, None]
            * self.heading_weights[None, None, :, None, None]
            * self.speed_weights[None, None, None, :, None]
            * self.ship_weights[None, None, None, None, :]
        )

    @property
    def class_weights(self) -> np.ndarray:
        """Heading probability of each class [-] (the sum over its headings), shape (classes,)."""
        return np.array(
            [self.heading_weights[self.heading_class == k].sum() for k in range(self.classes_deg.size)]
        )

    @property
    def shape(self) -> tuple[int, int, int, int, int]:
        """(ships, classes, speeds, hs, tz): the computation cells."""
        return (
            len(self.ships),
            self.classes_deg.size,
            self.speeds.size,
            self.scatter.hs.size,
            self.scatter.tz.size,
        )

    @property
    def comp_weight(self) -> np.ndarray:
        """w [-] of every computation cell, shape `shape` (a class carries its headings' weight)."""
        p = self.scatter.probability
        return (
            self.ship_weights[:, None, None, None, None]
            * self.class_weights[None, :, None, None, None]
            * self.speed_weights[None, None, :, None, None]
            * p[None, None, None, :, :]
        )

    @property
    def beam(self) -> np.ndarray:
        """Per class: beam seas (no parametric excitation; probability 0 exactly)."""
        return self.classes_deg == BEAM_DEG

    def seeds(self, seed: int) -> np.ndarray:
        """The Monte Carlo seed s_c of every computation cell (`SEED_STRIDE`), shape `shape`."""
        n = int(np.prod(self.shape))
        return SEED_STRIDE * int(seed) + 1 + np.arange(n, dtype=np.int64).reshape(self.shape)


def make_grid(
    scatter: ScatterDiagram,
    ships: Sequence,
    ship_names: Sequence[str],
    ship_weights,
    headings_rad,
    heading_weights,
    speeds,
    speed_weights,
) -> CellGrid:
    """Check and assemble a `CellGrid`. Headings χ [rad] in [0, 2π) (0 following, π/2 beam, π head), speeds [m/s].

    **Raises:** `ValueError` for empty, repeated or out-of-range headings and speeds, and for bad weights.
    """
    if not ships:
        raise ValueError("`ships` must name at least one ship.")
    if len(ship_names) != len(ships) or len(set(ship_names)) != len(ship_names):
        raise ValueError(
            f"`ship_names` must give each of the {len(ships)} ships a distinct name; got {list(ship_names)}."
        )
    headings_rad = [float(h) for h in np.atleast_1d(np.asarray(headings_rad, dtype=float))]
    if not headings_rad:
        raise ValueError("`headings` must hold at least one heading.")
    for h in headings_rad:
        if not (math.isfinite(h) and 0.0 <= h < 2 * math.pi):
            raise ValueError(
                f"`headings` must be angles χ in [0, 2π) rad (0 following, π/2 beam, π head); got {h!r}."
            )
    deg = np.array([canonical_heading_deg(h) for h in headings_rad])
    if len(set(deg.tolist())) != deg.size:
        raise ValueError(f"`headings` repeats a heading: {deg.tolist()} deg.")
    speeds = np.asarray(np.atleast_1d(np.asarray(speeds, dtype=float)), dtype=float)
    if speeds.size == 0 or not np.all(np.isfinite(speeds)) or np.any(speeds < 0):
        raise ValueError(f"`speeds` must be finite and >= 0 [m/s]; got {speeds.tolist()}.")
    if len(set(speeds.tolist())) != speeds.size:
        raise ValueError(f"`speeds` repeats a speed: {speeds.tolist()} m/s.")
    check_speeds(speeds, ships)
    classes: list[float] = []
    member = []
    for d in deg:
        c = heading_class_deg(float(d))
        if c not in classes:
            classes.append(c)
        member.append(classes.index(c))
    grid = CellGrid(
        scatter=scatter,
        ships=tuple(ships),
        ship_names=tuple(ship_names),
        ship_weights=normalised_weights(ship_weights, len(ships), "ship_weights"),
        headings_deg=deg,
        heading_weights=normalised_weights(heading_weights, deg.size, "heading_weights"),
        heading_class=np.array(member, dtype=np.int64),
        classes_deg=np.array(classes),
        speeds=speeds,
        speed_weights=normalised_weights(speed_weights, speeds.size, "speed_weights"),
    )
    n = int(np.prod(grid.shape))
    if n >= SEED_STRIDE:  # each cell its own seed (`SEED_STRIDE`)
        s, k, u, i, j = grid.shape
        raise ValueError(
            f"{n} computation cells ({s} ships × {k} heading classes × {u} speeds × the {i} H_s × {j} T_z of the "
            f"scatter diagram {scatter.source}): more than one run can seed ({SEED_STRIDE - 1}); use a coarser "
            "scatter diagram, fewer headings or speeds, or several runs."
        )
    return grid


def skipped_cells(comp_weight: np.ndarray, needed: np.ndarray, skip_weight: float) -> np.ndarray:
    """The computation cells left out under `skip_weight`: the lightest needed cells, lightest first, as long as
    their weights add up to at most `skip_weight` (ties broken by index). Leaving them out changes the long-term
    probability by at most their total weight (each cell's probability is in [0, 1]): that bound is reported and
    added to the upper end of the interval."""
    out = np.zeros(comp_weight.shape, bool)
    if skip_weight <= 0:
        return out
    flat = np.flatnonzero(needed.reshape(-1))
    w = comp_weight.reshape(-1)[flat]
    order = np.argsort(w, kind="stable")
    keep = np.cumsum(w[order]) <= skip_weight
    out.reshape(-1)[flat[order[keep]]] = True
    return out


def parse_part(part) -> tuple[int, int] | None:
    """`(i, n)` of a part i of n (1 ≤ i ≤ n), from a tuple or the text `i/N`; None for None."""
    if part is None:
        return None
    if isinstance(part, str):
        try:
            i, n = (int(x) for x in part.split("/"))
        except ValueError:
            raise ValueError(
                f"`part` must be 'i/N' with integers 1 <= i <= N (e.g. 2/8); got {part!r}."
            ) from None
    else:
        i, n = part
    if not (isinstance(i, int) and isinstance(n, int) and 1 <= i <= n):
        raise ValueError(f"`part` must be 'i/N' with integers 1 <= i <= N (e.g. 2/8); got {part!r}.")
    return i, n


def worker_of(unit_index: int, num_workers: int) -> int:
    """The worker (part × process) that computes work unit `unit_index`: round robin, so every split of the same
    problem computes every unit with the same program and inputs (results bit for bit the same)."""
    return unit_index % num_workers
