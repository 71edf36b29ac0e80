"""No surprises on import: `import jaxroll` leaves JAX's and XLA's global settings as it found them;
`jaxroll.configure()` opts in (float64, XLA:CPU's options, one JAX device per core), before JAX starts or — with a
precise warning — after; without float64 the library refuses to compute, naming the call that fixes it.

JAX's settings are per process and fixed once its backends start, so the import and the opt-in are tested in child
processes started without the test session's settings (no XLA_FLAGS, no JAX_NUM_CPU_DEVICES, no compilation cache).
"""

import json
import math
import os
import subprocess
import sys
import textwrap

import jax
import numpy as np
import pytest
from helpers import SHIP

import jaxroll
from jaxroll._config import LOOP_OPTION, MATH_FLAG, SMALL_LOOP_BYTES, usable_cores, with_jaxroll_flags

# Float32 JAX code a user may run beside jaxroll: its bits, dtypes and devices, and the settings jaxroll could
# change. `rsqrt` in float32 is computed differently by XLA:CPU with platform-dependent math off (seen on this
# machine's CPU), the loop is one that jaxroll's small-loop option would compile whole.
_STATE = """
import hashlib, json, os, jax, jax.numpy as jnp, numpy as np

def state():
    x = jnp.linspace(-30.0, 30.0, 100_003, dtype=jnp.float32)
    y = jax.jit(lambda x: jax.lax.rsqrt(jnp.abs(x) + 1) + jnp.tanh(x) * jnp.exp(x / 30) + jnp.sin(x))(x)
    loop = jax.jit(lambda x: jax.lax.fori_loop(0, 10, lambda i, x: jnp.sin(x) * 1.01, x))
    z = loop(x[:4096])
    return {
        "bits": hashlib.sha256(np.asarray(y).tobytes() + np.asarray(z).tobytes()).hexdigest(),
        "dtypes": [str(y.dtype), str(jnp.asarray(1.0).dtype), str(jnp.arange(3).dtype)],
        "devices": [str(d) for d in jax.devices()],
        "xla_flags": os.environ.get("XLA_FLAGS"),
        "x64": bool(jax.config.jax_enable_x64),
        "num_cpu_devices": jax.config.jax_num_cpu_devices,
        "small_call": "xla_cpu_small_call" in loop.lower(x[:4096]).compile().as_text(),
    }
"""


