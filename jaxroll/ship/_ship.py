"""Ship parameters: the roll model's coefficients, ship files (TOML) and the default ship.

A `Ship` holds everything the 1-DOF roll equation needs, at full scale and in SI units:

    φ̈ + b1 φ̇ + b2 φ̇|φ̇| + b3 φ̇³ + a1 φ + a3 φ³ + … + a9 φ⁹ + P(t) φ = 0,
    P(t) = r · (ω0² / GM0) · ΔGM(ζ_mid(t)),   ΔGM(ζ) = Σ_k C_k ζᵏ,   r = σ_obs/σ_thr.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

DEFAULT_SHIP_NOTE = (
    "C11 (representative): the particulars are the paper's Table 1 (Katsumura et al., arXiv 2407.02728); "
    "restoring, damping and ΔGM coefficients are representative values chosen to show the paper's regime, "
    "not the real C11 data, which are unpublished."
)


class Ship(eqx.Module):
    """Roll-model parameters of one ship at full scale (SI units, radians)."""

    lpp: Float[Array, ""]
    breadth: Float[Array, ""]
    depth: Float[Array, ""]
    draught: Float[Array, ""]
    displacement: Float[Array, ""]
    block_coefficient: Float[Array, ""]
    gm0: Float[Array, ""]
    roll_period: Float[Array, ""]
    restoring: Float[Array, " 4"]
    damping: Float[Array, " 3"]
    delta_gm: Float[Array, " 7"]
    gm_correction: Float[Array, ""]
    name: str = eqx.field(static=True, default="unnamed ship")
    provenance: str = eqx.field(static=True, default="")

    def __init__(
        self,
        *,
        lpp,
        breadth,
        depth,
        draught,
        displacement,
        block_coefficient,
        gm0,
        roll_period,
        restoring,
        damping,
        delta_gm,
        gm_correction=1.0,
        name: str = "unnamed ship",
        provenance: str = "",
    ):
        scalars = dict(
            lpp=lpp,
            breadth=breadth,
            depth=depth,
            draught=draught,
            displacement=displacement,
            block_coefficient=block_coefficient,
            gm0=gm0,
            roll_period=roll_period,
            gm_correction=gm_correction,
        )
        for key, value in scalars.items():
            arr = jnp.asarray(value, dtype=float)
            if arr.shape != ():
                raise ValueError(f"Ship `{key}` must be a scalar; got shape {arr.shape}.")
            setattr(self, key, arr)
        for key, value, size in (("restoring", restoring, 4), ("damping", damping, 3), ("delta_gm", delta_gm, 7)):
            arr = jnp.asarray(value, dtype=float)
            if arr.shape != (size,):
                raise ValueError(f"Ship `{key}` must have shape ({size},); got {arr.shape}.")
            setattr(self, key, arr)
        self.name = name
        self.provenance = provenance

    @property
    def omega0(self) -> Float[Array, ""]:
        """Natural roll frequency ω0 = 2π/Tφ [rad/s]."""
        return 2 * jnp.pi / self.roll_period

    @property
    def restoring_coefficients(self) -> Float[Array, " 5"]:
        """(a1, a3, a5, a7, a9) of the restoring polynomial per unit inertia [1/s² · rad^(1−n)], a1 = ω0²."""
        return jnp.concatenate([self.omega0[None] ** 2, self.restoring])


def _default_ship() -> Ship:
    omega0 = 2 * math.pi / 24.4
    return Ship(
        lpp=262.0,
        breadth=40.0,
        depth=24.45,
        draught=11.5,
        displacement=6.7247e7,
        block_coefficient=0.56,
        gm0=1.9299,
        roll_period=24.4,
        restoring=[-0.25 * omega0**2, -0.25 * omega0**2, 0.0, 0.0],
        damping=[2 * 0.015 * omega0, 0.5, 0.0],
        delta_gm=[0.0, 0.55, 0.05, -0.004, 0.0, 0.0, 0.0],
        gm_correction=1.0,
        name="C11 (representative)",
        provenance=DEFAULT_SHIP_NOTE,
    )


def c11_representative() -> Ship:
    """The default ship "C11 (representative)".

    Table-1 particulars of the paper's C11 post-Panamax container ship (Lpp 262 m, GM0 1.9299 m, Tφ 24.4 s) with
    *representative* restoring, damping and ΔGM coefficients (CONVENTIONS.md): they reproduce the paper's
    regime but are not the real C11 data, which are unpublished.
    """
    return _default_ship()


# ----------------------------------------------------------------------------------------------------------------
# Ship files
# ----------------------------------------------------------------------------------------------------------------

# (section, key, Ship attribute or (attribute, index), unit) — the one description of the file format.
_FIELDS: tuple[tuple[str, str, Any, str], ...] = (
    ("particulars", "lpp_m", "lpp", "m"),
    ("particulars", "breadth_m", "breadth", "m"),
    ("particulars", "depth_m", "depth", "m"),
    ("particulars", "draught_m", "draught", "m"),
    ("particulars", "displacement_kg", "displacement", "kg"),
    ("particulars", "block_coefficient", "block_coefficient", "-"),
    ("particulars", "gm0_m", "gm0", "m"),
    ("particulars", "roll_period_s", "roll_period", "s"),
    ("restoring", "a3", ("restoring", 0), "1/(s² rad²)"),
    ("restoring", "a5", ("restoring", 1), "1/(s² rad⁴)"),
    ("restoring", "a7", ("restoring", 2), "1/(s² rad⁶)"),
    ("restoring", "a9", ("restoring", 3), "1/(s² rad⁸)"),
    ("damping", "b1", ("damping", 0), "1/s"),
    ("damping", "b2", ("damping", 1), "1/rad"),
    ("damping", "b3", ("damping", 2), "s/rad²"),
    *(("delta_gm", f"c{k}", ("delta_gm", k), f"m^{1 - k}") for k in range(7)),
    ("correction", "gm_ratio", "gm_correction", "-"),
)
_POSITIVE = {"lpp_m", "breadth_m", "depth_m", "draught_m", "displacement_kg", "gm0_m", "roll_period_s"}


def _get(ship: Ship, attr) -> float:
    if isinstance(attr, tuple):
        return float(getattr(ship, attr[0])[attr[1]])
    return float(getattr(ship, attr))


def ship_to_dict(ship: Ship) -> dict[str, Any]:
    """The ship as the nested dictionary of its TOML file (SI units; see docs/ship_file.md)."""
    out: dict[str, Any] = {"name": ship.name}
    if ship.provenance:
        out["provenance"] = ship.provenance
    for section, key, attr, _ in _FIELDS:
        out.setdefault(section, {})[key] = _get(ship, attr)
    return out


def validate_ship(ship: Ship) -> None:
    """Raise `ValueError` if the ship's values are physically invalid (concrete values only)."""
    d = ship_to_dict(ship)
    problems = []
    for section, key, _, unit in _FIELDS:
        v = d[section][key]
        if not math.isfinite(v):
            problems.append(f"[{section}] {key} is {v}; it must be a finite number ({unit})")
        elif key in _POSITIVE and v <= 0:
            problems.append(f"[{section}] {key} = {v} must be > 0 ({unit})")
    p = d["particulars"]
    if math.isfinite(p["draught_m"]) and math.isfinite(p["depth_m"]) and p["draught_m"] >= p["depth_m"] > 0:
        problems.append(f"draught_m = {p['draught_m']} must be below depth_m = {p['depth_m']}")
    if not 0 < p["block_coefficient"] <= 1:
        problems.append(f"block_coefficient = {p['block_coefficient']} must be in (0, 1]")
    b = d["damping"]
    if min(b["b1"], b["b2"], b["b3"]) < 0:
        problems.append(
            f"damping coefficients must be >= 0 (got b1={b['b1']}, b2={b['b2']}, b3={b['b3']}); "
            "negative damping feeds energy into the roll"
        )
    if d["correction"]["gm_ratio"] < 0:
        problems.append(f"[correction] gm_ratio = {d['correction']['gm_ratio']} must be >= 0")
    if problems:
        raise ValueError(f"Invalid ship {ship.name!r}: " + "; ".join(problems) + ".")


