"""Figures (the only package that imports matplotlib)."""

from ._pdf import *  # noqa: F401,F403
