"""Ship files (TOML): read and write a `Ship`'s roll-model parameters (format: docs/ship_file.md).

The fields, their sections and units are the one table `jaxroll.ship._ship._FIELDS`; a ship read from a file is
checked by `jaxroll.ship._ship.validate_ship`.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import equinox as eqx
import numpy as np

from ..ship._restoring_surface import RestoringSurface
from ..ship._ship import _FIELDS, Ship, _parameter_tables, validate_ship
from ..ship._wave_moment import moment_table

WAVE_MOMENT = "wave_moment"
"""Optional table of a ship file: the hull's direct wave roll moment F(ω, χ) [N m per m of wave amplitude]
(`source`, `omega_rad_s`, `heading_rad`, `moment_real_N`, `moment_imag_N`; docs/ship_file.md)."""
_MOMENT_KEYS = ("source", "omega_rad_s", "heading_rad", "moment_real_N", "moment_imag_N")
_RADIATION_KEYS = ("added_inertia_kg_m2", "radiation_damping_N_m_s")
"""Optional keys of `[wave_moment]` (a BEM table, `source = "bem"`): A44(ω) and B44(ω) about G on `omega_rad_s`."""

RESTORING_SURFACE = "restoring_surface"
"""Optional table of a ship file: the hull's GZ(φ, ζ_mid) surface beyond the polynomial model (`source`,
`heel_max_rad`, `zeta_min_m`, `zeta_max_m`, `coefficients`, `fit_rms_m`, `fit_max_error_m`; docs/ship_file.md)."""
_SURFACE_KEYS = (
    "source",
    "heel_max_rad",
    "zeta_min_m",
    "zeta_max_m",
    "coefficients",
    "fit_rms_m",
    "fit_max_error_m",
)

DAMPING_SOURCE_KEY = "source"
"""Optional text key of the `[damping]` table: where b1, b2, b3 come from (e.g. a decay test, the simplified
Ikeda method). Older files without it remain valid; see docs/ship_file.md."""


def ship_to_dict(ship: Ship, *, damping_source: str | None = None) -> dict[str, Any]:
    """The ship as the nested dictionary of its TOML file (SI units; see docs/ship_file.md).

    `damping_source`: text stored as `[damping] source` (where b1..b3 come from); None writes no such key.
    """
    out: dict[str, Any] = {"name": ship.name}
    if ship.provenance:
        out["provenance"] = ship.provenance
    out.update(_parameter_tables(ship))
    if damping_source is not None:
        out["damping"] = {DAMPING_SOURCE_KEY: str(damping_source), **out["damping"]}
    table = ship.wave_moment
    if table is not None:  # F = (F/I44)·I44, rows per heading
        force = np.asarray(table.values) * float(table.inertia)
        out[WAVE_MOMENT] = {
            "source": table.source,
            "omega_rad_s": np.asarray(table.omega).tolist(),
            "heading_rad": np.asarray(table.headings).tolist(),
            "moment_real_N": force.real.tolist(),
            "moment_imag_N": force.imag.tolist(),
        }
        if table.added_inertia is not None:
            out[WAVE_MOMENT][_RADIATION_KEYS[0]] = np.asarray(table.added_inertia).tolist()
            out[WAVE_MOMENT][_RADIATION_KEYS[1]] = np.asarray(table.radiation_damping).tolist()
    surface = ship.restoring_surface
    if surface is not None:
        out[RESTORING_SURFACE] = {
            "source": surface.source,
            "heel_max_rad": float(surface.heel_max),
            "zeta_min_m": float(surface.zeta_min),
            "zeta_max_m": float(surface.zeta_max),
            "coefficients": np.asarray(surface.coefficients).tolist(),
            "fit_rms_m": float(surface.fit_rms),
            "fit_max_error_m": float(surface.fit_max_error),
        }
    return out


def _surface_from_dict(table: Any, source: str) -> RestoringSurface:
    """The `[restoring_surface]` table of a ship file as a `RestoringSurface`."""
    where = f"{source}: [{RESTORING_SURFACE}]"
    if not isinstance(table, dict):
        raise ValueError(f"{where} must be a table; got {type(table).__name__}.")
    unknown, missing = sorted(set(table) - set(_SURFACE_KEYS)), [k for k in _SURFACE_KEYS if k not in table]
    if unknown or missing:
        raise ValueError(
            f"{where} needs exactly the fields {list(_SURFACE_KEYS)}; "
            + (f"unknown {unknown}" if unknown else f"missing {missing}")
            + ". See docs/ship_file.md."
        )
    values = {}
    for key in _SURFACE_KEYS[1:]:
        v = table[key]
        try:
            arr = np.asarray(v, dtype=float)
        except (TypeError, ValueError):
            arr = None
        if (
            arr is None
            or isinstance(v, bool)
            or (key == "coefficients") != (arr.ndim == 2)
            or (key != "coefficients" and arr.ndim != 0)
        ):
            what = (
                "rows of numbers (one row per heel power φ³, φ⁵, …)" if key == "coefficients" else "a number"
            )
            raise ValueError(f"{where} {key} must be {what}; got {v!r}. See docs/ship_file.md.")
        values[key] = arr
    try:
        return RestoringSurface(
            values["coefficients"],
            heel_max=values["heel_max_rad"],
            zeta_min=values["zeta_min_m"],
            zeta_max=values["zeta_max_m"],
            fit_rms=values["fit_rms_m"],
            fit_max_error=values["fit_max_error_m"],
            source=str(table["source"]),
        )
    except ValueError as e:
        raise ValueError(f"{where}: {e} See docs/ship_file.md.") from None


def _moment_from_dict(table: Any, ship: Ship, source: str):
    """The `[wave_moment]` table of a ship file as a `WaveMoment` per the ship's roll inertia."""
    if not isinstance(table, dict):
        raise ValueError(f"{source}: [{WAVE_MOMENT}] must be a table; got {type(table).__name__}.")
    unknown = sorted(set(table) - set(_MOMENT_KEYS) - set(_RADIATION_KEYS))
    missing = [k for k in _MOMENT_KEYS if k not in table]
    if unknown or missing:
        raise ValueError(
            f"{source}: [{WAVE_MOMENT}] needs exactly the fields {list(_MOMENT_KEYS)} (and optionally "
            f"{list(_RADIATION_KEYS)}); "
            + (f"unknown {unknown}" if unknown else f"missing {missing}")
            + ". See docs/ship_file.md."
        )
    try:
        omega, heading, re, im = (np.asarray(table[k], dtype=float) for k in _MOMENT_KEYS[1:])
    except (TypeError, ValueError):
        raise ValueError(
            f"{source}: [{WAVE_MOMENT}]: omega_rad_s and heading_rad must be lists of numbers, moment_real_N and "
            "moment_imag_N lists of rows of numbers (one row per heading). See docs/ship_file.md."
        ) from None
    shape = (heading.size, omega.size)
    if re.shape != shape or im.shape != shape:
        raise ValueError(
            f"{source}: [{WAVE_MOMENT}]: moment_real_N and moment_imag_N must have one row of {omega.size} "
            f"frequencies per heading ({heading.size}); got shapes {re.shape} and {im.shape}. See docs/ship_file.md."
        )
    radiation = {}
    if any(k in table for k in _RADIATION_KEYS):
        try:
            radiation = dict(zip(("added_inertia", "radiation_damping"), (table[k] for k in _RADIATION_KEYS)))
        except KeyError:
            raise ValueError(
                f"{source}: [{WAVE_MOMENT}]: give both {' and '.join(_RADIATION_KEYS)}, or neither. See "
                "docs/ship_file.md."
            ) from None
    try:
        return moment_table(omega, heading, re + 1j * im, ship, source=str(table["source"]), **radiation)
    except ValueError as e:
        raise ValueError(f"{source}: [{WAVE_MOMENT}]: {e} See docs/ship_file.md.") from None


