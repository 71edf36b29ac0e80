"""Stored programs (`jaxroll._compiled.cached_program`) and concrete-or-traced checks (`require`)."""

import concurrent.futures

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll
from jaxroll import _compiled


@pytest.fixture
def program_cache(tmp_path, monkeypatch):
    """The store in a folder of its own (not the suite's session cache: only jaxroll's store is redirected), and
    an empty in-memory table."""
    folder = tmp_path / "jaxroll-programs"
    monkeypatch.setattr(_compiled, "cache_dir", lambda: folder)
    monkeypatch.setattr(_compiled, "_LOADED", {})
    return folder


class _Params(eqx.Module):
    scale: jax.Array
    label: str = eqx.field(static=True)


calls = []


@_compiled.cached_program
def _program(params: _Params, x, power: int):
    calls.append(power)  # runs only when traced
    return {"y": params.scale * x**power, "label": params.label, "n": power}


def test_a_stored_program_gives_the_same_numbers_without_tracing(program_cache):
    params, x = _Params(jnp.asarray(2.0), "a"), jnp.linspace(0.0, 1.0, 5)
    calls.clear()
    first = _program(params, x, 3)
    assert calls == [3]  # traced once, to export it
    assert len(list(program_cache.glob("*.npz"))) == 1
    _compiled._LOADED.clear()  # as a new process: the program comes from disk
    second = _program(params, x, 3)
    assert calls == [3]  # not traced again
    np.testing.assert_array_equal(second["y"], first["y"])
    np.testing.assert_allclose(second["y"], 2.0 * np.linspace(0.0, 1.0, 5) ** 3, rtol=1e-15)
    assert second["label"] == "a" and second["n"] == 3  # static outputs come back too
    # another static configuration or another shape is another program
    _program(params, x, 2)
    _program(params, jnp.linspace(0.0, 1.0, 6), 3)
    _program(_Params(jnp.asarray(2.0), "b"), x, 3)
    assert len(list(program_cache.glob("*.npz"))) == 4


def test_bind_looks_the_program_up_once_and_follows_a_change_of_kind(program_cache, monkeypatch):
    """`bind(*fixed)`: the same outputs as the full call; the lookup runs again only when the bound arguments'
    kind changes (another static object, another shape)."""
    params = _Params(jnp.asarray(2.0), "a")
    call = _program.bind(params)
    lookups = []
    entry = _compiled._sha
    monkeypatch.setattr(_compiled, "_sha", lambda *parts: lookups.append(1) or entry(*parts))
    for x in (jnp.arange(3.0), jnp.arange(3.0) + 1, jnp.arange(3.0) + 2):
        out = call(x, 3)
        np.testing.assert_array_equal(out["y"], _program(params, x, 3)["y"])
        np.testing.assert_allclose(out["y"], 2.0 * np.asarray(x) ** 3, rtol=1e-15)
        assert out["label"] == "a" and out["n"] == 3
    assert len(lookups) == 1 + 3  # the bound call's one lookup, then the three full calls' own
    lookups.clear()
    np.testing.assert_allclose(call(jnp.arange(3.0), 2)["y"], 2.0 * np.arange(3.0) ** 2)  # another static
    np.testing.assert_allclose(call(jnp.arange(4.0), 2)["y"], 2.0 * np.arange(4.0) ** 2)  # another shape
    np.testing.assert_allclose(call(jnp.arange(4.0) + 1, 2)["y"], 2.0 * (np.arange(4.0) + 1) ** 2)
    assert len(lookups) == 2
    monkeypatch.setattr(_compiled, "cache_dir", lambda: None)  # no stored program: the usual way
    np.testing.assert_allclose(_program.bind(params)(jnp.arange(7.0), 5)["y"], 2.0 * np.arange(7.0) ** 5)


def test_traced_calls_and_a_cache_that_is_off_trace_as_usual(program_cache, monkeypatch):
    params, x = _Params(jnp.asarray(2.0), "a"), jnp.arange(3.0)
    calls.clear()
    g = jax.grad(lambda s: jnp.sum(_program(_Params(s, "a"), x, 2)["y"]))(jnp.asarray(2.0))
    np.testing.assert_allclose(g, np.sum(np.arange(3.0) ** 2))
    assert calls and not list(program_cache.glob("*.npz"))  # a derivative never touches the store
    monkeypatch.setattr(_compiled, "cache_dir", lambda: None)
    np.testing.assert_allclose(_program(params, x, 2)["y"], 2.0 * np.arange(3.0) ** 2)
    assert not list(program_cache.glob("*.npz"))


