"""Hull files (TOML): read and write station offsets and their `[loading]` table.

The format (full scale, SI units; unknown fields are errors) is described in `docs/hydrostatics.md`. The hull
itself is `jaxroll.ship._hull.Hull`; the loading condition `jaxroll.ship._hydrostatics.Loading`.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..ship._equilibrium import kg_for_gm
from ..ship._hull import C11_GM0, C11_PARTICULARS, Hull, _c11_hull_path, _validate_offsets, c11_like_hull
from ..ship._hydrostatics import SEAWATER_DENSITY, Loading, loading_condition

_HULL_KEYS = {"lpp_m", "depth_m", "stations_m", "waterlines_m", "half_breadths_m", "station_origin"}
_LOADING_KEYS = {"kg_m", "draught_m", "displacement_kg", "lcg_m", "water_density_kg_m3"}


def _number_list(value, label: str, source: str) -> np.ndarray:
    if not isinstance(value, list) or not value:
        raise ValueError(f"{source}: [hull] {label} must be a non-empty list of numbers [m]; got {value!r}.")
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise ValueError(f"{source}: [hull] {label}[{i}] must be a number [m]; got {v!r}.")
    return np.asarray(value, dtype=float)


def hull_from_dict(data: Mapping[str, Any], *, source: str = "<dict>") -> tuple[Hull, dict[str, float]]:
    """Build a `Hull` (and the optional `[loading]` table) from the dictionary of a hull file.

    **Returns:** `(hull, loading)` where `loading` holds the `[loading]` keys present (`kg_m`, `draught_m` or
    `displacement_kg`, `lcg_m`, `water_density_kg_m3`), checked to be numbers.

    **Raises:** `ValueError` naming the missing/unknown/malformed field and how to fix it. The format is in
    `docs/hydrostatics.md`.
    """
    if not isinstance(data, Mapping):
        raise ValueError(f"{source}: a hull file must be a TOML table; got {type(data).__name__}.")
    unknown = sorted(set(data) - {"name", "provenance", "hull", "loading"})
    if unknown:
        raise ValueError(
            f"{source}: unknown top-level field(s) {unknown}; allowed: name, provenance, [hull], [loading]. "
            "See docs/hydrostatics.md."
        )
    table = data.get("hull")
    if not isinstance(table, Mapping):
        raise ValueError(
            f"{source}: missing [hull] table (lpp_m, depth_m, stations_m, waterlines_m, half_breadths_m)."
        )
    extra = sorted(set(table) - _HULL_KEYS)
    if extra:
        raise ValueError(f"{source}: unknown field(s) {extra} in [hull]; allowed: {sorted(_HULL_KEYS)}.")
    missing = sorted(_HULL_KEYS - {"station_origin"} - set(table))
    if missing:
        raise ValueError(f"{source}: missing field(s) {missing} in [hull]. See docs/hydrostatics.md.")
    for key in ("lpp_m", "depth_m"):
        v = table[key]
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise ValueError(f"{source}: [hull] {key} must be a number [m]; got {v!r}.")
    stations = _number_list(table["stations_m"], "stations_m", source)
    waterlines = _number_list(table["waterlines_m"], "waterlines_m", source)
    rows = table["half_breadths_m"]
    if not isinstance(rows, list) or not all(isinstance(r, list) for r in rows):
        raise ValueError(
            f"{source}: [hull] half_breadths_m must be a list of rows (one per station), each a list of "
            "half-breadths [m] (one per waterline)."
        )
    if len(rows) != stations.size:
        raise ValueError(
            f"{source}: [hull] half_breadths_m has {len(rows)} rows but there are {stations.size} stations; "
            "give one row per station."
        )
    for i, row in enumerate(rows):
        if len(row) != waterlines.size:
            raise ValueError(
                f"{source}: [hull] half_breadths_m is ragged: row {i} (station x = {stations[i]} m) has "
                f"{len(row)} "
                f"values but there are {waterlines.size} waterlines; give one half-breadth per waterline "
                "(0.0 where the hull has no breadth)."
            )
        _number_list(row, f"half_breadths_m[{i}]", source)
    half_breadths = np.asarray(rows, dtype=float)
    lpp = float(table["lpp_m"])
    origin = table.get("station_origin", "ap")
    if origin not in ("ap", "amidships"):
        raise ValueError(
            f'{source}: [hull] station_origin must be "ap" (x from the aft perpendicular, the default) or '
            f'"amidships"; got {origin!r}.'
        )
    if origin == "amidships":
        stations = stations + lpp / 2
    _validate_offsets(
        stations, waterlines, half_breadths, np.asarray(lpp), np.asarray(float(table["depth_m"])), source
    )
    hull = Hull(
        stations=stations,
        waterlines=waterlines,
        half_breadths=half_breadths,
        lpp=lpp,
        depth=float(table["depth_m"]),
        name=str(data.get("name", Path(source).stem)),
        provenance=str(data.get("provenance", f"hull file {source}")),
    )
    loading = data.get("loading", {})
    if not isinstance(loading, Mapping):
        raise ValueError(f"{source}: [loading] must be a table; got {type(loading).__name__}.")
    extra = sorted(set(loading) - _LOADING_KEYS)
    if extra:
        raise ValueError(
            f"{source}: unknown field(s) {extra} in [loading]; allowed: {sorted(_LOADING_KEYS)}."
        )
    for key, v in loading.items():
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise ValueError(f"{source}: [loading] {key} must be a number (SI units); got {v!r}.")
    if "draught_m" in loading and "displacement_kg" in loading:
        raise ValueError(f"{source}: [loading] gives both draught_m and displacement_kg; keep one.")
    return hull, {k: float(v) for k, v in loading.items()}


def read_hull_file(path: str | Path) -> tuple[Hull, dict[str, float]]:
    """Read a hull file (TOML, format in `docs/hydrostatics.md`): the hull and its `[loading]` table."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"Hull file {str(path)!r} does not exist.")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{path}: not valid TOML ({e}).") from None
    return hull_from_dict(data, source=str(path))


