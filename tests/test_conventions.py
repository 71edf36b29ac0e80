"""The conventions of the public API (docs/conventions.md): one angle rule over every public function, class,
field and property; and the small promises of issue 45 (item 15): `--quiet` on every command, parameter objects that
show their numbers, `Record.to_xarray()`."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re

import numpy as np
import pytest

import jaxroll as jxr

SUBPACKAGES = ("", "sea", "ship", "roll", "laws", "theory", "extremes", "calibration", "criteria", "io", "longterm",
               "notebook", "plotting")  # fmt: skip

#: Words that make a name an angle (a roll, heel or heading angle, or a roll amplitude).
ANGLE_WORDS = {"angle", "angles", "heading", "headings", "phi", "phi0", "heel", "heels", "chi", "theta", "roll",
               "amplitude", "amplitudes"}  # fmt: skip
#: Words that make such a name something else: a period, a rate, a count, an index, weights, a source.
NOT_ANGLE_WORDS = {"period", "gyradius", "rate", "moments", "source", "weights", "index", "n", "num", "log",
                   "noise", "hysteresis", "smoothing", "class", "classes", "convention", "sampling", "moment"}  # fmt: skip
#: Angle-like names that are not angles, by where they are.
NOT_ANGLES = {
    ("calibrated_ship", "roll"): "a roll fit (RollFit or TimeDomainFit)",
    ("import_record", "roll"): "the roll column's name or number in the lab's file",
    ("fit_captive", "polynomial_degree"): "the degree of a polynomial",
    (
        "RollProblem",
        "capsize_angle",
    ): None,  # radians: checked like the others (listed to show the rule's reach)
}
DEGREE_UNIT = re.compile(r"\[\s*(deg|degree|degrees|°)\b|\bin degrees\b|\[°")
RADIAN_UNIT = re.compile(r"\[\s*rad\b(?!/)")


def _public_objects():
    """(where, name, object) of every public function and class of jaxroll and its subpackages."""
    seen = set()
    for sub in SUBPACKAGES:
        module = jxr if not sub else importlib.import_module(f"jaxroll.{sub}")
        names = jxr.__all__ if not sub else [n for n in vars(module) if not n.startswith("_")]
        for name in names:
            obj = getattr(jxr if not sub else module, name)
            if inspect.ismodule(obj) or id(obj) in seen or not (inspect.isclass(obj) or callable(obj)):
                continue
            if not getattr(obj, "__module__", "").startswith("jaxroll"):
                continue
            seen.add(id(obj))
            yield f"jaxroll.{sub + '.' if sub else ''}{name}", name, obj


def _angle_names(obj):
    """(kind, name, docstring) of the parameters, fields and properties of `obj` whose names are angle-like."""
    out = []
    doc = inspect.getdoc(obj) or ""
    targets = [obj]
    if inspect.isclass(obj):
        doc += "\n" + (inspect.getdoc(obj.__init__) or "")
        targets += [v for k, v in vars(obj).items() if not k.startswith("_") and inspect.isfunction(v)]
        if dataclasses.is_dataclass(obj):
            out += [("field", f.name, doc) for f in dataclasses.fields(obj) if not f.name.startswith("_")]
        for k, v in vars(obj).items():
            if isinstance(v, property) and not k.startswith("_"):
                out.append(("property", k, (inspect.getdoc(v) or "") + "\n" + doc))
    for target in targets:
        try:
            params = inspect.signature(target).parameters
        except (TypeError, ValueError):
            continue
        tdoc = doc + "\n" + (inspect.getdoc(target) or "")
        out += [("parameter", p, tdoc) for p in params if p not in ("self", "cls")]
    return [(kind, n, d) for kind, n, d in out if _is_angle(n) or "deg" in n]


def _is_angle(name: str) -> bool:
    words = set(name.lower().split("_"))
    return bool(words & ANGLE_WORDS) and not words & NOT_ANGLE_WORDS


def _lines_about(name: str, doc: str) -> list[str]:
    """The docstring's lines that describe `name`: where it is written as `name` (or `name` [unit], `name`:)."""
    pattern = re.compile(rf"`{re.escape(name)}`|^\s*-?\s*{re.escape(name)}\s*[\[:(]")
    return [line for line in doc.splitlines() if pattern.search(line)]


def _unit_after(name: str, line: str) -> str:
    """The text of `line` from `name` up to the next name in backticks (the unit written after it)."""
    start = line.find(f"`{name}`")
    start = 0 if start < 0 else start + len(name) + 2
    nxt = line.find("`", start)
    return line[start : nxt if nxt >= 0 else None]


