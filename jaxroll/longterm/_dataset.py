"""The long-term result as an `xarray.Dataset`: the cells' variables, the long-term values, partial datasets and
their merge, and the summary that `longterm.json` holds.

Cell dims: (hs, tz, heading, speed, ship); per angle: + angle. The long-term variables are always recomputed from
the cell variables by `add_longterm`, so a dataset merged from parts is the one a single run gives, bit for bit.
"""

from __future__ import annotations

import hashlib
import json
import math

import numpy as np

from ._moment import LONGTERM_PARAMETRIC_VARS, MOMENT_EXCITATION, dataset_variables, longterm_variables
from ._monte_carlo import EFFORT_FRACTIONS, ESTIMATORS, Z95, binomial_variance
from ._risk import annual, longterm_probability

CELL_DIMS = (
    "hs",
    "tz",
    "heading_deg",
    "speed",
    "ship",
)  # angles in degrees say so: `_deg` (docs/conventions.md)
#: `method` flag values (CF `flag_values`/`flag_meanings`).
METHODS = ("not_computed", "zero_weight", "left_out", "no_excitation", "theory", "monte_carlo")
#: `uncertainty` flag values: what a cell's interval is.
UNCERTAINTY = ("none", "sampling", "model_factor", "unknown")
_LONGTERM_VARS = (
    "longterm_probability",
    "longterm_probability_ci95",
    "longterm_sampling_sd",
    "longterm_model_below",
    "longterm_model_above",
    "longterm_per_year_probability",
    "longterm_per_year_probability_ci95",
    "longterm_per_year_rate",
    "longterm_per_year_rate_ci95",
    "longterm_capsize_probability",
    "longterm_capsize_probability_ci95",
    "longterm_capsize_per_year",
    "left_out_weight",
    "exposures_per_year",
    *LONGTERM_PARAMETRIC_VARS,
)
#: The interval's ends (the `bound` dimension, as every `*_ci95` of the labelled outputs).
BOUNDS = ("lower", "upper")


def _flags(names):
    return {"flag_values": np.arange(len(names), dtype=np.int8), "flag_meanings": " ".join(names)}