def damping_source(data: dict[str, Any]) -> str | None:
    """The `[damping] source` text of a ship file's dictionary, or None when the file does not say."""
    table = data.get("damping") if isinstance(data, dict) else None
    value = table.get(DAMPING_SOURCE_KEY) if isinstance(table, dict) else None
    return None if value is None else str(value)


def ship_from_dict(data: dict[str, Any], *, source: str = "<dict>") -> Ship:
    """Build a `Ship` from the nested dictionary of a ship file, with errors that name the missing/unknown field."""
    if not isinstance(data, dict):
        raise ValueError(f"{source}: a ship file must be a TOML table; got {type(data).__name__}.")
    known_sections = {s for s, *_ in _FIELDS}
    unknown = sorted(set(data) - known_sections - {"name", "provenance", WAVE_MOMENT, RESTORING_SURFACE})
    if unknown:
        raise ValueError(
            f"{source}: unknown top-level field(s) {unknown}; allowed: name, provenance, "
            f"{', '.join(f'[{s}]' for s in sorted(known_sections))}, [{WAVE_MOMENT}], [{RESTORING_SURFACE}]. See "
            "docs/ship_file.md."
        )
    values: dict[str, Any] = {"restoring": [0.0] * 4, "damping": [0.0] * 3, "delta_gm": [0.0] * 7}
    missing = []
    for section in known_sections:
        table = data.get(section)
        if table is None:
            continue
        if not isinstance(table, dict):
            raise ValueError(f"{source}: [{section}] must be a table; got {type(table).__name__}.")
        allowed = {k for s, k, *_ in _FIELDS if s == section} | (
            {DAMPING_SOURCE_KEY} if section == "damping" else set()
        )
        extra = sorted(set(table) - allowed)
        if extra:
            raise ValueError(
                f"{source}: unknown field(s) {extra} in [{section}]; allowed: {sorted(allowed)}. "
                "See docs/ship_file.md."
            )
    for section, key, attr, unit in _FIELDS:
        table = data.get(section, {})
        if key not in table:
            missing.append(f"[{section}] {key} ({unit})")
            continue
        v = table[key]
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise ValueError(f"{source}: [{section}] {key} must be a number ({unit}); got {v!r}.")
        if isinstance(attr, tuple):
            values[attr[0]][attr[1]] = float(v)
        else:
            values[attr] = float(v)
    if missing:
        raise ValueError(f"{source}: missing field(s) {', '.join(missing)}. See docs/ship_file.md.")
    provenance = str(data.get("provenance", f"ship file {source}"))
    src = data.get("damping", {}).get(DAMPING_SOURCE_KEY)
    if src is not None:
        if not isinstance(src, str):
            raise ValueError(
                f"{source}: [damping] source must be text (where b1..b3 come from); got {src!r}."
            )
        if f"damping: {src}" not in provenance:
            provenance = f"{provenance} [damping: {src}]".strip()
    ship = Ship(
        **values,
        name=str(data.get("name", Path(source).stem)),
        provenance=provenance,
    )
    validate_ship(ship)
    if WAVE_MOMENT in data:
        ship = eqx.tree_at(
            lambda s: s.wave_moment,
            ship,
            _moment_from_dict(data[WAVE_MOMENT], ship, source),
            is_leaf=lambda x: x is None,
        )
    if RESTORING_SURFACE in data:
        ship = eqx.tree_at(
            lambda s: s.restoring_surface,
            ship,
            _surface_from_dict(data[RESTORING_SURFACE], source),
            is_leaf=lambda x: x is None,
        )
    return ship