def test_a_program_that_cannot_be_exported_runs_the_usual_way(program_cache):
    @_compiled.cached_program
    def checked(x):
        return eqx.error_if(x, x < 0, "negative")  # a host callback: not exportable

    np.testing.assert_array_equal(checked(jnp.arange(3.0)), np.arange(3.0))
    marker = list(program_cache.glob("*.npz"))
    assert len(marker) == 1 and _compiled.files.read_entry(marker[0], marker[0].stem) == {}  # not exportable
    with pytest.raises(Exception, match="negative"):
        checked(-jnp.ones(3))


def test_prepare_compiles_ahead_and_concurrent_calls_trace_once(program_cache, monkeypatch):
    """`prepare` exports and compiles from arguments of the same kind (other values): the call then neither traces
    nor compiles; calls made at once from several threads trace and compile the program once between them."""
    compiled = []
    real = _compiled._compiled
    monkeypatch.setattr(_compiled, "_compiled", lambda *a: compiled.append(1) or real(*a))
    calls.clear()
    params, x = _Params(jnp.asarray(2.0), "p"), jnp.linspace(0.0, 1.0, 7)
    _program.prepare(_Params(jnp.asarray(-1.0), "p"), jnp.zeros(7), 4, compile=False)
    assert calls == [4] and compiled == []  # traced (exported), not compiled
    _program.prepare(_Params(jnp.asarray(-1.0), "p"), jnp.zeros(7), 4)
    assert calls == [4] and compiled == [1]
    np.testing.assert_allclose(_program(params, x, 4)["y"], 2.0 * np.linspace(0.0, 1.0, 7) ** 4, rtol=1e-15)
    assert calls == [4] and compiled == [1]
    with concurrent.futures.ThreadPoolExecutor(4) as pool:
        results = list(pool.map(lambda _: _program(params, x, 5)["y"], range(4)))
    assert calls == [4, 5] and compiled == [1, 1]
    for y in results:
        np.testing.assert_array_equal(y, results[0])


def test_compiler_options_the_same_with_the_cache_on_or_off(program_cache, monkeypatch):
    """A program with XLA options (`SMALL_PROGRAM`) gives the same bits from the store and with the cache off (where
    it is compiled with the same options), the numbers of the plain program to rounding; an option that this XLA
    does not know is left out."""

    def power(params, x):
        return jnp.sum(jnp.sin(params.scale * x) ** 3) / jnp.linalg.norm(x)

    small = _compiled.cached_program(compiler_options=_compiled.SMALL_PROGRAM)(power)
    unknown = _compiled.cached_program(compiler_options={"xla_no_such_option_anywhere": True})(power)
    params, x = _Params(jnp.asarray(1.7), "o"), jnp.linspace(0.1, 3.0, 101)
    stored, odd = small(params, x), unknown(params, x)
    monkeypatch.setattr(_compiled, "cache_dir", lambda: None)
    _compiled._LOADED.clear()
    np.testing.assert_array_equal(small(params, x), stored)
    plain = jax.jit(power)(params, x)
    np.testing.assert_allclose(stored, plain, rtol=1e-14)
    np.testing.assert_allclose(odd, plain, rtol=1e-14)


def test_a_corrupt_stored_program_is_replaced(program_cache):
    params, x = _Params(jnp.asarray(3.0), "c"), jnp.arange(4.0)
    ref = _program(params, x, 1)["y"]
    (path,) = program_cache.glob("*.npz")
    path.write_bytes(b"not a program")
    _compiled._LOADED.clear()
    np.testing.assert_array_equal(_program(params, x, 1)["y"], ref)
    assert path.stat().st_size > 100