def build_dataset(grid, cells: dict, config: dict, attrs: dict):
    """The dataset from per-computation-cell arrays `cells` (shape `grid.shape` [+ angle / effort axes]; see
    `_run.longterm`), the run's `config` (JSON-able) and dataset `attrs` (provenance and the like)."""
    import xarray as xr

    k = grid.heading_class

    def to_cells(a):  # (ship, class, speed, hs, tz, ...) → (hs, tz, heading, speed, ship, ...)
        a = np.asarray(a)[:, k]
        if a.dtype.kind == "f":
            a = a + 0.0  # no negative zeros
        return np.moveaxis(a, (0, 1, 2, 3, 4), (4, 2, 3, 0, 1))

    angle_dims = (*CELL_DIMS, "angle_deg")
    data = {
        "weight": (
            CELL_DIMS,
            grid.weight,
            {
                "units": "1",
                "long_name": "cell weight: occurrence × heading × speed × loading probability (sums to 1)",
            },
        ),
        "probability": (
            angle_dims,
            to_cells(cells["probability"]),
            {
                "units": "1",
                "long_name": "short-term P(max |roll| > angle within the exposure), capsizes "
                "included (NaN: not computed)",
            },
        ),
        "probability_lower": (
            angle_dims,
            to_cells(cells["probability_lower"]),
            {
                "units": "1",
                "long_name": "95 % interval, lower (Monte Carlo: Wilson; theory: model allowance)",
            },
        ),
        "probability_upper": (
            angle_dims,
            to_cells(cells["probability_upper"]),
            {"units": "1", "long_name": "95 % interval, upper"},
        ),
        "probability_variance": (
            angle_dims,
            to_cells(cells["variance"]),
            {"units": "1", "long_name": "sampling variance of the estimate (0: theory)"},
        ),
        "capsize_probability": (
            CELL_DIMS,
            to_cells(cells["capsize_probability"]),
            {"units": "1", "long_name": "short-term P(capsize within the exposure)"},
        ),
        "capsize_probability_lower": (
            CELL_DIMS,
            to_cells(cells["capsize_lower"]),
            {"units": "1", "long_name": "95 % interval of the capsize probability, lower"},
        ),
        "capsize_probability_upper": (
            CELL_DIMS,
            to_cells(cells["capsize_upper"]),
            {"units": "1", "long_name": "95 % interval of the capsize probability, upper"},
        ),
        "capsize_probability_variance": (
            CELL_DIMS,
            to_cells(cells["capsize_variance"]),
            {"units": "1", "long_name": "sampling variance of the capsize estimate"},
        ),
        "method": (
            CELL_DIMS,
            to_cells(cells["method"]).astype(np.int8),
            {"units": "1", "long_name": "how the cell's probability was obtained", **_flags(METHODS)},
        ),
        "uncertainty": (
            CELL_DIMS,
            to_cells(cells["uncertainty"]).astype(np.int8),
            {"units": "1", "long_name": "what the cell's interval is", **_flags(UNCERTAINTY)},
        ),
        "realizations": (
            CELL_DIMS,
            to_cells(cells["realizations"]).astype(np.int64),
            {"units": "1", "long_name": "Monte Carlo trials (splitting: runs a stage; 0: none)"},
        ),
        "n_exceeded": (
            angle_dims,
            to_cells(cells["n_exceeded"]).astype(np.int64),
            {
                "units": "1",
                "long_name": "Monte Carlo trials beyond the angle or capsized (-1: splitting, no trial counts)",
            },
        ),
        "n_capsized": (
            CELL_DIMS,
            to_cells(cells["n_capsized"]).astype(np.int64),
            {"units": "1", "long_name": "Monte Carlo trials that capsized (-1: splitting)"},
        ),
        "estimator": (
            CELL_DIMS,
            to_cells(cells["estimator"]).astype(np.int8),
            {
                "units": "1",
                "long_name": "the Monte Carlo cell's estimator (splitting: the rare cells, docs/longterm.md)",
                **_flags(ESTIMATORS),
            },
        ),
        "cost_trials": (
            CELL_DIMS,
            to_cells(cells["cost_trials"]),
            {
                "units": "1",
                "long_name": "Monte Carlo cost in trials of discard + exposure (brute force: its trials; "
                "splitting: its simulated time, pilot included, over a trial's; NaN: none)",
            },
        ),
        "n_exceeded_effort": (
            (*CELL_DIMS, "effort", "angle_deg"),
            to_cells(cells["n_exceeded_effort"]).astype(np.int64),
            {
                "units": "1",
                "long_name": "trials beyond the angle among the first effort × realizations (-1: splitting)",
            },
        ),
        "seed": (
            CELL_DIMS,
            to_cells(cells["seed"]).astype(np.int64),
            {
                "units": "1",
                "long_name": "the cell's Monte Carlo seed s: jax.random.key(s); `jaxroll risk --seed s-1` "
                "reproduces it",
            },
        ),
        "theory_probability": (
            angle_dims,
            to_cells(cells["theory_probability"]),
            {"units": "1", "long_name": "the theory's probability (NaN: not evaluated)"},
        ),
        "theory_capsize_probability": (
            CELL_DIMS,
            to_cells(cells["theory_capsize_probability"]),
            {"units": "1", "long_name": "the theory's capsize probability"},
        ),
        "lyapunov_exponent": (
            CELL_DIMS,
            to_cells(cells["lyapunov_exponent"]),
            {
                "units": "s-1",
                "long_name": "envelope FPK Lyapunov exponent λ of the linearised "
                "roll (λ <= 0: the roll dies out)",
            },
        ),
        "envelope_gamma": (
            CELL_DIMS,
            to_cells(cells["envelope_gamma"]),
            {
                "units": "s-1",
                "long_name": "fitted envelope decay rate γ (<= 0: the envelope model does not fit)",
            },
        ),
        "theory_doubtful": (
            CELL_DIMS,
            to_cells(cells["theory_doubtful"]).astype(bool),
            {"units": "1", "long_name": "the theory fails a validity check (docs/longterm.md)"},
        ),
        "theory_outside_validated_map": (
            CELL_DIMS,
            to_cells(cells["theory_outside_validated_map"]).astype(bool),
            {
                "units": "1",
                "long_name": "a theory cell outside the map the theory was validated on (H1/3 4-8 m, T01 8-12 s, "
                "0-5 m/s): the widest measured allowance",
            },
        ),
        "theory_refined": (
            CELL_DIMS,
            to_cells(cells["theory_refined"]).astype(bool),
            {
                "units": "1",
                "long_name": "the theory's second pass (Richardson-extrapolated) was run; "
                "else its one-grid first pass (docs/longterm.md, Cost)",
            },
        ),
    }
    data.update(dataset_variables(to_cells, angle_dims, CELL_DIMS, cells))
    if "computed" in cells:
        data["computed"] = (
            CELL_DIMS,
            to_cells(cells["computed"]).astype(bool),
            {"units": "1", "long_name": "computed by this part"},
        )
    coords = {
        "hs": ("hs", grid.scatter.hs, {"units": "m", "long_name": "significant wave height H_s"}),
        "tz": ("tz", grid.scatter.tz, {"units": "s", "long_name": "zero-upcrossing period T_z"}),
        "t01": ("tz", grid.scatter.t01, {"units": "s", "long_name": "mean period T01 = 1.0864 T_z (ITTC)"}),
        "heading_deg": (
            "heading_deg",
            grid.headings_deg,
            {"units": "degree", "long_name": "heading χ: 0 following, 90 beam, 180 head"},
        ),
        "heading_class_deg": (
            "heading_deg",
            grid.classes_deg[k],
            {"units": "degree", "long_name": "computed at χ' = min(χ, 360 − χ) (port/starboard symmetry)"},
        ),
        "speed": ("speed", grid.speeds, {"units": "m s-1", "long_name": "ship speed U"}),
        "ship": ("ship", np.array(grid.ship_names, dtype=object), {"long_name": "loading condition (ship)"}),
        "angle_deg": (
            "angle_deg",
            np.asarray(config["angles_deg"], float),
            {"units": "degree", "long_name": "roll angle"},
        ),
        "bound": ("bound", np.array(BOUNDS), {"long_name": "end of the interval"}),
        "effort": (
            "effort",
            np.array(EFFORT_FRACTIONS),
            {"units": "1", "long_name": "fraction of each Monte Carlo cell's trials"},
        ),
    }
    ds = xr.Dataset(
        {k_: xr.Variable(*v) for k_, v in data.items()},
        coords={k_: xr.Variable(*v) for k_, v in coords.items()},
    )
    ds.attrs.update(attrs)  # `dataset_attrs(config, …)`: versions, backend, the configuration as JSON text
    if "part" in attrs:  # a partial dataset carries the digest of what it holds (`merge_parts` checks it)
        ds.attrs["part_sha256"] = part_digest(ds)
    return ds


