"""How results show themselves in Jupyter (no numerics): HTML summary tables for `_repr_html_`, and progress bars.

Every stage may use it (like `_compiled`): the result types' `_repr_html_` methods build their tables with
`html_table`, and the Monte Carlo entry points turn `progress=True` into a bar with `progress_bar` (tqdm's notebook
widget in Jupyter, its text bar elsewhere).
"""

from __future__ import annotations

import contextlib
import html
import math
import sys
from collections.abc import Callable, Iterator, Sequence
from typing import Any

_STYLE = (
    "<style>.jaxroll-table td,.jaxroll-table th{padding:1px 8px;text-align:right}"
    ".jaxroll-table td:first-child,.jaxroll-table th:first-child{text-align:left}"
    ".jaxroll-table caption{text-align:left;font-weight:bold;padding-bottom:2px}"
    ".jaxroll-note{font-size:smaller;opacity:.8}</style>"
)


def fmt(value: Any, digits: int = 4) -> str:
    """A number as a short string (`digits` significant digits); None and NaN as `—`, ±inf as `∞`."""
    if value is None:
        return "—"
    if isinstance(value, str):
        return value
    try:
        x = float(value)
    except (TypeError, ValueError):
        return str(value)
    if math.isnan(x):
        return "—"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if x != 0 and (abs(x) >= 10**digits or abs(x) < 1e-3):
        return f"{x:.{digits - 1}e}"
    return f"{x:.{digits}g}"


def fmt_interval(lo: Any, hi: Any, digits: int = 3) -> str:
    """`[lo, hi]` with `fmt`."""
    return f"[{fmt(lo, digits)}, {fmt(hi, digits)}]"


def html_table(
    title: str,
    rows: Sequence[Sequence[Any]],
    *,
    header: Sequence[str] | None = None,
    note: str | None = None,
    max_rows: int = 200,
) -> str:
    """A compact HTML table: a caption, an optional header row, rows of cells (strings are escaped, numbers go
    through `fmt`), and a note under it. More than `max_rows` rows are cut with a line saying how many."""
    parts = [_STYLE, '<table class="jaxroll-table">', f"<caption>{html.escape(title)}</caption>"]
    if header is not None:
        parts.append("<tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in header) + "</tr>")
    for row in rows[:max_rows]:
        cells = (c if isinstance(c, str) else fmt(c) for c in row)
        parts.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells) + "</tr>")
    if len(rows) > max_rows:
        width = len(header) if header is not None else len(rows[0])
        parts.append(f'<tr><td colspan="{width}">… {len(rows) - max_rows} more rows</td></tr>')
    parts.append("</table>")
    if note:
        parts.append(f'<div class="jaxroll-note">{html.escape(note)}</div>')
    return "".join(parts)


def estimate_cell(value: float, std_error: float) -> str:
    """`value ± SE` with the SE to 2 significant digits and the value to the same decimal place."""
    if not (math.isfinite(std_error) and std_error > 0):
        return fmt(value, 6)
    decimals = max(0, 1 - math.floor(math.log10(std_error)))
    return f"{value:.{decimals}f} ± {std_error:.2g}" if decimals < 10 else f"{value:.3e} ± {std_error:.2g}"


def in_notebook() -> bool:
    """Whether this process is a Jupyter kernel (IPython's ZMQ shell), where widgets can be shown."""
    ipython = sys.modules.get("IPython")
    if ipython is None:
        return False
    shell = ipython.get_ipython()
    return shell is not None and type(shell).__name__ == "ZMQInteractiveShell"


@contextlib.contextmanager
def progress_bar(
    progress: Callable[[int], None] | bool | None, total: int, description: str
) -> Iterator[Callable[[int], None] | None]:
    """The `progress` callback a Monte Carlo loop calls with the realizations done so far.

    `progress=True`: a tqdm bar of `total` realizations (`tqdm.auto`: the notebook widget in Jupyter, a text bar on
    stderr elsewhere), closed at the end; a callable is used as given; None or False: no progress."""
    if progress is None or progress is False:
        yield None
        return
    if callable(progress):
        yield progress
        return
    if progress is not True:
        raise TypeError(f"`progress` must be True, False, None or a callable(done: int); got {progress!r}.")
    try:
        from tqdm.auto import tqdm
    except ImportError:
        raise ImportError(
            "progress=True draws a tqdm progress bar, and tqdm is not installed: pip install tqdm (or install "
            "jaxroll with its notebook extra: pip install 'jaxroll[notebook]')."
        ) from None
    bar = tqdm(total=total, desc=description, unit=" realizations", leave=True)

    def update(done: int) -> None:
        bar.update(done - bar.n)

    try:
        yield update
    finally:
        bar.close()


def estimates_table(title: str, estimates, *, note: str | None = None) -> str:
    """A table of fitted values: name, `value ± SE`, the 95 % interval and the unit, for a mapping of name →
    estimate (an object with `value`, `std_error`, `unit` and `ci95`)."""
    rows = [
        (name, estimate_cell(e.value, e.std_error), fmt_interval(*e.ci95, digits=5), e.unit)
        for name, e in estimates.items()
    ]
    return html_table(title, rows, header=("parameter", "estimate ± SE", "95 % interval", "unit"), note=note)


def module_repr(module) -> str:
    """`repr` of a parameter object (an `eqx.Module`) with its numbers: concrete 0-d arrays as floats (or ints),
    concrete 1-d arrays of up to 8 elements as lists, larger or traced arrays as equinox shows them (`f64[40]`).
    `ITTC(hs=5.0, t01=10.0)` instead of `ITTC(hs=f64[], t01=f64[])`."""
    import equinox as eqx
    import jax
    import numpy as np

    def shown(leaf):
        if isinstance(leaf, jax.core.Tracer) or not hasattr(leaf, "shape") or not hasattr(leaf, "dtype"):
            return leaf
        if leaf.ndim > 1 or leaf.size > 8 or np.dtype(leaf.dtype).kind not in "fiub":
            return leaf
        value = np.asarray(leaf).tolist()
        return _Shown(value)

    return eqx.tree_pformat(jax.tree_util.tree_map(shown, module), short_arrays=True)


class _Shown:
    """A value shown as Python shows it (`5.0`, `[1.0, 2.0]`), inside an equinox repr."""

    def __init__(self, value):
        self.value = value

    def __repr__(self) -> str:
        return repr(self.value)
