"""JAX's process-wide settings that jaxroll relies on, changed only when asked: `configure()`; and the check that
refuses to compute without float64 (`require_float64`); and `single_threaded_blas()`, a scoped limit on the
BLAS/LAPACK threads (the envelope FPK's solves call LAPACK through jaxlib).

`import jaxroll` changes nothing in JAX's or XLA's global configuration (docs/architecture.md, "Process-wide
settings"). `jaxroll.configure()` — one call, first thing after the imports — asks for what the library was built
and measured with: float64, XLA:CPU's platform-independent math and small loops compiled whole (both through
`XLA_FLAGS`, read once when JAX starts its backends), and one JAX CPU device per core (`jax_num_cpu_devices`, fixed
at the same moment). The `jaxroll` command calls it for its own process.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import threading
import warnings
from typing import Literal

import jax

MATH_FLAG = "xla_cpu_enable_platform_dependent_math"
LOOP_OPTION = "xla_cpu_small_while_loop_byte_threshold"
#: XLA:CPU compiles a while loop that touches fewer bytes than this as one function (XLA's default: 1024 bytes),
#: instead of dispatching each of its kernels on every iteration (docs/architecture.md, "Process-wide settings").
SMALL_LOOP_BYTES = 4_000_000
_DEVICE_COUNT_FLAG = "xla_force_host_platform_device_count"

_WARNED: set[str] = set()  # the late-call warnings given (each once per process)


def with_jaxroll_flags(flags: str) -> str:
    """`XLA_FLAGS` with jaxroll's two XLA:CPU settings added where the user has not named them: platform-independent
    math, and `SMALL_LOOP_BYTES` as an `--xla_backend_extra_options` entry (XLA merges several such flags)."""
    words = flags.split()
    if MATH_FLAG not in flags:
        words.append(f"--{MATH_FLAG}=false")
    if LOOP_OPTION not in flags:
        words.append(f"--xla_backend_extra_options={LOOP_OPTION}={SMALL_LOOP_BYTES}")
    return " ".join(words)


def backends_started() -> bool | None:
    """Whether JAX has started its backends (after which XLA_FLAGS and the CPU device count are fixed); None when
    JAX's private API to ask has moved."""
    try:
        from jax._src import xla_bridge

        return bool(xla_bridge.backends_are_initialized())
    except (ImportError, AttributeError):  # pragma: no cover - private API moved
        return None


def usable_cores() -> int:
    """The CPU cores this process may run on (its affinity mask where the OS has one)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def _user_chose_cpu_devices() -> bool:
    """The number of JAX CPU devices was chosen already: `JAX_NUM_CPU_DEVICES`, the config, or XLA's flag."""
    return (
        "JAX_NUM_CPU_DEVICES" in os.environ
        or _DEVICE_COUNT_FLAG in os.environ.get("XLA_FLAGS", "")
        or jax.config.jax_num_cpu_devices != -1
    )


def _cpu_device_count() -> int | None:
    """JAX's CPU devices once its backends have started; None where the CPU is not JAX's default backend."""
    if jax.default_backend() != "cpu":
        return None
    return len(jax.devices("cpu"))


def configure(
    *,
    x64: bool = True,
    xla_flags: bool = True,
    cpu_devices: int | Literal["all"] | None = "all",
) -> None:
    """Set JAX up as jaxroll's results were computed and measured: call it once, first thing after the imports.

    `import jaxroll` changes no global setting of JAX or XLA, so a process that also runs other JAX code (in
    float32, or counting `jax.devices()`) behaves as before the import. This call opts in, for the whole process
    (the `jaxroll` command does it for its own):

    **Arguments:**

    - `x64`: turn on float64 (`jax_enable_x64`). jaxroll's statistics, theories, tail probabilities and fits need
      it and refuse to run without it (a `RuntimeError` naming this call). False leaves the setting as it is.
    - `xla_flags`: add to `XLA_FLAGS`, where the variable does not name them already,
      `--xla_cpu_enable_platform_dependent_math=false` (without it the float32 Monte Carlo kernel compiled for
      different batch sizes rounds differently: results then depend on the chunk size and the device count in
      their last bits) and `xla_cpu_small_while_loop_byte_threshold=4000000` as a backend option (XLA:CPU then
      compiles each loop touching under 4 MB as one function: the time loops run faster, with the same results).
      False leaves `XLA_FLAGS` as it is.
    - `cpu_devices`: "all" makes every CPU core this process may use a JAX device, so that the Monte Carlo runs on
      all of them (XLA runs one device's loop on one core), unless the number was chosen already
      (`JAX_NUM_CPU_DEVICES`, `jax_num_cpu_devices`, `--xla_force_host_platform_device_count`); an int n asks
      for n devices; None leaves it. Nothing changes on GPUs (`jax.devices()` lists them).

    The XLA flags and the CPU devices are fixed when JAX starts its backends (its first computation). Called
    later, `configure` applies what can still be applied (float64) and warns once, naming what it could not.
    Calling it again changes nothing.

    **Raises:** `ValueError` for a `cpu_devices` that is not "all", None or an integer ≥ 1.
    """
    if not (
        cpu_devices is None
        or cpu_devices == "all"
        or (isinstance(cpu_devices, int) and not isinstance(cpu_devices, bool) and cpu_devices >= 1)
    ):
        raise ValueError(f"`cpu_devices` must be 'all', None or an integer >= 1; got {cpu_devices!r}.")
    if x64:
        jax.config.update("jax_enable_x64", True)
    started = backends_started()
    missed: list[str] = []
    if xla_flags:
        flags = os.environ.get("XLA_FLAGS", "")
        wanted = with_jaxroll_flags(flags)
        if wanted != flags:
            if started:
                if MATH_FLAG not in flags:
                    missed.append(
                        "XLA:CPU's platform-independent math (Monte Carlo results may then differ in "
                        "their last bits with the chunk size and the device count)"
                    )
                if LOOP_OPTION not in flags:
                    missed.append(
                        "small loops compiled whole (the time loops run slower, with the same results)"
                    )
            else:
                os.environ["XLA_FLAGS"] = wanted
    if cpu_devices is not None:
        want = usable_cores() if cpu_devices == "all" else cpu_devices
        if not (cpu_devices == "all" and _user_chose_cpu_devices()):
            if started:
                have = _cpu_device_count()
                if have is not None and have != want:
                    missed.append(
                        f"{want} JAX CPU devices (JAX has {have}: the Monte Carlo runs on {have} of "
                        f"the {usable_cores()} cores)"
                    )
            elif want > 1 or cpu_devices != "all":
                try:
                    jax.config.update("jax_num_cpu_devices", want)
                except RuntimeError:  # pragma: no cover - started, where `backends_started` could not tell
                    missed.append(f"{want} JAX CPU devices (fixed when JAX started)")
    if missed:
        message = (
            "jaxroll.configure() came after JAX had started its backends, so it could not apply: "
            + "; ".join(missed)
            + ". Call jaxroll.configure() before the first JAX computation, or set them before Python starts "
            '(XLA_FLAGS, JAX_NUM_CPU_DEVICES; docs/architecture.md, "Process-wide settings").'
        )
        if message not in _WARNED:
            _WARNED.add(message)
            warnings.warn(message, stacklevel=2)


