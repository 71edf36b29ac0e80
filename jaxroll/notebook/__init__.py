"""Jupyter: `explore()` (sliders over the sea state, heading, speed and GM correction redrawing the theories'
PDFs, and a small Monte Carlo on request; needs the `notebook` extra, ipywidgets) and `in_notebook()`.

The result types show themselves as HTML summary tables in a notebook (`_repr_html_`), and `progress=True` in
`monte_carlo` and its named uses draws tqdm's notebook bar there.
"""

from .._display import in_notebook as in_notebook
from ._explore import (
    EXPLORE_BINS_DEG as EXPLORE_BINS_DEG,
    EXPLORE_THEORIES as EXPLORE_THEORIES,
    Explorer as Explorer,
    explore as explore,
    explore_curves as explore_curves,
    explore_monte_carlo as explore_monte_carlo,
)