#: What a part's digest covers besides its variables and coordinates: the configuration, the part, the versions.
_DIGEST_ATTRS = ("config_json", "part", "jaxroll_version", "jax_version", "jaxlib_version", "x64")
#: The versions the parts of one merge must share with each other and with the jaxroll that merges them.
_VERSION_ATTRS = ("jaxroll_version", "jax_version", "jaxlib_version", "x64")


def part_digest(ds) -> str:
    """SHA-256 of a partial dataset's content and configuration: the attributes `_DIGEST_ATTRS`, every coordinate
    and every variable but the long-term ones (recomputed by the merge), by name, dims and values (NaN as NaN,
    booleans and integers as int64: the same digest after a netCDF round trip)."""
    h = hashlib.sha256()
    for k in _DIGEST_ATTRS:
        h.update(f"{k}\0{ds.attrs.get(k)}\0".encode())
    names = sorted(set(ds.coords) | {v for v in ds.data_vars if v not in _LONGTERM_VARS})
    for name in names:
        a = np.asarray(ds[name].values)
        if a.dtype.kind in "biu":
            data = a.astype(np.int64).tobytes()
        elif a.dtype.kind == "f":
            f = a.astype(np.float64)
            data = np.where(np.isnan(f), np.nan, f).tobytes() + np.isnan(f).tobytes()
        else:
            data = "\0".join(str(x) for x in a.reshape(-1)).encode()
        h.update(f"{name}\0{ds[name].dims}\0{a.shape}\0".encode() + data)
    return h.hexdigest()