def _run(code: str) -> dict:
    """Run `code` (after `_STATE`) in a fresh Python with JAX's defaults; it prints one JSON line last."""
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("XLA_FLAGS", "JAX_NUM_CPU_DEVICES", "JAX_ENABLE_X64", "JAX_COMPILATION_CACHE_DIR")
    }
    env.update(JAX_PLATFORMS="cpu", JAX_ENABLE_COMPILATION_CACHE="false", PYTHONWARNINGS="default")
    proc = subprocess.run(
        [sys.executable, "-c", _STATE + textwrap.dedent(code)],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def late():
    """Float32 code, then `import jaxroll`, the same code, then `configure()` twice (JAX started by then)."""
    return _run("""
        import warnings
        before = state()
        import jaxroll
        after = state()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            jaxroll.configure()
            first = [str(w.message) for w in caught]
            jaxroll.configure()
            second = [str(w.message) for w in caught][len(first):]
        print(json.dumps({"before": before, "after": after, "warnings": first, "again": second,
                          "x64": bool(jax.config.jax_enable_x64), "flags": os.environ.get("XLA_FLAGS")}))
    """)


@pytest.fixture(scope="module")
def import_first():
    """`import jaxroll` before any JAX computation, then the float32 code."""
    return _run("""
        import jaxroll
        print(json.dumps(state()))
    """)


def test_import_changes_no_global_setting(late, import_first):
    plain = late["before"]  # the process before it imported jaxroll: JAX as a user has it
    assert plain["dtypes"] == ["float32", "float32", "int32"] and not plain["x64"]
    assert plain["xla_flags"] is None and plain["num_cpu_devices"] == -1 and len(plain["devices"]) == 1
    # the same bits, dtypes, devices and settings after the import, and with jaxroll imported before JAX started
    assert late["after"] == plain
    assert import_first == plain


def test_configure_after_jax_started_applies_float64_and_warns_once(late):
    assert late["x64"]  # float64 can still be turned on
    assert late["flags"] is None  # XLA_FLAGS is not edited once it can no longer take effect
    (message,) = late["warnings"]
    assert message.startswith(
        "jaxroll.configure() came after JAX had started its backends, so it could not apply: "
    )
    assert "XLA:CPU's platform-independent math" in message and "small loops compiled whole" in message
    cores = usable_cores()
    assert (
        f"{cores} JAX CPU devices (JAX has 1: the Monte Carlo runs on 1 of the {cores} cores)" in message
    ) == (cores > 1)
    assert "Call jaxroll.configure() before the first JAX computation" in message
    assert late["again"] == []  # once


def test_configure_before_jax_starts_sets_everything_once():
    out = _run("""
        import jaxroll
        jaxroll.configure()
        once = os.environ["XLA_FLAGS"], jax.config.jax_num_cpu_devices
        jaxroll.configure()  # again: nothing changes
        twice = os.environ["XLA_FLAGS"], jax.config.jax_num_cpu_devices
        s = state()
        import warnings
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            jaxroll.configure()  # after JAX started, with everything in effect: no warning
        print(json.dumps({"once": once, "twice": twice, "state": s, "cores": len(os.sched_getaffinity(0))}))
    """)
    assert out["once"] == out["twice"]
    flags, devices = out["once"]
    assert flags == (f"--{MATH_FLAG}=false --xla_backend_extra_options={LOOP_OPTION}={SMALL_LOOP_BYTES}")
    s = out["state"]
    assert s["x64"] and s["dtypes"] == ["float32", "float64", "int64"]
    assert s["small_call"]  # XLA read the flags: a loop over a 16 kB carry is compiled as one function
    cores = out["cores"]
    assert len(s["devices"]) == cores and devices == (cores if cores > 1 else -1)


def test_configure_keeps_the_users_choices(monkeypatch):
    # XLA flags the user named stay as they are; their other options are kept beside jaxroll's
    mine = f"--{MATH_FLAG}=true --xla_backend_extra_options={LOOP_OPTION}=8"
    assert with_jaxroll_flags(mine) == mine
    other = "--xla_backend_extra_options=xla_cpu_disable_loop_unrolling=true"
    assert with_jaxroll_flags(other).split() == [
        other,
        f"--{MATH_FLAG}=false",
        f"--xla_backend_extra_options={LOOP_OPTION}={SMALL_LOOP_BYTES}",
    ]
    # in this process JAX has started, with the settings the test session chose (tests/conftest.py)
    flags = os.environ.get("XLA_FLAGS")
    jaxroll.configure()
    assert os.environ.get("XLA_FLAGS") == flags and jax.config.jax_enable_x64


@pytest.mark.parametrize("bad", [0, -2, 1.5, True, "every", "ALL"])
def test_configure_refuses_a_bad_device_count(bad):
    with pytest.raises(ValueError, match=r"`cpu_devices` must be 'all', None or an integer >= 1; got "):
        jaxroll.configure(cpu_devices=bad)


def test_the_command_line_configures_its_process(monkeypatch, capsys):
    from jaxroll._cli import main

    calls = []
    monkeypatch.setattr(jaxroll, "configure", lambda **kw: calls.append(kw))
    assert main(["ship", "show"]) == 0
    assert calls == [{}]  # every default: float64, the XLA options, every core a device
    capsys.readouterr()


# ----------------------------------------------------------------------------------------------------------
# Without float64 the library refuses, naming the call that fixes it
# ----------------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def inputs():
    problem = jaxroll.RollProblem.from_sea(SHIP, jaxroll.ITTC(7.0, 10.0), dt=0.5)
    return {
        "problem": problem,
        "law": jaxroll.RayleighLaw(0.1),
        "sea": jaxroll.ITTC(7.0, 10.0),
        "sde": jaxroll.theory.roll_sde(SHIP, problem.filter_fit.filter),
    }


ENTRY_POINTS = {
    "jaxroll.RollProblem.from_sea": lambda i: jaxroll.RollProblem.from_sea(SHIP, i["sea"]),
    "jaxroll.RollProblem": lambda i: jaxroll.RollProblem(SHIP, i["problem"].excitation),
    "jaxroll.monte_carlo_amplitudes": lambda i: jaxroll.monte_carlo_amplitudes(
        i["problem"], jax.random.key(0), num_realizations=4, duration=100.0
    ),
    "jaxroll.monte_carlo": lambda i: jaxroll.monte_carlo(
        i["problem"], jax.random.key(0), jaxroll.MaxRoll(0.2), num_realizations=4, duration=100.0
    ),
    "jaxroll.simulate": lambda i: jaxroll.simulate(i["problem"], jax.random.key(0), 10, None, None),
    "jaxroll.theory.roberts_pdf": lambda i: jaxroll.theory.roberts_pdf(SHIP, i["problem"].wave),
    "jaxroll.theory.esam_pdf": lambda i: jaxroll.theory.esam_pdf(SHIP, i["problem"].wave),
    "jaxroll.theory.moment_pdf": lambda i: jaxroll.theory.moment_pdf(SHIP, i["problem"].wave),
    "jaxroll.theory.envelope_fpk_pdf": lambda i: jaxroll.theory.envelope_fpk_pdf(SHIP, i["problem"].wave),
    "jaxroll.theory.theory_law": lambda i: jaxroll.theory.theory_law("roberts", SHIP, i["problem"].wave),
    "jaxroll.theory.stationary_moments": lambda i: jaxroll.theory.stationary_moments(
        i["sde"], closure_order=4
    ),
    "RayleighLaw.sf": lambda i: i["law"].sf(0.2),
    "RayleighLaw.quantile": lambda i: i["law"].quantile(0.5),
    "RayleighLaw.mean": lambda i: i["law"].mean(),
    "jaxroll.max_pdf": lambda i: jaxroll.max_pdf(i["law"], 0.3, 100),
    "jaxroll.exceedance_probability": lambda i: jaxroll.exceedance_probability(
        i["law"], 0.3, rate=0.1, duration=3600.0
    ),
    "jaxroll.fit_filter": lambda i: jaxroll.fit_filter(i["problem"].wave),
    "jaxroll.hull_hydrostatics": lambda i: jaxroll.hull_hydrostatics(jaxroll.c11_hull(), None),
    # issue 45: was refused by a private function's name (jaxroll.ship._restoring._vanishing_angle)
    "jaxroll.longterm": lambda i: jaxroll.longterm(),
}


@pytest.mark.parametrize("name", ENTRY_POINTS)
def test_without_float64_the_library_names_the_call(name, inputs):
    call = ENTRY_POINTS[name]
    jax.config.update("jax_enable_x64", False)
    try:
        with pytest.raises(RuntimeError) as info:
            call(inputs)
    finally:
        jax.config.update("jax_enable_x64", True)
    assert str(info.value) == (
        f"{name} needs float64, but JAX runs in float32 (importing jaxroll does not change that): call "
        'jaxroll.configure() first (or jax.config.update("jax_enable_x64", True)).'
    )


def test_the_safety_net_names_the_program():
    # a program of the library reached without a named entry point's check still refuses (filter_jit,
    # cached_program), naming the function
    from jaxroll._compiled import cached_program, filter_jit

    def double(x):
        return 2 * x

    for wrap in (filter_jit, cached_program):
        jax.config.update("jax_enable_x64", False)
        try:
            with pytest.raises(RuntimeError, match=r"\.double needs float64, but JAX runs in float32"):
                wrap(double)(np.ones(3))
        finally:
            jax.config.update("jax_enable_x64", True)
        np.testing.assert_array_equal(wrap(double)(np.ones(3)), 2.0)
    assert math.isfinite(float(jaxroll.RayleighLaw(0.1).mean()))  # and float64 works again
