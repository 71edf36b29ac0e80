"""A units side file as labs hand it over (two rows: the column names, then their units), for `import_record`."""

from __future__ import annotations

from pathlib import Path

from ._records import _err


def read_units_file(path: str | Path) -> dict[str, str]:
    """A units side file as labs hand it over: two rows, the column names and then their units, with the data
    file's delimiter (`,` `;` tab `|` or spaces), e.g. `time,x,y,z,phi,theta,psi` over `s,m,m,m,rad,rad,rad`.

    **Returns:** {column name: unit}, and {"#1": unit, "#2": …} by 1-based position (for files without names).

    **Raises:** `RecordError` when it does not hold two rows of the same length; `FileNotFoundError`."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"Units file {str(path)!r} does not exist.")
    rows = [
        ln for ln in _text(path).splitlines() if ln.strip() and not ln.lstrip().startswith(("#", "%", "//"))
    ]
    if len(rows) != 2:
        raise _err(
            str(path),
            None,
            f"a units file holds two rows (the column names, then their units); it has {len(rows)}.",
        )
    delim = next((d for d in (";", "\t", ",", "|") if d in rows[0]), " ")  # the names row's delimiter
    names, units = (_split(r, delim) for r in rows)
    if len(names) != len(units):
        raise _err(
            str(path),
            2,
            f"the units row has {len(units)} fields but the names row {len(names)}; give one unit a column.",
        )
    out = {n.strip(): u.strip() for n, u in zip(names, units)}
    out.update({f"#{j + 1}": u.strip() for j, u in enumerate(units)})
    return out


def _text(path: Path) -> str:
    data = path.read_bytes()
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def _split(line: str, delim: str) -> list[str]:
    return line.split() if delim == " " else [f.strip() for f in line.split(delim)]
