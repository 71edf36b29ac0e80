import os

os.environ.setdefault("MPLBACKEND", "Agg")

import jax
import jax.random as jr
import pytest

import jaxroll  # noqa: F401  (enables float64)

jax.config.update("jax_enable_x64", True)


@pytest.fixture
def getkey():
    """A fresh, deterministic key per call within a test."""
    counter = iter(range(10**9))

    def _getkey():
        return jr.key(next(counter))

    return _getkey
