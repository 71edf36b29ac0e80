"""End-to-end command time as a user waits for it: each command run as a fresh process, cold (empty compilation
cache) then warm (the cache the cold run filled), plus the set-up stages inside one process.

Prints `name=value` lines: `<command>_cold_s`, `<command>_warm_s` (wall, whole process: start-up, set-up, work,
figures, JSON) and `setup_*_s` (the filter fit and checks of `RollProblem.from_sea`, first and second call).
Targets (issue 15, 2-core CPU): `jaxroll pdf` warm ≤ 8 s; any command's set-up ≤ 1 s.

Usage: python benchmarks/cli.py [--quick] [--commands pdf,theory,...]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

COMMANDS = {
    "pdf": ["pdf"],
    "theory": ["theory"],
    "risk": ["risk", "--realizations", "1000"],
    "maxima": ["maxima", "--n0", "20,100", "--realizations", "1000"],
    "sweep": ["sweep", "--hs", "5,7", "--t01", "10", "--realizations", "1000", "--duration", "1800"],
    "hydrostatics": ["hydrostatics", "c11"],
    "sensitivity": [
        "sensitivity",
        "--wrt",
        "b1,gm_correction",
        "--statistics",
        "E_phi2,mean_envelope",
        "--realizations",
        "16",
        "--duration",
        "900",
        "--window",
        "300",
        "--burn-in",
        "150",
        "--chunk-size",
        "16",
        "--theory",
        "roberts,envelope_fpk",
    ],  # test_cli's settings
}
QUICK = {"pdf": ["pdf", "--realizations", "1000"], "theory": ["theory", "--theory", "roberts,esam"]}


def run(argv: list[str], cache: str, out: str) -> float:
    env = {**os.environ, "JAXROLL_CACHE_DIR": cache}
    t0 = time.perf_counter()
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "jaxroll",
            *argv,
            "--out",
            out,
            *(["--quiet"] if argv[0] in ("pdf", "risk", "maxima", "sweep", "sensitivity") else []),
        ],
        env=env,
        capture_output=True,
        text=True,
    )
    elapsed = time.perf_counter() - t0
    if res.returncode != 0:
        raise SystemExit(f"jaxroll {' '.join(argv)} failed ({res.returncode}):\n{res.stderr[-2000:]}")
    return elapsed


def setup_times(cache: str) -> tuple[float, float]:
    """`RollProblem.from_sea` for the paper's sea, first and second call in a process whose cache (the CLI's, in
    `cache`) a previous process filled."""
    code = """
import time, jax, jaxroll
jaxroll.configure()
jaxroll.enable_compilation_cache()
ship, sea = jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0)
out = []
for _ in range(2):
    t0 = time.perf_counter(); jax.block_until_ready(jaxroll.RollProblem.from_sea(ship, sea))
    out.append(time.perf_counter() - t0)
print(*out)
"""
    env = {**os.environ, "JAXROLL_CACHE_DIR": cache}
    for _ in range(2):  # the first process fills the cache
        res = subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
        )
    first, second = map(float, res.stdout.split())
    return first, second


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="small pdf and theory runs only")
    parser.add_argument("--commands", default=None, help="comma-separated subset of " + ",".join(COMMANDS))
    args = parser.parse_args()
    commands = QUICK if args.quick else COMMANDS
    if args.commands:
        commands = {k: v for k, v in COMMANDS.items() if k in args.commands.split(",")}
    with tempfile.TemporaryDirectory() as tmp:
        for name, argv in commands.items():
            out, cache = (
                os.path.join(tmp, name),
                os.path.join(tmp, f"cache-{name}"),
            )  # cold: a cache of its own
            cold = run(argv, cache, out)
            warm = run(argv, cache, out)
            print(f"{name}_cold_s={cold:.2f}")
            print(f"{name}_warm_s={warm:.2f}", flush=True)
        first, second = setup_times(os.path.join(tmp, "cache-setup"))
        print(f"setup_from_sea_first_call_s={first:.2f}")
        print(f"setup_from_sea_second_call_s={second:.2f}")


if __name__ == "__main__":
    import jaxroll

    jaxroll.configure()  # float64, XLA:CPU's options, every core a JAX device (docs/architecture.md)
    main()