def test_set_up_from_stored_programs_equals_a_fresh_one(program_cache, monkeypatch):
    """The CLI's set-up (filter fit, its checks, the filter grid, the vanishing angle) from stored programs gives
    the problem a traced set-up gives, bit for bit."""
    ship, sea = jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0)
    stored = jaxroll.RollProblem.from_sea(ship, sea)  # runs the exported programs (as a warm run loads them)
    assert len(list(program_cache.glob("*.npz"))) >= 5
    monkeypatch.setattr(_compiled, "cache_dir", lambda: None)
    fresh = jaxroll.RollProblem.from_sea(ship, sea)
    for a, b in zip(jax.tree.leaves(stored), jax.tree.leaves(fresh), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


def test_require_raises_at_once_or_checks_at_run_time():
    x = jnp.asarray(-1.0)
    with pytest.raises(ValueError, match="must be positive"):
        _compiled.require(x, x <= 0, "must be positive")
    assert _compiled.require(jnp.asarray(2.0), jnp.asarray(False), "never") == 2.0
    f = jax.jit(lambda v: _compiled.require(v, v <= 0, "must be positive"))
    assert f(jnp.asarray(1.0)) == 1.0
    with pytest.raises(Exception, match="must be positive"):
        jax.block_until_ready(f(x))


_SHARDED_CHILD = """
import sys
import jax, numpy as np
import jaxroll
from jaxroll import _compiled
from jaxroll.roll import _sharding

jaxroll.configure()
assert jax.device_count() == 2, jax.devices()
# jaxroll's store in a folder of its own; XLA's cache is the test session's (inherited through the environment)
folder = _compiled.pathlib.Path(sys.argv[1]) / "jaxroll-programs"
_compiled.cache_dir = lambda: folder
problem = jaxroll.RollProblem.from_sea(jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0))
before = sum(1 for p in folder.glob("*.npz") if p.stat().st_size > 100)

def run():
    _sharding._COMPILED.clear()
    return jaxroll.monte_carlo_amplitudes(problem, jax.random.key(2), num_realizations=7, duration=300.0,
                                          chunk_size=4)

stored = run()  # exported, stored, then run from the export
_compiled._LOADED.clear()
loaded = run()  # as a new process: from disk
_compiled.cache_dir = lambda: None
traced = run()
for a in (stored, loaded):
    np.testing.assert_array_equal(a.counts_zero_crossing, traced.counts_zero_crossing)
    np.testing.assert_array_equal(a.counts_envelope, traced.counts_envelope)
    for k, v in traced.per_realization.items():
        np.testing.assert_array_equal(a.per_realization[k], v)
print("new programs", sum(1 for p in folder.glob("*.npz") if p.stat().st_size > 100) - before)
"""


def test_stored_monte_carlo_program_over_two_devices_equals_a_traced_one(tmp_path):
    """The Monte Carlo chunk sharded over two CPU devices (as `jaxroll.configure()` makes of two cores), from a
    stored program: the same numbers as traced, also when loaded from disk (in a child process: the devices are
    fixed when JAX starts)."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "JAX_NUM_CPU_DEVICES": "2", "JAX_PLATFORMS": "cpu"}
    res = subprocess.run(
        [sys.executable, "-c", _SHARDED_CHILD, str(tmp_path)], env=env, capture_output=True, text=True
    )
    assert res.returncode == 0, res.stderr[-3000:]
    assert int(res.stdout.split()[-1]) == 1  # the sharded chunk program was stored


_SET_UP_CHILD = """
import jax, numpy as np
import jaxroll

jaxroll.configure()
compiles = []
jax.monitoring.register_event_duration_secs_listener(
    lambda event, secs, **kw: compiles.append(event) if event == "/jax/core/compile/backend_compile_duration" else None)
ship = jaxroll.c11_representative()
wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), ship.lpp, 2.5, "head")
table = jaxroll.ship_to_dict(ship)
print(len(compiles), ship.gm0.dtype, ship.restoring.shape, float(wave.speed), table["damping"]["b2"])
"""


def test_the_set_up_compiles_no_eager_programs():
    """Building the ship, the sea and the effective wave from concrete numbers, and writing the ship back out,
    compile no XLA program (`as_float`, checks on the host): each eager operation would compile one (~10 ms on
    a cold run, in every command's set-up). In a new process, where nothing is compiled yet."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "JAX_PLATFORMS": "cpu", "JAX_ENABLE_COMPILATION_CACHE": "false"}
    res = subprocess.run([sys.executable, "-c", _SET_UP_CHILD], env=env, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr[-3000:]
    count, dtype, shape, speed, b2 = res.stdout.split()
    assert (count, dtype, shape, float(speed)) == ("0", "float64", "(4,)", 2.5)
    assert float(b2) == float(jaxroll.c11_representative().damping[1])


def test_as_float_and_host_checks_concrete_and_traced():
    """`as_float` gives what `jnp.asarray(x, float)` gives (a float64 array, uncommitted) for Python numbers, lists,
    integer and float32 arrays, and passes tracers through; the checks built on it raise at once on concrete
    values and at run time under jit."""
    for x in (
        3,
        2.5,
        [1, 2, 3],
        np.arange(3, dtype=np.int32),
        np.float32(0.1),
        jnp.asarray([1.5], jnp.float32),
    ):
        got, want = _compiled.as_float(x), jnp.asarray(x, dtype=float)
        assert got.dtype == want.dtype == jnp.float64 and not got.weak_type and not got._committed
        np.testing.assert_array_equal(np.asarray(got), np.asarray(want))
    assert jax.jit(lambda v: _compiled.as_float(v) * 2)(3) == 6.0
    assert _compiled.array_module(1.0) is np and _compiled.array_module(jnp.ones(())) is np
    with pytest.raises(ValueError, match=r"`hs` must be a finite number > 0"):
        jaxroll.ITTC(float("nan"), 10.0)
    with pytest.raises(ValueError, match=r"`speed` must be >= 0"):
        jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), 262.0, -1.0)
    with pytest.raises(Exception, match=r"`hs` must be a finite number > 0"):
        jax.block_until_ready(jax.jit(lambda h: jaxroll.ITTC(h, 10.0).hs)(-1.0))