def config_of(ds) -> dict:
    """The configuration a dataset records (its `config_json` attribute). **Raises:** `ValueError` where there is
    none or it is not JSON (nested beyond Python's recursion limit included)."""
    try:
        cfg = json.loads(ds.attrs["config_json"])
    except KeyError:
        raise ValueError("it has no config_json attribute: not a dataset of jaxroll longterm.") from None
    except (ValueError, TypeError, RecursionError):
        raise ValueError("its config_json attribute is not the JSON jaxroll longterm writes.") from None
    if not isinstance(cfg, dict):
        raise ValueError("its config_json attribute is not the JSON jaxroll longterm writes.")
    return cfg


def add_longterm(ds):
    """The long-term variables of `ds` (over its angles), computed from its cell variables (module `_risk`):
    `longterm_probability` per exposure with its 95 % interval and the interval's parts, the capsize probability,
    the per-year probability and rate, and `left_out_weight`. Returns a new dataset."""
    import xarray as xr

    from ._risk import model_bounds

    cfg = config_of(ds)
    w = ds["weight"].values
    p = ds["probability"].values
    unc = ds["uncertainty"].values
    p0 = np.where(np.isnan(p), 0.0, p)
    var = np.where(np.isnan(p), 0.0, ds["probability_variance"].values)
    kind = np.where(unc == 2, 1, np.where(unc == 3, 2, 0))
    lo, hi = model_bounds(p0, kind, ds["probability_lower"].values, ds["probability_upper"].values)
    lt = longterm_probability(w, p0, var, lo, hi)
    c = ds["capsize_probability"].values
    c0 = np.where(np.isnan(c), 0.0, c)[..., None]
    cvar = np.where(np.isnan(c), 0.0, ds["capsize_probability_variance"].values)[..., None]
    clo, chi = model_bounds(
        c0,
        kind,
        ds["capsize_probability_lower"].values[..., None],
        ds["capsize_probability_upper"].values[..., None],
    )
    cap = longterm_probability(w, c0, cvar, clo, chi)
    per_year = cfg["hours_per_year"] * 3600.0 / cfg["exposure_s"]
    yr = annual(w, p0, var, lo, hi, per_year)
    cyr = annual(w, c0, cvar, clo, chi, per_year)
    one = {"units": "1"}
    ci = lambda r, lo, hi: np.stack([r[lo], r[hi]], axis=-1)  # noqa: E731
    new = {
        "longterm_probability": (
            ("angle_deg",),
            lt["probability"],
            {**one, "long_name": "P(max |roll| > angle within one exposure), the cells' weighted mean"},
        ),
        "longterm_probability_ci95": (
            ("angle_deg", "bound"),
            ci(lt, "lower", "upper"),
            {**one, "long_name": "95 % interval of the long-term probability (sampling and model allowance)"},
        ),
        "longterm_sampling_sd": (("angle_deg",), lt["sampling_sd"], {**one, "long_name": "(Σ w² Var P)^1/2"}),
        "longterm_model_below": (
            ("angle_deg",),
            lt["model_below"],
            {**one, "long_name": "model allowance below"},
        ),
        "longterm_model_above": (
            ("angle_deg",),
            lt["model_above"],
            {**one, "long_name": "model allowance above"},
        ),
        "longterm_per_year_probability": (
            ("angle_deg",),
            yr["probability"],
            {**one, "long_name": "P(at least one exceedance in a year) = 1 − exp(−N_y P_LT)"},
        ),
        "longterm_per_year_probability_ci95": (
            ("angle_deg", "bound"),
            ci(yr, "lower", "upper"),
            {**one, "long_name": "95 % interval of the per-year probability"},
        ),
        "longterm_per_year_rate": (
            ("angle_deg",),
            yr["rate"],
            {"units": "year-1", "long_name": "expected exposures with an exceedance per year, N_y P_LT"},
        ),
        "longterm_per_year_rate_ci95": (
            ("angle_deg", "bound"),
            ci(yr, "rate_lower", "rate_upper"),
            {"units": "year-1", "long_name": "95 % interval of the per-year rate"},
        ),
        "longterm_capsize_probability": (
            (),
            cap["probability"][0],
            {**one, "long_name": "P(capsize within one exposure), the cells' weighted mean"},
        ),
        "longterm_capsize_probability_ci95": (
            ("bound",),
            np.array([cap["lower"][0], cap["upper"][0]]),
            {**one, "long_name": "95 % interval of the long-term capsize probability"},
        ),
        "longterm_capsize_per_year": (
            (),
            cyr["probability"][0],
            {**one, "long_name": "P(at least one capsize in a year)"},
        ),
        "left_out_weight": (
            (),
            float(np.where(ds["method"].values == METHODS.index("left_out"), w, 0.0).sum()),
            {**one, "long_name": "weight of the cells left out (a bound on their contribution)"},
        ),
        "exposures_per_year": (
            (),
            per_year,
            {"units": "year-1", "long_name": "exposures per year N_y = hours at sea per year / exposure"},
        ),
    }
    new.update(longterm_variables(ds, w, p0, var, lo, hi, longterm_probability))
    ds = ds.drop_vars([v for v in _LONGTERM_VARS if v in ds])
    # + 0.0: a negative zero (1 − Π (1 − 0) in floating point) would be printed "-0" (issue 45)
    ds = ds.assign({k: xr.Variable(d, np.asarray(a, float) + 0.0, at) for k, (d, a, at) in new.items()})
    return ds