def require_float64(name: str) -> None:
    """Refuse to run `name` (a public entry point, e.g. "jaxroll.monte_carlo") without float64: a `RuntimeError`
    that names the call to make. Entry points call it once, before any computation (not in their loops)."""
    if not jax.config.jax_enable_x64:
        raise RuntimeError(
            f"{name} needs float64, but JAX runs in float32 (importing jaxroll does not change that): call "
            'jaxroll.configure() first (or jax.config.update("jax_enable_x64", True)).'
        )


_BLAS_LOCK = threading.Lock()
# [callers inside `single_threaded_blas`, the (setter, previous count) pairs to restore]
_BLAS_DEPTH = [0, []]


def _openblas_controls() -> list:
    """(get, set) thread-count functions of every OpenBLAS loaded in this process (jaxlib's LAPACK kernels are
    SciPy's: `scipy.linalg.cython_lapack`, SciPy's bundled OpenBLAS; NumPy bundles its own). Found through the
    libraries mapped into the process (Linux); an empty list elsewhere."""
    try:
        import scipy.linalg.cython_lapack  # noqa: F401  (what jaxlib loads on its first LAPACK call)
    except ImportError:  # pragma: no cover
        pass
    try:
        with open("/proc/self/maps") as f:
            paths = {line.split()[-1] for line in f if "openblas" in line.rsplit("/", 1)[-1].lower()}
    except OSError:  # pragma: no cover - not Linux
        return []
    found = []
    for path in sorted(paths):
        try:
            lib = ctypes.CDLL(path)
        except OSError:  # pragma: no cover
            continue
        for prefix, suffix in (("scipy_", ""), ("scipy_", "64_"), ("", ""), ("", "64_")):
            get = getattr(lib, f"{prefix}openblas_get_num_threads{suffix}", None)
            put = getattr(lib, f"{prefix}openblas_set_num_threads{suffix}", None)
            if get is not None and put is not None:
                get.restype, put.argtypes = ctypes.c_int, [ctypes.c_int]
                found.append((get, put))
                break
    return found


def blas_threads() -> list[int]:
    """The thread count of each OpenBLAS loaded in this process (see `single_threaded_blas`)."""
    try:
        from threadpoolctl import threadpool_info
    except ImportError:
        return [int(get()) for get, _ in _openblas_controls()]
    return [int(i["num_threads"]) for i in threadpool_info() if i.get("user_api") == "blas"]


@contextlib.contextmanager
def single_threaded_blas():
    """Run the block inside with one BLAS/LAPACK thread; the previous counts come back on leaving it.

    jaxlib's LAPACK kernels (LU factorisations, triangular solves) are SciPy's OpenBLAS, which starts a thread per
    core for each call: on the envelope FPK's 96 × 96 blocks its threads spin on each other and on the other
    device's work, 4–40× slower when the machine is busy (a 96 × 96 inverse 31 → 0.8 ms at load 7 on 2 cores;
    `jaxroll.theory.passage_risk_batch`, `jaxroll longterm`'s theory). Through threadpoolctl where it is
    installed; otherwise OpenBLAS's own `openblas_set_num_threads` in the libraries loaded in this process (Linux);
    elsewhere it does nothing. Re-entrant and thread-safe: the counts are restored when the last caller leaves.
    The count is process-wide while inside (NumPy's own BLAS included)."""
    with _BLAS_LOCK:
        if _BLAS_DEPTH[0] == 0:
            restore = []
            try:
                from threadpoolctl import threadpool_limits

                limiter = threadpool_limits(limits=1, user_api="blas")
                restore.append((limiter.restore_original_limits, None))
            except ImportError:
                for get, put in _openblas_controls():
                    n = int(get())
                    put(1)
                    restore.append((put, n))
            _BLAS_DEPTH[1] = restore
        _BLAS_DEPTH[0] += 1
    try:
        yield
    finally:
        with _BLAS_LOCK:
            _BLAS_DEPTH[0] -= 1
            if _BLAS_DEPTH[0] == 0:
                for put, n in _BLAS_DEPTH[1]:
                    put() if n is None else put(n)
                _BLAS_DEPTH[1] = []