def test_enable_compilation_cache_keeps_programs_for_a_new_session(tmp_path, monkeypatch):
    """`jaxroll.enable_compilation_cache` (what the `jaxroll` command calls; Python and Jupyter users opt in): JAX's
    persistent cache in the folder given, else JAXROLL_CACHE_DIR, off where that is empty; jaxroll's stored
    programs go beside it."""
    before = (jax.config.jax_compilation_cache_dir, jax.config.jax_persistent_cache_min_compile_time_secs)
    try:
        assert jaxroll.enable_compilation_cache(tmp_path / "xla") == tmp_path / "xla"
        assert jax.config.jax_compilation_cache_dir == str(tmp_path / "xla")
        assert jax.config.jax_persistent_cache_min_compile_time_secs == 0.0
        monkeypatch.setattr(_compiled, "_LOADED", {})
        angle = float(jaxroll.vanishing_angle(jaxroll.c11_representative(), num=1237))
        assert angle == pytest.approx(np.deg2rad(71.598), abs=1e-4)
        assert [p.suffix for p in (tmp_path / "xla" / "jaxroll-programs").iterdir()] == [".npz"]
        monkeypatch.setenv("JAXROLL_CACHE_DIR", str(tmp_path / "env"))
        assert jaxroll.enable_compilation_cache() == tmp_path / "env"
        monkeypatch.setenv("JAXROLL_CACHE_DIR", "")
        assert jaxroll.enable_compilation_cache() is None
        assert jax.config.jax_compilation_cache_dir == str(tmp_path / "env")  # left as it was
    finally:
        jax.config.update("jax_compilation_cache_dir", before[0])
        jax.config.update("jax_persistent_cache_min_compile_time_secs", before[1])


def test_filter_jit_is_the_same_function_concrete_traced_and_through_a_closure():
    """`_compiled.filter_jit` (the laws', theories' and fits' programs, `SOLVER_PROGRAM` on concrete calls) gives the
    function's values when called directly, under `jit`, `grad` and `vmap`, and when a tracer reaches it through a
    closure rather than its arguments (XLA options are only allowed on a top-level program: it falls back)."""
    calls = []

    @_compiled.filter_jit
    def f(x, n: int):
        calls.append(n)
        return jnp.sin(x) * n

    x = jnp.arange(3.0)
    want = np.sin(np.arange(3.0)) * 2
    np.testing.assert_allclose(f(x, 2), want, rtol=1e-15)
    np.testing.assert_allclose(jax.jit(lambda x: f(x, 2))(x), want, rtol=1e-15)
    np.testing.assert_allclose(jax.grad(lambda x: f(x, 2).sum())(x), 2 * np.cos(np.arange(3.0)), rtol=1e-15)
    np.testing.assert_allclose(
        jax.vmap(lambda x: f(x, 2))(jnp.stack([x, x])), np.stack([want, want]), rtol=1e-15
    )
    f(x + 1.0, 2)
    assert (
        calls.count(2) == 2
    )  # one program for the concrete calls (the second reused it), one inlined elsewhere

    def outer(y):
        return _compiled.filter_jit(lambda x: x * y)(x)

    np.testing.assert_allclose(jax.jit(outer)(3.0), 3 * np.arange(3.0), rtol=1e-15)
    assert _compiled._accepted(tuple(sorted(_compiled.SOLVER_PROGRAM.items())))