#: The cell variables a partial dataset must hold (besides `computed`), and those that are probabilities.
_PART_VARS = ("weight", "probability", "probability_lower", "probability_upper", "probability_variance",
              "capsize_probability", "capsize_probability_lower", "capsize_probability_upper",
              "capsize_probability_variance", "method", "uncertainty", "realizations", "n_exceeded", "n_capsized",
              "seed", "theory_probability", "theory_capsize_probability")  # fmt: skip
_PROBABILITIES = ("probability", "probability_lower", "probability_upper", "capsize_probability",
                  "capsize_probability_lower", "capsize_probability_upper")  # fmt: skip


def _check_part(ds, name: str) -> tuple[int, int]:
    """(i, N) of a partial dataset, after checking that it is one, whole and unchanged since jaxroll wrote it,
    written by this jaxroll and JAX, with probabilities in [0, 1] and weights that sum to 1. **Raises:**
    `ValueError` starting with `name`."""
    from ..io import provenance

    if "part" not in ds.attrs or "computed" not in ds:
        raise ValueError(f"{name} is not a partial dataset (longterm(part=…), --part i/N).")
    try:
        i, n = (int(x) for x in str(ds.attrs["part"]).split("/"))
        assert 1 <= i <= n
    except (ValueError, AssertionError):
        raise ValueError(
            f"{name}: its part attribute {str(ds.attrs['part'])[:40]!r} is not i/N with 1 <= i <= N: not a "
            "partial dataset as jaxroll longterm writes it."
        ) from None
    missing = [v for v in _PART_VARS if v not in ds]
    if missing:
        raise ValueError(f"{name} (part {i}/{n}) lacks the variables {', '.join(missing)}: rerun that part.")
    try:
        config_of(ds)
    except ValueError as e:
        raise ValueError(f"{name} (part {i}/{n}): {e}") from None
    here = {k: v for k, v in provenance().items() if k in _VERSION_ATTRS}
    theirs = {k: ds.attrs.get(k) for k in _VERSION_ATTRS}
    if theirs != here:
        differ = ", ".join(
            f"{k} {theirs[k]} (this one: {here[k]})" for k in _VERSION_ATTRS if theirs[k] != here[k]
        )
        raise ValueError(
            f"{name} (part {i}/{n}) was written by another jaxroll or JAX ({differ}): the merge recomputes the "
            "long-term values, and the parts' numbers are bit for bit only within one version. Merge with the "
            "versions that wrote the parts, or rerun them."
        )
    if ds.attrs.get("part_sha256") != part_digest(ds):
        raise ValueError(
            f"{name} (part {i}/{n}) was changed since jaxroll wrote it (its content or configuration does not match "
            "its digest, part_sha256): rerun that part."
        )
    for v in _PROBABILITIES:
        a = ds[v].values
        if np.any(~np.isnan(a) & ~((a >= 0) & (a <= 1))):
            raise ValueError(f"{name} (part {i}/{n}): {v} holds values outside [0, 1]: rerun that part.")
    computed = ds["computed"].values & np.isin(ds["method"].values, [METHODS.index("theory"),
                                                                     METHODS.index("monte_carlo")])  # fmt: skip
    if (
        np.isnan(ds["probability"].values[computed]).any()
        or np.isnan(ds["capsize_probability"].values[computed]).any()
    ):
        raise ValueError(
            f"{name} (part {i}/{n}): a cell it computed has no probability (NaN): rerun that part."
        )
    w = ds["weight"].values
    if not (np.all(np.isfinite(w)) and np.all(w >= 0) and math.isclose(float(w.sum()), 1.0, rel_tol=1e-9)):
        raise ValueError(f"{name} (part {i}/{n}): its cell weights do not sum to 1: rerun that part.")
    return i, n


