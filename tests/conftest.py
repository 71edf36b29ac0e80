import atexit
import os
import shutil
import tempfile

os.environ.setdefault("MPLBACKEND", "Agg")
# The CLI keeps compiled programs in a persistent cache (~/.cache/jaxroll). The tests must neither write into the
# user's cache nor depend on what it holds, but they may share compiled kernels among themselves: one fresh
# temporary cache per test session, made by the first process (pytest, or xdist's controller) and inherited by
# the workers and every child process (notebooks, CLI subprocesses), removed at the end. Tests of the cache give
# it a folder of their own.
if "JAXROLL_TEST_SESSION_CACHE" not in os.environ:
    _session_cache = tempfile.mkdtemp(prefix="jaxroll-test-cache-")
    os.environ["JAXROLL_TEST_SESSION_CACHE"] = _session_cache
    atexit.register(shutil.rmtree, _session_cache, True)
os.environ["JAXROLL_CACHE_DIR"] = os.environ["JAXROLL_TEST_SESSION_CACHE"]
# JAX's own persistent cache in the same folder, for this process and — through the environment — for the
# notebooks' kernels and the other child processes (the library does not turn it on by itself; the CLI does).
os.environ["JAX_COMPILATION_CACHE_DIR"] = os.environ["JAXROLL_CACHE_DIR"]
os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = "0.2"
# Under pytest-xdist the workers already use every core: one JAX CPU device each (not one per core, which
# `jaxroll.configure()` would choose). Multi-device runs are tested in child processes (test_scaling, test_compiled).
if "PYTEST_XDIST_WORKER" in os.environ:
    os.environ.setdefault("JAX_NUM_CPU_DEVICES", "1")

import gc

import jax
import jax.random as jr
import pytest

import jaxroll
from jaxroll import _compiled

# As users are told to (README, docs/architecture.md): float64, XLA:CPU's platform-independent math and small loops
# compiled whole, one CPU device per core (one per worker under xdist, above) — before JAX starts its backends.
jaxroll.configure()
# Strict dtype promotion (as diffrax/equinox test): an implicit float32 → float64 or int → float mix is an error,
# so a silent precision loss in the library cannot hide behind the tests.
jax.config.update("jax_numpy_dtype_promotion", "strict")


# Under xdist each worker runs whole files (`--dist loadfile`), handed out in collection order
# (`--no-loadscope-reorder`, pyproject.toml): the files that take longest go first, so the two workers finish
# together (longest processing time first) instead of one waiting on a large file handed out last. Worker seconds
# per file (the sum of its 120 slowest entries) measured on the 2-core machine under a load of ~7 (session 19,
# `pytest --durations=120`; about 3x the idle figures); files not listed follow, in name order.
SLOWEST_FILES_FIRST = (
    "test_longterm.py",  # 549 s
    "test_cli.py",  # 347
    "test_moments.py",  # 326
    "test_envelope_fpk.py",  # 253
    "test_sgisc.py",  # 232
    "test_passage.py",  # 190
    "test_calibration.py",  # 166
    "test_notebooks.py",  # 163
    "test_scaling.py",  # 147
    "test_hydrostatics.py",  # 143
    "test_docs.py",  # 141
    "test_wave_moment.py",  # 132 (-n 0, load ~4; issue 44's session)
    "test_effective_wave.py",  # 125
    "test_maxima.py",  # 120
    "test_sensitivity.py",  # 117
    "test_mesh.py",  # 105
    "test_time_domain.py",  # 102
    "test_jupyter.py",  # 95
    "test_laws.py",  # 94
    "test_kernel.py",  # 88
    "test_dynamics.py",  # 83
    "test_compiled.py",  # 79
    "test_heading.py",  # 62
)


def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(SLOWEST_FILES_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: each file's own order is kept


@pytest.fixture
def getkey():
    """A fresh, deterministic key per call within a test."""
    counter = iter(range(10**9))

    def _getkey():
        return jr.key(next(counter))

    return _getkey


def _mapped_regions() -> int:
    try:
        with open("/proc/self/maps") as f:
            return sum(1 for _ in f)
    except OSError:  # not Linux
        return 0


@pytest.fixture(autouse=True, scope="module")
def _bounded_compiled_code():
    """Free the compiled programs after a test module once the process maps many memory regions.

    XLA:CPU maps ~3 regions per compiled kernel (~270 for a Monte Carlo program) and Linux allows 65 530 per
    process (vm.max_map_count): the whole suite in one process used to pass that and crash inside XLA (a
    segmentation fault or an abort while compiling or caching). Measured: ~24 000 regions after a third of the
    suite. Clearing JAX's caches unmaps them; below the threshold the kernels stay shared across modules.
    """
    yield
    if _mapped_regions() > 30_000:
        jax.clear_caches()
        _compiled._LOADED.clear()
        gc.collect()