def ship_from_dict(data: dict[str, Any], *, source: str = "<dict>") -> Ship:
    """Build a `Ship` from the nested dictionary of a ship file, with errors that name the missing/unknown field."""
    if not isinstance(data, dict):
        raise ValueError(f"{source}: a ship file must be a TOML table; got {type(data).__name__}.")
    known_sections = {s for s, *_ in _FIELDS}
    unknown = sorted(set(data) - known_sections - {"name", "provenance"})
    if unknown:
        raise ValueError(
            f"{source}: unknown top-level field(s) {unknown}; allowed: name, provenance, "
            f"{', '.join(f'[{s}]' for s in sorted(known_sections))}. See docs/ship_file.md."
        )
    values: dict[str, Any] = {"restoring": [0.0] * 4, "damping": [0.0] * 3, "delta_gm": [0.0] * 7}
    missing = []
    for section in known_sections:
        table = data.get(section)
        if table is None:
            continue
        if not isinstance(table, dict):
            raise ValueError(f"{source}: [{section}] must be a table; got {type(table).__name__}.")
        allowed = {k for s, k, *_ in _FIELDS if s == section}
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
    ship = Ship(
        **values,
        name=str(data.get("name", Path(source).stem)),
        provenance=str(data.get("provenance", f"ship file {source}")),
    )
    validate_ship(ship)
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


def ship_to_toml(ship: Ship) -> str:
    """The ship file text (TOML) of `ship`."""
    import tomli_w

    lines = ["# jaxroll ship file: SI units, full scale, radians. Format: docs/ship_file.md\n"]
    return "".join(lines) + tomli_w.dumps(ship_to_dict(ship))


def restoring_fields_from_gz(gz_coefficients, gm0: float, roll_period: float) -> np.ndarray:
    """Convert a GZ polynomial [m] GZ = GM0 φ + g3 φ³ + … + g9 φ⁹ to (a3, a5, a7, a9) = ω0² g_n / GM0."""
    omega0 = 2 * np.pi / roll_period
    g = np.asarray(gz_coefficients, dtype=float)
    return omega0**2 * g / gm0