def merge_parts(datasets, names=None):
    """One dataset from the partial datasets of `longterm(part=(i, N))` for i = 1 … N (any order): every variable and
    attribute the one run gives (`part`, `part_sha256` and `run_time_s` left out), bit for bit. `names`: what
    messages call the datasets (default "dataset 1", …; the CLI gives the files).

    **Raises:** `ValueError` when they are not the parts of one run: a part missing or repeated, configurations or
    coordinates that differ, a cell computed by no part or by two; or a part changed since jaxroll wrote it (its
    digest `part_sha256`), written by another jaxroll or JAX (`jaxroll_version`, `jax_version`, `jaxlib_version`,
    `x64`), lacking a variable, or holding probabilities outside [0, 1] or NaN where it computed a cell."""
    if not datasets:
        raise ValueError("no partial dataset to merge.")
    names = list(names) if names is not None else [f"dataset {k + 1}" for k in range(len(datasets))]
    parts = [_check_part(ds, name) for ds, name in zip(datasets, names, strict=True)]
    n = parts[0][1]
    if any(q[1] != n for q in parts) or sorted(q[0] for q in parts) != list(range(1, n + 1)):
        raise ValueError(
            f"the datasets are parts {sorted(f'{a}/{b}' for a, b in parts)}; the merge needs each "
            f"part 1/{n} … {n}/{n} exactly once."
        )
    ref = datasets[0]
    for ds in datasets[1:]:
        if ds.attrs["config_json"] != ref.attrs["config_json"]:
            a, b = config_of(ref), config_of(ds)
            differ = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
            raise ValueError(
                f"the parts come from different runs (configurations differ in {', '.join(differ)})."
            )
        for c in ref.coords:
            if c not in ds.coords or not np.array_equal(ds[c].values, ref[c].values):
                raise ValueError(f"the parts come from different runs (their {c} coordinates differ).")
        if not np.array_equal(ds["weight"].values, ref["weight"].values):
            raise ValueError("the parts come from different runs (their cell weights differ).")
    count = sum(ds["computed"].values.astype(int) for ds in datasets)
    trivial = ref["method"].values != METHODS.index("not_computed")  # the same in every part (no computation)
    if np.any(count > 1) or np.any((count == 0) & ~trivial):
        raise ValueError("the parts overlap or leave cells out: they are not the parts of one run.")
    out = ref.drop_vars("computed")
    cell_vars = [v for v in out.data_vars if out[v].dims[: len(CELL_DIMS)] == CELL_DIMS and v != "weight"]
    for v in cell_vars:
        values = out[v].values.copy()
        for ds in datasets[1:]:
            mask = ds["computed"].values.reshape(ds["computed"].shape + (1,) * (values.ndim - len(CELL_DIMS)))
            values = np.where(np.broadcast_to(mask, values.shape), ds[v].values, values)
        out[v] = (out[v].dims, values, out[v].attrs)
    out.attrs = {k: v for k, v in ref.attrs.items() if k not in ("part", "part_sha256", "run_time_s")}
    return add_longterm(out)


def _moment_cell(cell) -> bool:
    return "direct_moment" in cell and bool(cell["direct_moment"])


