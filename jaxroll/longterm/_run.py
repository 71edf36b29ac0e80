"""`longterm(...)`: the long-term exceedance probability over a scatter diagram, headings, speeds and loadings.

Work is cut into units — the theory of one (ship, heading class, speed), or the Monte Carlo of one cell — computed
by the worker `unit % W` of W = parts × processes (`--part i/N`, `jax.distributed`): every split runs each unit
with the same program and inputs, so the results do not depend on it, bit for bit. Units are checkpointed one by
one (`checkpoint`: a directory; a rerun resumes, a Monte Carlo cell also within its chunks).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path

import jax
import numpy as np

from .._config import require_float64
from ..io import dataset_attrs, ship_to_dict
from ..roll import SPLITTING_EXCITATIONS
from ..roll._monte_carlo import SURFACE_MAXIMA_REFUSAL
from ..sea import Spreading
from ..ship import c11_representative, vanishing_angle
from ._allowance import measured_allowance
from ._cells import (
    HOURS_PER_YEAR,
    MAX_SEED,
    _integer,
    _real,
    check_exposure,
    check_types,
    make_grid,
    parse_part,
    skipped_cells,
    worker_of,
)
from ._configuration import THEORY, check_time_steps, run_config
from ._dataset import METHODS, add_longterm, build_dataset
from ._moment import (
    MOMENT_EXCITATION,
    PARAMETRIC_KEYS,
    empty_parametric,
    fill_parametric,
    moment_classes,
    parametric_only,
    refuse_theory,
    surface_ships,
)
from ._monte_carlo import (
    CELL_ESTIMATORS,
    EFFORT_FRACTIONS,
    ESTIMATORS,
    RARE_BELOW,
    cell_problem,
    neyman_allocation,
)
from ._risk import AUTO_SHARE, AUTO_TOLERANCE, auto_cells, doubtful, fill_cells, rare_cells
from ._scatter import ScatterDiagram, scatter_diagram
from ._theory import REFINE_DELTA, class_template, class_theory
from ._units import _gather, _hash, _load_unit, _responsible_cells, _save_unit, _twin

METHOD_NAMES = ("theory", "monte-carlo", "auto")


def _check(value, ok: bool, message: str):
    if not ok:
        raise ValueError(message)
    return value


def longterm(
    scatter: str | os.PathLike | ScatterDiagram = "rec34",
    ships=None,
    *,
    ship_weights=None,
    ship_names: Sequence[str] | None = None,
    ship_files: Sequence[str | None] | None = None,
    headings=(math.pi,),
    heading_weights=None,
    speeds=(0.0,),
    speed_weights=None,
    angles=(math.radians(30.0),),
    exposure: float = 3 * 3600.0,
    method: str = "theory",
    realizations: int = 1000,
    discard: float = 500.0,
    dt: float = 0.5,
    excitation: str = "filter",
    filter_order: int | str = "auto",
    phi0: float = math.radians(5.0),
    seed: int = 0,
    hours_per_year: float = HOURS_PER_YEAR,
    auto_share: float = AUTO_SHARE,
    auto_tolerance: float = AUTO_TOLERANCE,
    model_factor: float | str = "measured",
    skip_weight: float = 0.0,
    refine_delta: float = REFINE_DELTA,
    estimator: str = "brute_force",
    rare_below: float = RARE_BELOW,
    part=None,
    checkpoint: str | os.PathLike | None = None,
    progress: Callable[[int, int, str], None] | None = None,
    chunk_size: int | None = None,
    memory_budget: float | None = None,
    spreading: Spreading | None = None,
):
    """Long-term probability that the roll exceeds each angle within one exposure, over a wave scatter diagram,
    headings, speeds and loading conditions, with the cells that dominate it (docs/longterm.md).

    **Arguments:**

    - `scatter`: `"rec34"` (IACS Rec. 34, North Atlantic), a scatter CSV file or a `ScatterDiagram` (H_s [m] ×
      T_z [s]; each cell's sea is ITTC with T01 = 1.0864 T_z).
    - `ships`: a `Ship` or a sequence of them (loading conditions; default C11 (representative)), with
      `ship_weights` (default uniform), `ship_names` (the dataset's `ship` coordinate) and `ship_files` (the files
      they came from, for the recorded `jaxroll risk` commands; None: the default ship).
    - `headings`: χ [rad] in [0, 2π) (0 following, π/2 beam, π head); χ and 2π − χ are one problem (port and
      starboard), computed once. `heading_weights` (default uniform). `speeds` [m/s] ≥ 0 with `speed_weights`.
    - `angles`: roll angles [rad] below every ship's angle of vanishing stability.
    - `exposure` [s]: the short-term exposure of every cell (3 h). `hours_per_year`: hours at sea per year, for
      the per-year values (default 8766, all year).
    - `method`: `"theory"` (every cell by theory), `"monte-carlo"` (every cell by Monte Carlo: trials of
      `discard` + `exposure` s, `realizations` per cell) or `"auto"` (theory everywhere, Monte Carlo on the cells
      that dominate P_LT — the smallest set carrying `auto_share` of it — and on material cells failing a
      validity check (`auto_tolerance`), with `realizations` × their number trials shared by Neyman allocation).
    - `refine_delta`: δ of the theory's two passes: per heading class and speed, the cells outside the smallest
      set carrying 1 − δ of the one-grid Σ w P keep that value (no Richardson step), with a widened allowance
      (docs/longterm.md, "Cost"); 0: every cell refined.
    - `model_factor`: the theory cells' allowance [P/f, f·P] in the long-term interval: `"measured"` (default),
      the factor measured against an exact-spectrum sea in the cell's T01 band, the widest measured outside the
      validated map (H1/3 4–8 m, T01 8–12 s, 0–5 m/s; those cells flagged `theory_outside_validated_map`, and
      simulated under `auto` where material); or one number f ≥ 1 for every cell (docs/longterm.md, "Model
      allowance"). `skip_weight`: leave out
      the lightest cells up to this total weight (a bound on their contribution, added to the interval).
    - A ship carrying a direct wave moment (`ship.wave_moment`): its cells off head and following seas are
      simulated with the moment (superposition, brute force; `"auto"` simulates them all, `"theory"` is refused),
      beam seas included, and each cell also gets `parametric_probability`, the moment off (docs/longterm.md, "The
      direct wave moment").
    - Monte Carlo: `dt` [s], `excitation` ("filter" | "superposition"), `filter_order`, `phi0` [rad], `seed` (cell
      c uses `jax.random.key(SEED_STRIDE·seed + c + 1)`, recorded), `estimator` (a name in `CELL_ESTIMATORS`:
      `"brute_force"`, or `"splitting"`: the rare cells by multilevel splitting, the others by brute force),
      `rare_below` (`"splitting"`: a Monte Carlo cell is rare where its probability at the largest angle is below
      this — by the theory with `"auto"`, by the splitting run's pilot with `"monte-carlo"`; default 1e-3;
      docs/longterm.md, "Rare cells"), `chunk_size`, `memory_budget`.
    - `spreading`: a `jaxroll.sea.Spreading` (short-crested seas about each heading, every cell; beam seas then
      have parametric excitation and are computed), or None (long-crested, the default; docs/spreading.md).
    - `part`: `(i, N)` or `"i/N"`: compute only this part's units (a partial dataset, `merge_longterm`).
    - `checkpoint`: a directory; finished units are saved there and a rerun resumes.
    - `progress(done, total, phase)`: called as cells (theory) and trials (Monte Carlo) are done.

    After `jax.distributed.initialize()` the units are shared among the processes and every process returns
    the whole dataset.

    **Returns:** an `xarray.Dataset` (dims hs, tz, heading [deg], speed [m/s], ship, angle [deg]): per cell
    `weight`, `probability` with `probability_lower`/`_upper`, `capsize_probability`, `method`, `seed`, …; the
    long-term `longterm_probability`, `longterm_per_year_probability`, … ; the configuration and provenance in its
    attributes.

    **Raises:** `ValueError` for bad arguments (before any computation).
    """
    # ---- checks, before any computation --------------------------------------------------------------------
    require_float64("jaxroll.longterm")
    scatter = scatter_diagram(scatter)
    if ships is None:
        ships = [c11_representative()]
    elif not isinstance(ships, list | tuple):
        ships = [ships]
    ships = list(ships)
    check_types(ships, checkpoint)  # NumPy numbers are numbers: each converted, or refused by its name
    reals = dict(exposure=exposure, hours_per_year=hours_per_year, dt=dt, discard=discard, auto_share=auto_share,
                 auto_tolerance=auto_tolerance, skip_weight=skip_weight, refine_delta=refine_delta,
                 rare_below=rare_below, phi0=phi0)  # fmt: skip
    (exposure, hours_per_year, dt, discard, auto_share, auto_tolerance, skip_weight, refine_delta, rare_below,
     phi0) = (_real(v, n) for n, v in reals.items())  # fmt: skip
    model_factor = model_factor if model_factor == "measured" else _real(model_factor, "model_factor")
    filter_order = filter_order if filter_order == "auto" else _integer(filter_order, "filter_order")
    seed, realizations = (_integer(v, n) for n, v in dict(seed=seed, realizations=realizations).items())
    names = list(ship_names) if ship_names is not None else [s.name for s in ships]
    files = list(ship_files) if ship_files is not None else [None] * len(ships)
    grid = make_grid(scatter, ships, names, ship_weights, headings, heading_weights, speeds, speed_weights)
    _check(
        method, method in METHOD_NAMES, f"`method` must be one of {', '.join(METHOD_NAMES)}; got {method!r}."
    )
    _check(
        estimator,
        estimator in CELL_ESTIMATORS,
        f"`estimator` must be one of {', '.join(CELL_ESTIMATORS)}; got {estimator!r}.",
    )
    angles_deg = np.array([math.degrees(float(a)) for a in np.atleast_1d(np.asarray(angles, dtype=float))])
    _check(
        None,
        angles_deg.size > 0 and len(set(angles_deg.tolist())) == angles_deg.size,
        f"`angles` must be distinct angles [rad]; got {np.radians(angles_deg).tolist()}.",
    )
    for ship in ships:
        vanish = math.degrees(float(vanishing_angle(ship)))
        bad = [a for a in angles_deg if not (0 < a < vanish)]
        _check(
            None,
            not bad,
            f"`angles` must be in (0, {vanish:.1f})° (the angle of vanishing stability of "
            f"{ship.name}); got {bad}° (capsizes are counted apart, and in every exceedance).",
        )
    for name, value in (("exposure", exposure), ("hours_per_year", hours_per_year), ("dt", dt)):
        _check(
            None,
            isinstance(value, int | float) and math.isfinite(value) and value > 0,
            f"`{name}` must be a finite number > 0; got {value!r}.",
        )
    _check(
        None,
        isinstance(discard, int | float) and math.isfinite(discard) and discard >= 0,
        f"`discard` must be a finite number >= 0 [s]; got {discard!r}.",
    )
    _check(
        None,
        isinstance(realizations, int) and realizations >= 1,
        f"`realizations` must be an integer >= 1; got {realizations!r}.",
    )
    _check(
        None,
        0 <= seed <= MAX_SEED,
        f"`seed` must be an integer in [0, {MAX_SEED}] (10^12 - 1); got {seed!r}.",
    )
    check_exposure(exposure, hours_per_year)
    _check(
        None,
        isinstance(rare_below, int | float) and 0 < rare_below <= 1,
        f"`rare_below` must be in (0, 1] (a Monte Carlo cell is rare, and estimated by splitting, where its "
        f"probability is below it); got {rare_below!r}.",
    )
    _check(
        None,
        estimator != "splitting" or excitation in SPLITTING_EXCITATIONS,
        f"`estimator='splitting'` needs excitation='filter' (splitting restarts runs from the shaping filter's "
        f"state); got excitation={excitation!r}.",
    )
    _check(None, 0 < auto_share <= 1, f"`auto_share` must be in (0, 1]; got {auto_share!r}.")
    _check(None, auto_tolerance >= 0, f"`auto_tolerance` must be >= 0; got {auto_tolerance!r}.")
    _check(
        None,
        model_factor == "measured" or (isinstance(model_factor, int | float) and model_factor >= 1),
        f"`model_factor` must be 'measured' or a number >= 1; got {model_factor!r}.",
    )
    _check(None, 0 <= skip_weight < 1, f"`skip_weight` must be in [0, 1); got {skip_weight!r}.")
    _check(None, 0 <= refine_delta < 1, f"`refine_delta` must be in [0, 1); got {refine_delta!r}.")
    part = parse_part(part)
    _check(
        spreading,
        spreading is None or isinstance(spreading, Spreading),
        f"`spreading` must be a jaxroll.sea.Spreading or None; got {spreading!r}.",
    )
    spread = (
        {} if spreading is None else {"spreading": spreading.label(), "directions": spreading.num_directions}
    )

    shape = grid.shape
    n_angles = angles_deg.size
    comp_w = grid.comp_weight
    # the direct wave moment joins the roll of these cells (a ship carrying one, off head and following seas): a
    # beam sea is no longer 0, and only the Monte Carlo covers them (docs/longterm.md, "The direct wave moment")
    moment = np.broadcast_to(moment_classes(grid, spreading is not None)[:, :, None, None, None], shape)
    # long-crested beam seas have no parametric excitation (P = 0 exactly); short-crested ones have (other
    # directions); with a moment, beam seas roll
    beam = np.broadcast_to(grid.beam[None, :, None, None, None] & (spreading is None), shape) & ~moment
    # a ship with a GZ(φ, ζ) surface (`ship.restoring_surface`): no theory knows it, and its exceedance Monte Carlo
    # is refused for now (`SURFACE_MAXIMA_REFUSAL`)
    if surface_ships(grid).any():
        raise ValueError(f"`longterm`: {SURFACE_MAXIMA_REFUSAL}")
    positive = comp_w > 0
    left_out = skipped_cells(comp_w, positive & ~beam, skip_weight)
    needed = positive & ~beam & ~left_out
    if method == "theory":
        refuse_theory(grid, needed & moment)
    below, above, outside, covered = measured_allowance(
        grid.scatter.hs[:, None], grid.scatter.t01[None, :], np.asarray(grid.speeds, float)[:, None, None]
    )
    if model_factor != "measured":
        below = above = np.full(below.shape, float(model_factor))
    factor = np.stack(
        np.broadcast_arrays(*(np.broadcast_to(x, shape) for x in (below, above)))
    )  # [2, *shape]
    outside = np.broadcast_to(outside, shape) & needed
    uncovered = np.broadcast_to(~covered, shape) & needed
    seeds = grid.seeds(seed)
    n_proc, proc = jax.process_count(), jax.process_index()
    n_part, i_part = (1, 1) if part is None else (part[1], part[0])
    workers, me = n_part * n_proc, (i_part - 1) * n_proc + proc
    run_theory = method in ("theory", "auto")
    if method in ("monte-carlo",):  # the time step against every cell, before any simulation
        check_time_steps(grid, needed, dt, spreading)
    elif method == "auto":
        check_time_steps(grid, needed & moment, dt, spreading)
    needed_all, needed = needed, needed & ~moment  # the theory's cells (all of them but the moment cells)

    # ---- theory --------------------------------------------------------------------------------------------
    cells = _empty(shape, n_angles)
    cells["seed"] = seeds
    units = [
        (s, k, u)
        for s in range(shape[0])
        for k in range(shape[1])
        for u in range(shape[2])
        if needed[s, k, u].any() and _twin(grid, k, u) == k
    ]
    if run_theory:
        # `auto` needs every cell's theory to choose its Monte Carlo cells: each part computes all of it (shared
        # among the part's processes); `theory` shares the units among all workers.
        mine_units = [
            j
            for j in range(len(units))
            if (j % n_proc == proc if method == "auto" else worker_of(j, workers) == me)
        ]
        twins = {
            j: [
                k2
                for k2 in range(shape[1])
                if k2 != units[j][1]
                and _twin(grid, k2, units[j][2]) == units[j][1]
                and needed[units[j][0], k2, units[j][2]].any()
            ]
            for j in mine_units
        }
        total = int(
            sum(
                np.any([needed[s, k2, u] for k2 in (k, *twins[j])], axis=0).sum()
                for j, (s, k, u) in ((j, units[j]) for j in mine_units)
            )
        )
        done = [0]

        def tick(n):
            done[0] += n
            if progress is not None:
                progress(done[0], total, "theory")

        computed_here = np.zeros(shape, bool)
        for j in mine_units:
            s, k, u = units[j]
            # the unit's cells: needed in its class or in a class that is the same problem (zero speed: χ, 180° − χ)
            mask = np.any([needed[s, k2, u] for k2 in (k, *twins[j])], axis=0)
            ij = np.argwhere(mask)
            hs, t01 = grid.scatter.hs[ij[:, 0]], grid.scatter.t01[ij[:, 1]]
            spec = {
                "kind": "theory",
                "theory": THEORY,
                "ship": ship_to_dict(ships[s]),
                "heading_deg": float(grid.classes_deg[k]),
                "speed": float(grid.speeds[u]),
                "hs": hs.tolist(),
                "t01": t01.tolist(),
                "angles_deg": angles_deg.tolist(),
                "exposure": float(exposure),
                "refine_delta": float(refine_delta),
                **spread,
                "version": _version(),
            }
            name = f"theory_{_hash(spec)}"
            r = _load_unit(checkpoint, name)
            if r is None:
                template = class_template(
                    ships[s], float(grid.speeds[u]), float(grid.classes_deg[k]), spreading
                )
                w_unit = np.sum(
                    [np.where(needed[s, k2, u], comp_w[s, k2, u], 0.0) for k2 in (k, *twins[j])], axis=0
                )[ij[:, 0], ij[:, 1]]
                r = class_theory(
                    ships[s],
                    template,
                    hs,
                    t01,
                    np.radians(angles_deg),
                    float(exposure),
                    tick,
                    weight=w_unit,
                    refine_delta=float(refine_delta),
                )
                _save_unit(checkpoint, name, r)
            else:
                tick(len(ij))
            for k2 in (k, *twins[j]):
                sel = (s, k2, u, ij[:, 0], ij[:, 1])
                keep = needed[s, k2, u][ij[:, 0], ij[:, 1]]
                sel = tuple(x[keep] if isinstance(x, np.ndarray) else x for x in sel)
                for key, name_ in _THEORY_KEYS.items():
                    cells[key][sel] = np.asarray(r[name_])[keep] if np.ndim(r[name_]) else r[name_]
                computed_here[sel] = True
        theory_keys = tuple(_THEORY_KEYS)
        gathered = _gather({k: np.nan_to_num(cells[k], nan=0.0) for k in theory_keys}, computed_here)
        have = _gather({"c": computed_here}, computed_here)["c"] if n_proc > 1 else computed_here
        for k in theory_keys:
            cells[k] = np.where(
                have.reshape(have.shape + (1,) * (gathered[k].ndim - have.ndim)),
                gathered[k],
                np.nan if cells[k].dtype.kind == "f" else 0,
            ).astype(cells[k].dtype)
        cells["theory_doubtful"] = have & doubtful(
            cells["lyapunov_exponent"],
            cells["envelope_gamma"],
            cells["theory_capsize_probability"],
            float(exposure),
        )

    # ---- which cells get a Monte Carlo, and how many trials -------------------------------------------------
    needed = needed_all
    trials = np.zeros(shape, np.int64)
    if method == "monte-carlo":
        trials[needed] = realizations
    elif method == "auto":
        flat = lambda a: a.reshape(int(np.prod(shape)), *a.shape[5:])  # noqa: E731
        dominant, material = auto_cells(
            flat(comp_w),
            flat(np.nan_to_num(cells["theory_probability"])),
            flat(cells["theory_doubtful"] | uncovered),
            flat(needed & ~moment),
            auto_share,
            auto_tolerance,
        )
        chosen = (dominant | material).reshape(shape)
        if chosen.any():
            check_time_steps(grid, chosen, dt, spreading)
            n = neyman_allocation(
                comp_w[chosen],
                cells["theory_probability"][chosen][:, 0],
                realizations * int(chosen.sum()),
                max(2, realizations // 4),
            )
            trials[chosen] = n
        trials[needed & moment] = realizations  # no theory there: every moment cell simulated
    # which Monte Carlo cells are rare (splitting): auto by the theory, monte-carlo by each cell's pilot
    rare = np.zeros(shape, bool)
    if estimator == "splitting" and method == "auto":
        rare = rare_cells(trials, cells["theory_probability"], rare_below)
    screened = estimator == "splitting" and method == "monte-carlo"

    # ---- Monte Carlo, one cell at a time --------------------------------------------------------------------
    mc_cells = [tuple(int(x) for x in c) for c in np.argwhere(trials > 0)]
    mine_mc = [j for j in range(len(mc_cells)) if worker_of(j, workers) == me]
    # a moment cell off beam seas is simulated twice: with the moment, and without it (its parametric-only share)
    # (in a short-crested sea beam seas have a parametric excitation too: every moment cell twice)
    twice = moment & ~np.broadcast_to(grid.beam[None, :, None, None, None] & (spreading is None), shape)
    total = int(sum(trials[mc_cells[j]] * (1 + twice[mc_cells[j]]) for j in mine_mc))
    done_trials = [0]
    run_options = {"chunk_size": chunk_size, "memory_budget": memory_budget}
    if n_proc > 1:
        run_options["devices"] = jax.local_devices()
    mc_here = np.zeros(shape, bool)

    def simulate_cell(c, ship, excitation, name_c, kind="monte_carlo"):
        s, k, u, i, jj = c
        hs, t01 = float(grid.scatter.hs[i]), float(grid.scatter.t01[jj])
        speed, heading = float(grid.speeds[u]), float(grid.classes_deg[k])
        screened_c = screened and name_c == "splitting"
        spec = {
            "kind": kind,
            "estimator": name_c,
            **({"rare_below": float(rare_below)} if screened_c else {}),
            "ship": ship_to_dict(ship),
            "heading_deg": heading,
            "speed": speed,
            "hs": hs,
            "t01": t01,
            "angles_deg": angles_deg.tolist(),
            "exposure": float(exposure),
            "discard": float(discard),
            "n": int(trials[c]),
            "seed": int(seeds[c]),
            "dt": float(dt),
            "excitation": excitation,
            "filter_order": filter_order if filter_order == "auto" else int(filter_order),
            "phi0": float(phi0),
            **spread,
            "version": _version(),
        }
        name = f"mc_{_hash(spec)}"
        r = _load_unit(checkpoint, name)
        base = done_trials[0]
        if r is None:
            problem = cell_problem(
                ship,
                hs,
                t01,
                speed,
                heading,
                excitation=excitation,
                dt=dt,
                filter_order=filter_order,
                phi0=phi0,
                spreading=spreading,
            )
            inner = (
                None if progress is None else (lambda n, base=base: progress(base + n, total, "monte_carlo"))
            )
            est = CELL_ESTIMATORS[name_c](
                problem,
                jax.random.key(int(seeds[c])),
                angles_deg=angles_deg,
                exposure=float(exposure),
                discard=float(discard),
                num_realizations=int(trials[c]),
                progress=inner,
                checkpoint=None if checkpoint is None else Path(checkpoint) / name,
                **({"brute_force_above": float(rare_below)} if screened_c else {}),
                **run_options,
            )
            r = {
                "probability": est.probability,
                "lower": est.lower,
                "upper": est.upper,
                "variance": est.variance,
                "capsize": np.array(
                    [est.capsize_probability, est.capsize_lower, est.capsize_upper, est.capsize_variance]
                ),
                "n": np.array([est.n_realizations, est.n_capsized]),
                "n_exceeded": est.n_exceeded,
                "n_exceeded_effort": est.n_exceeded_effort,
                "estimator": np.array(ESTIMATORS.index(est.estimator)),
                "cost_trials": np.array(est.cost_trials),
            }
            _save_unit(checkpoint, name, r)
        done_trials[0] = base + int(trials[c])
        if progress is not None:
            progress(done_trials[0], total, "monte_carlo")
        return r

    for j in mine_mc:
        c = mc_cells[j]
        if moment[c]:  # the superposition makes both excitations; no splitting (it restarts a filter's state)
            r = simulate_cell(c, ships[c[0]], MOMENT_EXCITATION, "brute_force")
            if twice[c]:
                rp = simulate_cell(
                    c, parametric_only(ships[c[0]]), excitation, "brute_force", "parametric_only"
                )
                for key, name_ in zip(
                    PARAMETRIC_KEYS, ("probability", "lower", "upper", "variance"), strict=True
                ):
                    cells[key][c] = rp[name_]
        else:
            r = simulate_cell(
                c, ships[c[0]], excitation, "splitting" if rare[c] or screened else "brute_force"
            )
        cells["probability"][c] = r["probability"]
        cells["probability_lower"][c], cells["probability_upper"][c] = r["lower"], r["upper"]
        cells["variance"][c] = r["variance"]
        (
            cells["capsize_probability"][c],
            cells["capsize_lower"][c],
            cells["capsize_upper"][c],
            cells["capsize_variance"][c],
        ) = r["capsize"]
        cells["realizations"][c], cells["n_capsized"][c] = r["n"]
        cells["n_exceeded"][c] = r["n_exceeded"]
        cells["n_exceeded_effort"][c] = r["n_exceeded_effort"]
        # (a unit saved before the estimators were recorded is a brute-force one)
        cells["estimator"][c] = r.get("estimator", ESTIMATORS.index("brute_force"))
        cells["cost_trials"][c] = r.get("cost_trials", r["n"][0])
        mc_here[c] = True
    mc_keys = (
        "probability",
        "probability_lower",
        "probability_upper",
        "variance",
        "capsize_probability",
        "capsize_lower",
        "capsize_upper",
        "capsize_variance",
        "realizations",
        "n_capsized",
        "n_exceeded",
        "n_exceeded_effort",
        "estimator",
        "cost_trials",
        *PARAMETRIC_KEYS,
    )
    if n_proc > 1:
        got = _gather({k: np.nan_to_num(cells[k], nan=0.0) for k in mc_keys}, mc_here)
        have = _gather({"c": mc_here}, mc_here)["c"]
        for k in mc_keys:
            cells[k] = np.where(have.reshape(have.shape + (1,) * (got[k].ndim - have.ndim)), got[k], cells[k])
        mc_here = have
    is_mc = trials > 0

    # ---- every cell's method, value and interval ------------------------------------------------------------
    cells["theory_outside_validated_map"] = outside & ~is_mc
    fill_cells(cells, shape, method, comp_w, beam, left_out, needed, is_mc, factor)
    fill_parametric(
        cells, moment, np.broadcast_to(grid.beam[None, :, None, None, None] & (spreading is None), shape)
    )
    if part is not None or n_proc > 1:
        if part is not None:
            mine = np.zeros(shape, bool)
            mine[is_mc] = np.isin(
                np.arange(len(mc_cells)) % workers, [(i_part - 1) * n_proc + q for q in range(n_proc)]
            )
            if method == "theory":
                mine |= _responsible_cells(grid, units, needed, workers, i_part, n_proc)
            elif method == "auto":
                mine |= _responsible_cells(grid, units, needed & ~is_mc, workers, i_part, n_proc)
            cells["computed"] = mine
            not_mine = (needed | is_mc) & ~mine
            for k in (
                "probability",
                "probability_lower",
                "probability_upper",
                "variance",
                "capsize_probability",
                "capsize_lower",
                "capsize_upper",
                "capsize_variance",
                "theory_probability",
                "theory_capsize_probability",
                "lyapunov_exponent",
                "envelope_gamma",
                "theory_pass1_probability",
                "theory_pass1_capsize_probability",
                "cost_trials",
                "parametric_probability",
                "parametric_lower",
                "parametric_upper",
            ):
                extra = (1,) * (cells[k].ndim - len(shape))
                cells[k] = np.where(not_mine.reshape(shape + extra), np.nan, cells[k])
            for k in (
                "realizations",
                "n_capsized",
                "n_exceeded",
                "n_exceeded_effort",
                "theory_doubtful",
                "theory_refined",
                "estimator",
            ):
                extra = (1,) * (cells[k].ndim - len(shape))
                cells[k] = np.where(not_mine.reshape(shape + extra), 0, cells[k]).astype(cells[k].dtype)
            cells["method"] = np.where(not_mine, METHODS.index("not_computed"), cells["method"])
    config = run_config(
        grid,
        files,
        angles_deg,
        exposure,
        method,
        realizations,
        discard,
        dt,
        excitation,
        filter_order,
        phi0,
        seed,
        hours_per_year,
        auto_share,
        auto_tolerance,
        model_factor,
        skip_weight,
        estimator,
        refine_delta,
        rare_below,
        spreading,
    )
    attrs = dataset_attrs(config, **({} if part is None else {"part": f"{i_part}/{n_part}"}))
    ds = build_dataset(grid, cells, config, attrs)
    return add_longterm(ds)


#: The theory's per-cell arrays: the cells' name → `class_theory`'s.
_THEORY_KEYS = {
    "theory_probability": "probability",
    "theory_capsize_probability": "capsize_probability",
    "lyapunov_exponent": "lyapunov_exponent",
    "envelope_gamma": "envelope_gamma",
    "theory_pass1_probability": "pass1_probability",
    "theory_pass1_capsize_probability": "pass1_capsize_probability",
    "theory_refined": "refined",
    "theory_pass_ratio": "pass_ratio",
    "theory_pass_capsize_ratio": "pass_capsize_ratio",
}


def _version() -> str:
    from .._version import __version__

    return __version__


def _empty(shape, n_angles) -> dict:
    f = lambda *extra: np.full(shape + extra, np.nan)  # noqa: E731
    z = lambda *extra: np.zeros(shape + extra, np.int64)  # noqa: E731
    return {
        "probability": f(n_angles),
        "probability_lower": f(n_angles),
        "probability_upper": f(n_angles),
        "variance": np.zeros(shape + (n_angles,)),
        "capsize_probability": f(),
        "capsize_lower": f(),
        "capsize_upper": f(),
        "capsize_variance": np.zeros(shape),
        "realizations": z(),
        "n_capsized": z(),
        "n_exceeded": z(n_angles),
        "n_exceeded_effort": z(len(EFFORT_FRACTIONS), n_angles),
        "theory_probability": f(n_angles),
        "theory_capsize_probability": f(),
        "lyapunov_exponent": f(),
        "envelope_gamma": f(),
        "theory_doubtful": np.zeros(shape, bool),
        "theory_outside_validated_map": np.zeros(shape, bool),
        "theory_pass1_probability": f(n_angles),
        "theory_pass1_capsize_probability": f(),
        "theory_refined": np.zeros(shape, bool),
        "theory_pass_ratio": np.ones(shape),
        "theory_pass_capsize_ratio": np.ones(shape),
        "method": z(),
        "uncertainty": z(),
        "estimator": z(),
        "cost_trials": f(),
        **empty_parametric(shape, n_angles),
    }


def merge_longterm(datasets, names=None):
    """The full dataset from the partial datasets of `longterm(part=(i, N))`, i = 1 … N (bit for bit the dataset
    of one run: `_dataset.merge_parts`; `names`: the datasets' names in messages). **Raises:** `ValueError` when they
    are not the complete, unchanged parts of one run written by this jaxroll and JAX."""
    from ._dataset import merge_parts

    return merge_parts(list(datasets), names)
