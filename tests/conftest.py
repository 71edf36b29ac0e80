import os

os.environ.setdefault("MPLBACKEND", "Agg")

import jax
import jax.random as jr
import pytest

import jaxroll  # noqa: F401  (enables float64)

jax.config.update("jax_enable_x64", True)
# Strict dtype promotion (as diffrax/equinox test): an implicit float32 → float64 or int → float mix is an error,
# so a silent precision loss in the library cannot hide behind the tests.
jax.config.update("jax_numpy_dtype_promotion", "strict")


@pytest.fixture
def getkey():
    """A fresh, deterministic key per call within a test."""
    counter = iter(range(10**9))

    def _getkey():
        return jr.key(next(counter))

    return _getkey