def risk_command(ds, index: dict) -> str:
    """The `jaxroll risk` command line that reproduces a Monte Carlo cell of `ds` trial for trial (its direct
    estimate), `index` the cell's coordinates by dim (hs, tz, heading_deg, speed, ship) as positions. Quoted for a POSIX
    shell (`shlex.join`): a ship file named `a b;touch x.toml` is one argument, never a second command."""
    import shlex

    cfg = config_of(ds)
    cell = ds.isel(index)
    ship_file = cfg["ships"][index["ship"]]["file"]
    parts = [
        "jaxroll", "risk",
        "--hs", repr(float(cell.hs)),
        "--t01", repr(float(cell.t01)),
        "--heading", f"{float(cell.heading_class_deg):g}",
        "--speed", repr(float(cell.speed)),
        "--hours", repr(cfg["exposure_s"] / 3600.0),
        "--discard", repr(cfg["discard_s"]),
        "--realizations", str(int(cell.realizations)),
        "--seed", str(int(cell.seed) - 1),
        "--angle", f"{float(ds.angle_deg[0]):g}",
        "--dt", repr(cfg["dt_s"]),
        "--method", str(cfg["excitation"]) if not _moment_cell(cell) else MOMENT_EXCITATION,
        "--filter-order", str(cfg["filter_order"]),
    ]  # fmt: skip
    if cfg.get("spreading", "none") != "none":
        parts += ["--spreading", str(cfg["spreading"])]
    if ship_file:
        parts += ["--ship", str(ship_file)]
    return shlex.join(parts)


def dominating_cells(ds, angle_index: int = 0, top: int = 10) -> list[dict]:
    """The `top` cells by contribution w·P at the angle of index `angle_index`, with their share of P_LT."""
    contrib = np.nan_to_num(ds["weight"].values * ds["probability"].values[..., angle_index])
    total = contrib.sum()
    order = np.argsort(-contrib.reshape(-1), kind="stable")[:top]
    out = []
    for flat in order:
        if contrib.reshape(-1)[flat] <= 0:
            break
        idx = dict(zip(CELL_DIMS, np.unravel_index(flat, contrib.shape), strict=True))
        cell = ds.isel({k: int(v) for k, v in idx.items()})
        method = METHODS[int(cell.method)]
        estimator = ESTIMATORS[int(cell.estimator)] if "estimator" in ds else "brute_force"
        row = {
            "hs_m": float(cell.hs),
            "tz_s": float(cell.tz),
            "t01_s": float(cell.t01),
            "heading_deg": float(cell.heading_deg),
            "speed_m_s": float(cell.speed),
            "ship": str(cell.ship.values),
            "weight": float(cell.weight),
            "probability": float(cell.probability[angle_index]),
            "probability_ci95": [
                float(cell.probability_lower[angle_index]),
                float(cell.probability_upper[angle_index]),
            ],
            "contribution": float(contrib.reshape(-1)[flat]),
            "share": float(contrib.reshape(-1)[flat] / total),
            "method": method,
            "theory_probability": float(cell.theory_probability[angle_index]),
        }
        if method == "monte_carlo":
            row["estimator"] = estimator
            row["realizations"] = int(cell.realizations)
            row["seed"] = int(cell.seed)
            if estimator == "brute_force":
                row["risk_command"] = risk_command(ds, {k: int(v) for k, v in idx.items()})
        out.append(row)
    return out


def _ci_effort(ds) -> dict:
    """The long-term interval's sampling part against the Monte Carlo effort: at each `effort` fraction, ±z σ from
    the first fraction of every brute-force cell's trials (angles). A splitting cell has no nested subsets of its
    runs: it enters every point with its whole run's variance and cost (`cost_trials`), so the points show what the
    brute-force cells' effort buys beside it. `trials`: the brute-force trials plus the splitting cells' cost in
    trials; `splitting_half_width`: the splitting cells' part of the half-width alone."""
    mc = ds["method"].values == METHODS.index("monte_carlo")
    if not mc.any():
        return {}
    w = ds["weight"].values
    n = ds["realizations"].values
    split = (
        mc & (ds["estimator"].values == ESTIMATORS.index("splitting")) if "estimator" in ds else mc & False
    )
    bf = mc & ~split
    var_split = np.where(split[..., None], ds["probability_variance"].values, 0.0)
    cost_split = float(np.where(split, ds["cost_trials"].values, 0.0).sum()) if split.any() else 0.0
    axes = tuple(range(w.ndim))
    trials, half = [], []
    for e, f in enumerate(ds.effort.values):
        m = np.maximum(1, np.round(f * n))
        k = ds["n_exceeded_effort"].values[..., e, :]
        var = np.where(bf[..., None], binomial_variance(np.maximum(k, 0), m[..., None]), 0.0) + var_split
        trials.append(int(np.where(bf, m, 0).sum() + round(cost_split)))
        half.append((Z95 * np.sqrt((w[..., None] ** 2 * var).sum(axis=axes))).tolist())
    out = {"trials": trials, "sampling_half_width": half}
    if split.any():
        out["splitting_cells"] = int(split.sum())
        out["splitting_half_width"] = (Z95 * np.sqrt((w[..., None] ** 2 * var_split).sum(axis=axes))).tolist()
    return out