def load_hull(path: str | Path) -> Hull:
    """Read the `Hull` of a hull file (TOML, full scale, SI; format in `docs/hydrostatics.md`)."""
    return read_hull_file(path)[0]


def loading_from_dict(hull: Hull, loading: Mapping[str, float], **overrides) -> Loading:
    """A [`Loading`][] from a hull file's `[loading]` keys, with keyword overrides (`kg`, `draught`, ...).

    Overrides given as not-None replace the file's values; a `draught` override drops the file's displacement
    and vice versa.
    """
    keys = dict(
        kg="kg_m",
        draught="draught_m",
        displacement="displacement_kg",
        lcg="lcg_m",
        water_density="water_density_kg_m3",
    )
    values = {arg: loading[key] for arg, key in keys.items() if key in loading}
    overrides = {k: v for k, v in overrides.items() if v is not None}
    if "draught" in overrides:
        values.pop("displacement", None)
    if "displacement" in overrides:
        values.pop("draught", None)
    values.update(overrides)
    if "kg" not in values:
        raise ValueError("KG is required: give `kg` [m] (CLI: --kg) or set [loading] kg_m in the hull file.")
    if "draught" not in values and "displacement" not in values:
        values["draught"] = None  # loading_condition names the problem
    return loading_condition(hull, **values)


def _fmt(v: float, digits: int) -> str:
    r = round(float(v), digits)
    return repr(r + 0.0)  # + 0.0 turns -0.0 into 0.0


def hull_to_toml(
    hull: Hull, loading: Mapping[str, float] | None = None, *, header: str = "", digits: int = 4
) -> str:
    """The hull file text (TOML) of `hull`: one offsets row per line, with an optional `[loading]` table.

    **Arguments:**

    - `hull`: the hull. `loading`: `[loading]` keys (`kg_m`, `draught_m` or `displacement_kg`, `lcg_m`,
        `water_density_kg_m3`) to store with it, or None.
    - `header`: comment lines put at the top of the file.
    - `digits`: decimals of a metre kept in the offsets (4: 0.1 mm).
    """
    import tomli_w

    lines = [f"# {line}".rstrip() for line in header.splitlines()] if header else []
    lines.append("# jaxroll hull file: full scale, SI units. Format: docs/hydrostatics.md")
    meta = {"name": hull.name, **({"provenance": hull.provenance} if hull.provenance else {})}
    lines.append(tomli_w.dumps(meta).rstrip())
    f = lambda v: _fmt(v, digits)
    stations, waterlines = np.asarray(hull.stations), np.asarray(hull.waterlines)

    def wrapped(values, per_line=10):
        chunks = [", ".join(f(v) for v in values[i : i + per_line]) for i in range(0, len(values), per_line)]
        return "[\n" + "".join(f"    {c},\n" for c in chunks) + "]"

    lines += [
        "",
        "[hull]",
        f"lpp_m = {f(hull.lpp)}",
        f"depth_m = {f(hull.depth)}",
        'station_origin = "ap"  # stations are x [m] from the aft perpendicular, positive forward',
        f"stations_m = {wrapped(stations)}",
        f"waterlines_m = {wrapped(waterlines)}  # z [m] above the baseline",
        "# half-breadths y [m]: one row per station, one column per waterline",
        "half_breadths_m = [",
    ]
    for x, row in zip(stations, np.asarray(hull.half_breadths)):
        lines.append(f"    [{', '.join(f(v) for v in row)}],  # x = {f(x)} m")
    lines.append("]")
    if loading:
        lines += ["", "[loading]", tomli_w.dumps({k: float(v) for k, v in loading.items()}).rstrip()]
    return "\n".join(lines) + "\n"


def write_c11_hull_file(path: str | Path | None = None) -> Path:
    """(Re)generate `jaxroll/data/c11_hull.toml` from `jaxroll.ship._hull.c11_like_offsets`, with KG giving GM0 = 1.9299 m.

    **Returns:** the path written.
    """
    path = _c11_hull_path() if path is None else Path(path)
    draft = c11_like_hull()
    # Round-trip through the file format first, so that KG is computed for the offsets actually stored.
    text = hull_to_toml(draft)
    hull, _ = hull_from_dict(tomllib.loads(text), source=str(path))
    kg = round(float(kg_for_gm(hull, C11_GM0, draught=C11_PARTICULARS["draught"])), 4)
    loading = {"draught_m": C11_PARTICULARS["draught"], "kg_m": kg, "water_density_kg_m3": SEAWATER_DENSITY}
    header = (
        "REPRESENTATIVE C11-like hull, NOT the real C11 lines (which are unpublished).\n"
        "Generated by jaxroll.io._hull_file.write_c11_hull_file() from the parametric formula of\n"
        "jaxroll.ship._hull.c11_like_offsets (see docs/hydrostatics.md): Lpp 262 m, B 40 m, D 24.45 m,\n"
        "d 11.5 m (paper's Table 1), flat bottom with 5 m bilge radius, flared bow with raked stem, wide "
        "transom\n"
        "aft of the AP. At d = 11.5 m, rho = 1025 kg/m3: displacement ~6.82e7 kg, Cb ~0.552 (Table 1: "
        "6.7247e7 kg,\n"
        "0.56, which are mutually consistent only at rho = 1000). KG below gives GM0 = 1.9299 m."
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(hull_to_toml(hull, loading, header=header))
    return path
