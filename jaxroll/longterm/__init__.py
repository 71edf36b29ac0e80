"""Long-term risk: the probability of exceeding a roll angle over a wave scatter diagram, headings, speeds and
loading conditions, per exposure and per year, and the cells that dominate it (docs/longterm.md).

Stage files in data-flow order: `_scatter.py` (scatter diagrams, IACS Rec. 34), `_cells.py` (the cells, their
weights and seeds, heading symmetry, parts), `_theory.py` (short-term risk by theory, batched per heading class),
`_monte_carlo.py` (short-term risk by Monte Carlo per cell, Neyman allocation), `_allowance.py` (the theory's
allowance measured against an exact-spectrum sea, per region), `_risk.py` (the long-term integral,
its interval, the per-year conversion, the `auto` rule), `_dataset.py` (the `xarray.Dataset`, merge, summary),
`_units.py` (the work units: which cells a part computes, checkpoint files, gathering across processes), `_run.py` (`longterm`).

`jaxroll.longterm` is the function (`jaxroll/__init__.py` re-exports it and the names below); this package's
names are also re-exported at the top level (`jaxroll.read_scatter`, …).
"""

from ._allowance import (
    VALIDATED_MAP as VALIDATED_MAP,
    measured_allowance as measured_allowance,
)
from ._cells import (
    HOURS_PER_YEAR as HOURS_PER_YEAR,
    MAX_FROUDE as MAX_FROUDE,
    MAX_SEED as MAX_SEED,
    SEED_STRIDE as SEED_STRIDE,
    canonical_heading_deg as canonical_heading_deg,
    check_exposure as check_exposure,
    check_speeds as check_speeds,
)
from ._dataset import (
    METHODS as METHODS,
    UNCERTAINTY as UNCERTAINTY,
    add_longterm as add_longterm,
    dominating_cells as dominating_cells,
    longterm_summary as longterm_summary,
    risk_command as risk_command,
)
from ._monte_carlo import (
    CELL_ESTIMATORS as CELL_ESTIMATORS,
    EFFORT_FRACTIONS as EFFORT_FRACTIONS,
    CellEstimate as CellEstimate,
    neyman_allocation as neyman_allocation,
)
from ._risk import (
    AUTO_SHARE as AUTO_SHARE,
    AUTO_TOLERANCE as AUTO_TOLERANCE,
    MODEL_FACTOR as MODEL_FACTOR,
)
from ._run import longterm as longterm, merge_longterm as merge_longterm
from ._scatter import (
    T01_OVER_TZ as T01_OVER_TZ,
    ScatterDiagram as ScatterDiagram,
    ScatterError as ScatterError,
    parse_scatter as parse_scatter,
    read_scatter as read_scatter,
    rec34_scatter as rec34_scatter,
    scatter_diagram as scatter_diagram,
)