def longterm_summary(ds, top: int = 10) -> dict:
    """What `longterm.json` holds (besides the configuration), named as the dataset's variables (`longterm/{angle}/
    probability` is `longterm_probability(angle)`; docs/outputs.md): per angle [deg] the long-term probability per
    exposure with its interval and the interval's parts, the per-year values, the dominating cells; the capsize
    probabilities, the count of cells per method, the interval against effort, the per-year assumptions."""
    cfg = config_of(ds)
    methods = {m: int((ds["method"].values == i).sum()) for i, m in enumerate(METHODS) if m != "not_computed"}
    per_angle = {}
    moment = "direct_moment" in ds and bool(ds["direct_moment"].values.any())
    for a, angle in enumerate(float(x) for x in ds.angle_deg.values):
        per_angle[f"{angle:g}"] = {
            "probability": float(ds.longterm_probability[a]),
            "probability_ci95": [float(x) for x in ds.longterm_probability_ci95[a]],
            "sampling_sd": float(ds.longterm_sampling_sd[a]),
            "model_below": float(ds.longterm_model_below[a]),
            "model_above": float(ds.longterm_model_above[a]),
            "per_year": {
                "probability": float(ds.longterm_per_year_probability[a]),
                "probability_ci95": [float(x) for x in ds.longterm_per_year_probability_ci95[a]],
                "rate": float(ds.longterm_per_year_rate[a]),
                "rate_ci95": [float(x) for x in ds.longterm_per_year_rate_ci95[a]],
            },
            "dominating_cells": dominating_cells(ds, a, top),
        }
        if moment:  # the parametric-only roll beside the total (docs/longterm.md)
            per_angle[f"{angle:g}"].update(
                parametric_probability=float(ds.longterm_parametric_probability[a]),
                parametric_probability_ci95=[float(x) for x in ds.longterm_parametric_probability_ci95[a]],
                parametric_share=float(ds.longterm_parametric_share[a]),
            )
    hours = cfg["exposure_s"] / 3600.0
    return {
        "exposure_hours": hours,
        "exposures_per_year": float(ds.exposures_per_year),
        "longterm": per_angle,
        "longterm_capsize": {
            "probability": float(ds.longterm_capsize_probability),
            "probability_ci95": [float(x) for x in ds.longterm_capsize_probability_ci95],
            "per_year": float(ds.longterm_capsize_per_year),
        },
        "per_year_assumptions": (
            f"{cfg['hours_per_year']:g} h at sea per year = {float(ds.exposures_per_year):g} exposures of "
            f"{hours:g} h; the exposures a year spends in each cell Poisson with mean w_c N_y, independent of each "
            "other: P_year = 1 − exp(−N_y P_LT) ≤ `rate` = N_y P_LT, the expected number of exposures with an "
            "exceedance per year."
        ),
        "left_out_weight": float(ds.left_out_weight),
        "cells": methods,
        "monte_carlo_estimators": {
            e: int(
                ((ds["estimator"].values == i) & (ds["method"].values == METHODS.index("monte_carlo"))).sum()
            )
            for i, e in enumerate(ESTIMATORS)
            if e != "none"
        }
        if "estimator" in ds
        else {},
        "ci_against_effort": _ci_effort(ds),
        "interval": (
            "95 %: ±1.96 (Σ w² Var P)^1/2 over the Monte Carlo cells (brute force: Agresti–Coull; splitting: the "
            "genealogy variance), plus the model allowance added "
            + (
                "linearly: theory cells within [P/f_below, f_above P], the factors measured against an "
                "exact-spectrum sea in the cell's region (speed class, T01 band; the widest measured outside the "
                "validated map: theory_outside_validated_map), "
                if cfg["model_factor"] == "measured"
                else f"linearly: theory cells within [P/{cfg['model_factor']:g}, {cfg['model_factor']:g} P], "
            )
            + "doubtful theory cells not simulated and left-out cells within [0, 1]"
        ),
        "probability_definition": (
            "P(max |roll| > angle within one exposure, or capsize), for an exposure taken "
            "at random from the cells' distribution"
        ),
    }