def test_one_angle_rule_over_the_public_api():
    """Radians everywhere in Python; an argument, field or property in degrees says so with `_deg` in its name
    (`angle_deg`, `heading_deg`, `bins_deg`), and an angle-like name without it (`angle`, `heading`, `phi0`,
    `heels`) is in radians: its docstring never gives it in degrees. No other spelling of degrees (`degrees`,
    `_degree`) in a name. (docs/conventions.md, "Angles in the Python API".)"""
    broken, checked = [], 0
    for where, name, obj in _public_objects():
        for kind, arg, doc in _angle_names(obj):
            if (name, arg) in NOT_ANGLES and NOT_ANGLES[(name, arg)] is not None:
                continue
            checked += 1
            words = arg.split("_")
            if any("deg" in w and not re.fullmatch(r"(\d+)?deg", w) for w in words):  # `sf_20deg`: SF at 20°
                broken.append(f"{where} {kind} {arg!r}: degrees are spelled `_deg`")
                continue
            about = _lines_about(arg, doc)
            units = [_unit_after(arg, line) for line in about]
            if "deg" in words:
                if any(RADIAN_UNIT.match(u.strip()) for u in units):
                    broken.append(f"{where} {kind} {arg!r}: named in degrees but documented in radians")
            elif any(DEGREE_UNIT.search(u) for u in units):
                broken.append(f"{where} {kind} {arg!r}: in degrees without `_deg` ({units})")
    assert checked > 150, checked  # the walk reaches the API (≈ 200 angle-like names)
    assert not broken, "\n".join(broken)


def test_the_rule_catches_a_function_that_breaks_it():
    """The walk's checks fail on the mistakes it exists for (a test that cannot fail is a defect)."""

    def bad(angle, heading_degrees, phi0_deg):
        """**Arguments:** `angle` [deg]: the threshold; `heading_degrees`: χ; `phi0_deg` [rad]: the initial roll."""

    found = {a: _unit_after(a, line) for _, a, doc in _angle_names(bad) for line in _lines_about(a, doc)}
    assert set(found) == {"angle", "heading_degrees", "phi0_deg"}
    assert DEGREE_UNIT.search(found["angle"]) and RADIAN_UNIT.match(found["phi0_deg"].strip())
    assert "deg" not in "heading_degrees".split("_")


def test_longterm_takes_radians_and_names_its_degrees():
    """`longterm(headings=, angles=)` take radians (their names carry no unit); its dataset's angles are in
    degrees and say so: `heading_deg`, `heading_class_deg`, `angle_deg` (they were `heading`, `angle`)."""
    from jaxroll.longterm._dataset import CELL_DIMS

    doc = inspect.getdoc(jxr.longterm)
    assert re.search(r"`headings`: χ \[rad\]", doc) and re.search(r"`angles`: roll angles \[rad\]", doc)
    assert CELL_DIMS == ("hs", "tz", "heading_deg", "speed", "ship")
    from jaxroll._labels._layouts import LONGTERM

    assert LONGTERM.labels["longterm"] == "angle_deg" and LONGTERM.coords["angle_deg"][0] == "degree"


def test_every_degree_unit_of_the_layouts_is_named_deg():
    """Labelled results follow the same rule: a variable or coordinate in degrees has `_deg` in its name."""
    from jaxroll._labels import _layouts as layouts
    from jaxroll._labels._tree import Layout

    for lay in vars(layouts).values():
        if isinstance(lay, Layout):
            for name, unit in [*lay.units.items(), *((k, c[0]) for k, c in lay.coords.items())]:
                if unit == "degree":
                    assert "_deg" in name, name


@pytest.mark.parametrize("command", ["theory", "sgisc", "hydrostatics", "pdf", "risk", "longterm", "sweep"])
def test_quiet_is_accepted_by_every_command(command):
    """`--quiet` is accepted by every command that computes (scripts pass it to all; issue 45)."""
    from jaxroll._cli import build_parser

    hull = ["c11"] if command in ("sgisc", "hydrostatics") else []  # their one positional argument
    args = build_parser(command).parse_args([command, *hull, "--quiet"])
    assert args.quiet is True


def test_parameter_objects_show_their_numbers():
    """`repr(ITTC(hs=5, t01=10))` shows the numbers, not `f64[]` (issue 45); arrays of up to 8 as lists."""
    assert repr(jxr.ITTC(hs=5.0, t01=10.0)) == "ITTC(hs=5.0, t01=10.0)"
    assert repr(jxr.JONSWAP(hs=4.0, tp=9.0)).startswith("JONSWAP(hs=4.0, tp=9.0, gamma=3.3")
    text = repr(jxr.c11_representative())
    assert "gm0=1.9299" in text and "damping=[0.007725227836696213, 0.5, 0.0]" in text


def test_record_to_xarray():
    """`Record.to_xarray()`: the channels on the full-scale time, model time and file lines as coordinates, the
    header in the attributes, the numbers the record holds."""
    from importlib.resources import files

    path = files("jaxroll") / "data" / "records" / "captive" / "captive_H7_T10_heel00_r01.csv.gz"
    record = jxr.load_record(str(path))
    ds = record.to_xarray()
    np.testing.assert_array_equal(ds.time, record.time)
    np.testing.assert_array_equal(ds.wave, record.wave)
    np.testing.assert_array_equal(ds.delta_gm, record.delta_gm)
    np.testing.assert_allclose(ds.model_time, record.time / 10.0, rtol=1e-15)
    assert ds.wave.attrs["units"] == "m" and ds.time.attrs["units"] == "s" and ds.attrs["kind"] == "captive"
    assert ds.attrs["scale"] == 100.0 and ds.attrs["meta_wave_height_full_m"] == 7.0
    assert int(ds.line[0]) == int(record.lines[0])