def load_ship(path: str | Path) -> Ship:
    """Read a ship file (TOML, SI units at full scale; format in docs/ship_file.md)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"Ship file {str(path)!r} does not exist.")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{path}: not valid TOML ({e}).") from None
    return ship_from_dict(data, source=str(path))


def _toml_numbers(values, indent: str, per_line: int = 6) -> str:
    """A TOML array of floats (exact `repr`s), `per_line` to a line."""
    rows = [
        ", ".join(repr(float(v)) for v in values[i : i + per_line]) for i in range(0, len(values), per_line)
    ]
    return "[\n" + ",\n".join(indent + "    " + r for r in rows) + ",\n" + indent + "]"


def ship_to_toml(ship: Ship, *, damping_source: str | None = None) -> str:
    """The ship file text (TOML) of `ship`; `damping_source` is written as `[damping] source` when given, the
    wave moment (if the ship carries one) as `[wave_moment]`, six numbers to a line."""
    import tomli_w

    data = ship_to_dict(ship, damping_source=damping_source)
    moment = data.pop(WAVE_MOMENT, None)
    lines = ["# jaxroll ship file: SI units, full scale, radians. Format: docs/ship_file.md\n"]
    text = "".join(lines) + tomli_w.dumps(data)
    if moment is not None:
        text += (
            f"\n[{WAVE_MOMENT}]\n# the hull's roll moment F(ω, χ) [N m per m of wave amplitude] about G, one row "
            "per heading (docs/wave_moment.md)\n"
            f"source = {tomli_w.dumps({'s': moment['source']})[4:]}"
            f"omega_rad_s = {_toml_numbers(moment['omega_rad_s'], '')}\n"
            f"heading_rad = {_toml_numbers(moment['heading_rad'], '')}\n"
        )
        for key in ("moment_real_N", "moment_imag_N"):
            rows = ",\n".join("    " + _toml_numbers(r, "    ") for r in moment[key])
            text += f"{key} = [\n{rows},\n]\n"
        for key in _RADIATION_KEYS:
            if key in moment:
                text += f"{key} = {_toml_numbers(moment[key], '')}\n"
    return text
