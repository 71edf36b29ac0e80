"""Figures: the only package that imports matplotlib. Every function returns matplotlib figures or axes."""

from ._calibration import *  # noqa: F401,F403
from ._hydrostatics import *  # noqa: F401,F403
from ._longterm import *  # noqa: F401,F403
from ._pdf import *  # noqa: F401,F403
from ._polar import *  # noqa: F401,F403
from ._risk import *  # noqa: F401,F403
from ._sensitivity import *  # noqa: F401,F403
from ._sgisc import *  # noqa: F401,F403
from ._theory_map import *  # noqa: F401,F403
