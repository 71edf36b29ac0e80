"""The bad-input and fault corpus of issue 37, re-runnable: prints held/failed per case, exit status 1 if any failed.

Each case builds its inputs in a temporary folder (ship files, tank records, hull meshes, checkpoints, caches),
runs the `jaxroll` command in a subprocess (or a Python call), and says what "held" means: exit 2 with a message
matching a pattern, a warning that gives both numbers, no debris left, no code executed from a planted file.
A case whose setting this machine cannot make (a private mount point, a full disk) is "skipped" with the reason.

Add a case: write a function `def case_name(tmp: Path) -> Verdict` and append `Case("name", "37.N", "what", fn)`
to `CASES` (the helpers `jaxroll(...)`, `write_ship(...)`, `held_if_error(...)` keep each case a few lines).

Usage:
    python benchmarks/bad_input_audit.py                 # every case (≈ 10-20 min on 2 cores)
    python benchmarks/bad_input_audit.py -k ship -k 37.5 # cases whose name or item contains a pattern
    python benchmarks/bad_input_audit.py --list
    python benchmarks/bad_input_audit.py --cache DIR     # the compilation cache the commands use (default: the
                                                         # user's, as a user runs them; the cache cases make their own)

Environment: JAXROLL_AUDIT_MOUNT=DIR (an empty mount point you own, for the EXDEV case), JAXROLL_AUDIT_FULL=DIR
(a folder on a full or tiny file system, for the ENOSPC case).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import pickle
import re
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the jaxroll of this checkout, here and in the subprocesses (PYTHONPATH)


# ----------------------------------------------------------------------------------------------------------------
# The harness
# ----------------------------------------------------------------------------------------------------------------


@dataclasses.dataclass
class Verdict:
    held: bool | None  # None: skipped
    reason: str


@dataclasses.dataclass
class Case:
    name: str
    item: str  # "37.3": issue 37, item 3 ("37.F" the "Figures and words" section, "37+" cases added since)
    what: str
    run: Callable[[Path], Verdict]


@dataclasses.dataclass
class Run:
    code: int
    out: str
    err: str
    seconds: float

    @property
    def text(self) -> str:
        return self.out + self.err


CACHE: str | None = None  # --cache


def _env(**extra) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH", "")]))
    if CACHE is not None:
        env["JAXROLL_CACHE_DIR"] = CACHE
    env.update({k: str(v) for k, v in extra.items()})
    return env


def jaxroll(*argv, cwd: Path, env: dict | None = None, timeout: float = 900) -> Run:
    """`jaxroll ARGV` in a subprocess (as a user runs it): exit code, stdout, stderr, wall seconds."""
    t0 = time.time()
    proc = subprocess.run(
        [sys.executable, "-m", "jaxroll", *map(str, argv)],
        cwd=cwd,
        env=env or _env(),
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    return Run(proc.returncode, proc.stdout, proc.stderr, time.time() - t0)


def start(*argv, cwd: Path, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "jaxroll", *map(str, argv)],
        cwd=cwd,
        env=env or _env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def python(code: str, *, cwd: Path, timeout: float = 900) -> Run:
    """A Python snippet in a subprocess (library calls; jaxroll imported from this checkout)."""
    t0 = time.time()
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=cwd, env=_env(), capture_output=True, text=True, timeout=timeout
    )
    return Run(proc.returncode, proc.stdout, proc.stderr, time.time() - t0)


def last_line(text: str) -> str:
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1][:160] if lines else "(no output)"


def held_if_error(run: Run, pattern: str, *, absent: str | None = None) -> Verdict:
    """Held: exit 2, no traceback, stderr matches `pattern` (and not `absent`)."""
    if "Traceback" in run.err:
        return Verdict(False, f"traceback (exit {run.code}): {last_line(run.err)}")
    if run.code != 2:
        return Verdict(False, f"exit {run.code}, expected 2: {last_line(run.text)}")
    if not re.search(pattern, run.err):
        return Verdict(False, f"exit 2 but the message does not match {pattern!r}: {last_line(run.err)}")
    if absent is not None and re.search(absent, run.err):
        return Verdict(False, f"the message still says {absent!r}: {last_line(run.err)}")
    return Verdict(True, f"exit 2 in {run.seconds:.0f} s: {last_line(run.err)}")


def held_if_warning(run: Run, pattern: str) -> Verdict:
    """Held: no traceback, a `warning:` line on stderr matching `pattern` (exit 0 or 2)."""
    if "Traceback" in run.err:
        return Verdict(False, f"traceback (exit {run.code}): {last_line(run.err)}")
    lines = [ln for ln in run.err.splitlines() if "warning:" in ln and re.search(pattern, ln)]
    if not lines:
        return Verdict(False, f"no warning matching {pattern!r} (exit {run.code}): {last_line(run.text)}")
    return Verdict(True, f"exit {run.code}, warned: {lines[0][:160]}")


# ----------------------------------------------------------------------------------------------------------------
# Inputs
# ----------------------------------------------------------------------------------------------------------------


def c11_toml() -> str:
    from jaxroll import c11_representative, configure, ship_to_toml

    configure()  # float64: the file's numbers as the CLI writes them
    return ship_to_toml(c11_representative())


def write_ship(tmp: Path, old: str, new: str, name: str = "ship.toml") -> Path:
    """The default ship's file with one line changed."""
    text = c11_toml()
    assert old in text, old
    path = tmp / name
    path.write_text(text.replace(old, new))
    return path


def prism_stl(path: Path, section, length: float) -> Path:
    """A closed ascii STL prism: the convex polygon `section` [(y, z), …] extruded along x over [0, length] [m]."""
    tris, n = [], len(section)
    for i in range(n):
        (y0, z0), (y1, z1) = section[i], section[(i + 1) % n]
        a, b, c, d = (0, y0, z0), (0, y1, z1), (length, y1, z1), (length, y0, z0)
        tris += [(a, b, c), (a, c, d)]  # outward for a counter-clockwise section, like the caps
    for i in range(1, n - 1):
        (ya, za), (yb, zb), (yc, zc) = section[0], section[i], section[i + 1]
        tris += [
            ((0, ya, za), (0, yc, zc), (0, yb, zb)),
            ((length, ya, za), (length, yb, zb), (length, yc, zc)),
        ]
    lines = ["solid prism"]
    for t in tris:
        lines += [
            " facet normal 0 0 0",
            "  outer loop",
            *(f"   vertex {x:.6f} {y:.6f} {z:.6f}" for x, y, z in t),
            "  endloop",
            " endfacet",
        ]
    path.write_text("\n".join([*lines, "endsolid prism", ""]))
    return path


def tank_records(tmp: Path, kind: str, *, wave_unit_header: str | None = None, **options) -> Path:
    """Model-scale records of one sea state from `jaxroll tank` (the virtual tank), optionally with the `units`
    line's wave unit replaced (the column keeps its numbers: a unit slip)."""
    out = tmp / "tank"
    args = {
        "captive": ["--captive-seas", "7,10", "--captive-heels", "0", "--captive-realizations", "2"],
        "roll": ["--roll-seas", "7,10", "--roll-realizations", "2"],
    }[kind]
    run = jaxroll("tank", "--tests", kind, *args, "--out", out, "--quiet", cwd=tmp)
    if run.code != 0:
        raise RuntimeError(f"jaxroll tank failed: {last_line(run.err)}")
    folder = out / kind
    if wave_unit_header is not None:
        for f in folder.glob("*.csv"):
            text = f.read_text()
            units = re.search(r"^# units: (.*)$", text, re.M).group(1).split(", ")
            units[1 if kind == "captive" else 2] = wave_unit_header
            f.write_text(re.sub(r"^# units: .*$", "# units: " + ", ".join(units), text, count=1, flags=re.M))
    return folder


# ----------------------------------------------------------------------------------------------------------------
# Item 1 (developer `hulls`): asymmetric hull
# ----------------------------------------------------------------------------------------------------------------


def asymmetric_hull(tmp: Path) -> Verdict:
    # vertical port side at y = −8 m, starboard flared from y = 8 m at the keel to 10 m at z = 12 m
    stl = prism_stl(tmp / "asym.stl", [(-8, 0), (8, 0), (10, 12), (-8, 12)], 100.0)
    run = jaxroll(
        "hydrostatics",
        stl,
        "--kg",
        6,
        "--draught",
        5,
        "--roll-period",
        12,
        "--lpp",
        100,
        "--x-ap",
        0,
        "--out",
        tmp / "o",
        cwd=tmp,
    )
    if run.code == 2:
        return held_if_error(run, r"(?i)symmetr")
    if run.code == 0:  # supported: the displacement must be the hand calculation's
        area = 16 * 5 + 2 / 12 * 5**2 / 2  # ∫0^5 (16 + z/6) dz [m²]
        expected = 1025.0 * area * 100.0
        data = json.loads((tmp / "o" / "hydrostatics.json").read_text())
        found = _find_number(data, "displacement")
        if found is not None and abs(found / expected - 1) < 0.01:
            return Verdict(True, f"supported: Δ = {found:.4g} kg (hand {expected:.4g} kg)")
        return Verdict(False, f"accepted as symmetric: Δ = {found} kg, by hand {expected:.4g} kg")
    return Verdict(False, f"exit {run.code}: {last_line(run.text)}")


def _find_number(data, key):
    if isinstance(data, dict):
        for k, v in data.items():
            if key in k and isinstance(v, int | float):
                return float(v)
            found = _find_number(v, key)
            if found is not None:
                return found
    return None


# ----------------------------------------------------------------------------------------------------------------
# Item 2: unit slips in tank records
# ----------------------------------------------------------------------------------------------------------------


def captive_wave_mm_labelled_m(tmp: Path) -> Verdict:
    records = tank_records(tmp, "captive", wave_unit_header="m")
    run = jaxroll("calibrate", "captive", records, "--out", tmp / "o", cwd=tmp)
    return held_if_error(run, r"4σ of the measured wave is \d+ m .*header says H1/3 = 7 m")


def roll_wave_mm_labelled_m(tmp: Path) -> Verdict:
    records = tank_records(tmp, "roll", wave_unit_header="m")
    run = jaxroll("calibrate", "roll", records, "--estimator", "time-domain", "--out", tmp / "o", cwd=tmp)
    return held_if_error(run, r"4σ of the measured wave is \d+ m .*header says H1/3 = 7 m", absent="SVD")


# ----------------------------------------------------------------------------------------------------------------
# Item 3 (and cases added): implausible ship files
# ----------------------------------------------------------------------------------------------------------------


def _ship_show(tmp, old, new):
    return jaxroll("ship", "show", "--ship", write_ship(tmp, old, new), cwd=tmp)


def ship_gm0_in_mm(tmp):
    return held_if_error(_ship_show(tmp, "gm0_m = 1.9299", "gm0_m = 1929.9"), r"gm0_m = 1929.9 m .*1.93 m")


def ship_lpp_in_mm(tmp):
    return held_if_error(_ship_show(tmp, "lpp_m = 262.0", "lpp_m = 262000.0"), r"lpp_m = 262000 m .*262 m")


def ship_c1_1e9(tmp):
    return held_if_warning(_ship_show(tmp, "c1 = 0.55", "c1 = 1000000000.0"), r"ΔGM.*c1 = 1e\+09")


def ship_vanishing_angle_2deg(tmp):
    return held_if_warning(
        _ship_show(tmp, "a3 = -0.0165775403135739", "a3 = -50.0"), r"vanishing stability is 2\.\d+°"
    )


def ship_b1_1e6(tmp):
    return held_if_warning(
        _ship_show(tmp, "b1 = 0.007725227836696213", "b1 = 1000000.0"), r"damping ratio .*b1 = 1e\+06"
    )


def ship_displacement_in_tonnes(tmp):
    return held_if_warning(
        _ship_show(tmp, "displacement_kg = 67247000.0", "displacement_kg = 67247.0"),
        r"displacement_kg = .* × ρ C_b L B d",
    )


def ship_gm_against_roll_period(tmp):
    return held_if_warning(_ship_show(tmp, "gm0_m = 1.9299", "gm0_m = 0.019299"), r"roll radius of gyration")


def ship_gm_ratio_from_slipped_records(tmp):
    return held_if_warning(_ship_show(tmp, "gm_ratio = 1.0", "gm_ratio = 4.3e-08"), r"gm_ratio = 4.3e-08")


def pdf_lpp_in_mm_names_the_cause(tmp):
    ship = write_ship(tmp, "lpp_m = 262.0", "lpp_m = 262000.0")
    run = jaxroll("pdf", "--ship", ship, "--realizations", 20, "--out", tmp / "o", cwd=tmp)
    return held_if_error(run, r"lpp_m = 262000 m is beyond any ship", absent=r"superposition")


# ----------------------------------------------------------------------------------------------------------------
# Item 4: negative fitted damping
# ----------------------------------------------------------------------------------------------------------------


def decay_negative_b2(tmp: Path) -> Verdict:
    make = python(
        "import equinox as eqx, jax.numpy as jnp, jaxroll as jxr\njxr.configure()\n"
        "from jaxroll.calibration import virtual_decay_record\nfrom jaxroll.io import save_record\n"
        "s = eqx.tree_at(lambda s: s.damping, jxr.c11_representative(), jnp.asarray([0.012, -0.081, 0.0]))\n"
        "save_record(virtual_decay_record(s, roll_noise_deg=0.02), 'decay/decay.csv')\n",
        cwd=tmp,
    )
    if make.code:
        return Verdict(False, f"could not build the record: {last_line(make.err)}")
    run = jaxroll("calibrate", "decay", tmp / "decay", "--out", tmp / "o", cwd=tmp)
    verdict = held_if_warning(run, r"b2 = -0\.08\d* .*b2 = 0")
    if not verdict.held:
        return verdict
    import tomllib

    written = json.loads((tmp / "o" / "calibration.json").read_text())["written"]["damping"]
    ship = tomllib.loads((tmp / "o" / "ship.toml").read_text())["damping"]
    value = written["b2"]["value"] if isinstance(written["b2"], dict) else written["b2"]
    if value != ship["b2"]:
        return Verdict(False, f"calibration.json written b2 = {value}, ship.toml b2 = {ship['b2']}")
    return Verdict(True, verdict.reason[:120] + "; calibration.json's `written` = ship.toml")


# ----------------------------------------------------------------------------------------------------------------
# Item 5: edited checkpoints
# ----------------------------------------------------------------------------------------------------------------


def _checkpointed_pdf(tmp: Path) -> tuple[list, Path]:
    argv = [
        "pdf",
        "--realizations",
        40,
        "--duration",
        1200,
        "--chunk-size",
        20,
        "--theory",
        "none",
        "--quiet",
        "--checkpoint",
        tmp / "ck",
        "--out",
        tmp / "o",
    ]
    run = jaxroll(*argv, cwd=tmp)
    if run.code:
        raise RuntimeError(f"the checkpointed run failed: {last_line(run.err)}")
    return argv, tmp / "ck" / "checkpoint.npz"


def _edit_checkpoint(path: Path, edit, *, redigest: bool) -> None:
    import numpy as np

    with np.load(path) as data:
        contents = {k: data[k] for k in data.files}
    edit(contents)
    if redigest and "digest" in contents:  # as an editor who knows the format (jaxroll.roll._sharding)
        from jaxroll.roll._sharding import _content_digest

        contents.pop("digest")
        contents["digest"] = np.array(_content_digest(contents))
    np.savez(path, **contents)


def checkpoint_edited_histogram(tmp: Path) -> Verdict:
    argv, path = _checkpointed_pdf(tmp)

    def edit(c):
        c["summed/counts_zero_crossing"] = c["summed/counts_zero_crossing"].copy()
        c["summed/counts_zero_crossing"][400:500] += 50  # moves the median to ≈ 23°

    _edit_checkpoint(path, edit, redigest=False)
    return held_if_error(jaxroll(*argv, cwd=tmp), r"checkpoint .*(changed since|inconsistent|digest)")


def checkpoint_rewound_next_start(tmp: Path) -> Verdict:
    argv, path = _checkpointed_pdf(tmp)

    def edit(c):
        c["next_start"] = c["next_start"] * 0 + 20  # the second chunk would run again, double-counting
        for k in [k for k in c if k.startswith("per/")]:
            c[k] = c[k][:20]

    _edit_checkpoint(path, edit, redigest=True)
    return held_if_error(jaxroll(*argv, cwd=tmp), r"checkpoint .*inconsistent")


# ----------------------------------------------------------------------------------------------------------------
# Item 6: a sea beyond breaking, theories beyond their range
# ----------------------------------------------------------------------------------------------------------------


def hs_30_beyond_breaking(tmp: Path) -> Verdict:
    run = jaxroll("theory", "--hs", 30, "--theory", "roberts,esam", "--out", tmp / "o", cwd=tmp)
    for pattern in (r"steepness .*beyond the breaking limit", r"roberts, esam: the GM in waves varies by ε"):
        verdict = held_if_warning(run, pattern)
        if not verdict.held:
            return verdict
    return Verdict(
        True, "warned: beyond breaking (S_p against DNV-RP-C205), and ε beyond the averaging's range"
    )


def pdf_theories_against_capsizing_sea(tmp: Path) -> Verdict:
    run = jaxroll("pdf", "--hs", 12, "--realizations", 40, "--theory", "roberts", "--out", tmp / "o", cwd=tmp)
    return held_if_warning(run, r"realizations capsized \(P = .*stationary laws")


# ----------------------------------------------------------------------------------------------------------------
# Item 7 (developer `faults`): code executed from the cache
# ----------------------------------------------------------------------------------------------------------------


class _Payload:
    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def _plant(tmp: Path, folder: str, argv: list) -> Verdict:
    cache = tmp / "cache"
    env = _env(JAXROLL_CACHE_DIR=cache)
    first = jaxroll(*argv, "--out", tmp / "o1", cwd=tmp, env=env)
    if first.code:
        return Verdict(False, f"the first run failed: {last_line(first.err)}")
    files = [f for f in (cache / folder).rglob("*") if f.is_file()] if (cache / folder).exists() else []
    if not files:
        return Verdict(None, f"nothing stored under {folder}/ (the cache keeps other files now?)")
    marker = tmp / "EXECUTED"
    for f in files:  # every stored file replaced by a pickle that runs a shell command when unpickled
        f.write_bytes(pickle.dumps(_Payload(str(marker))))
    run = jaxroll(*argv, "--out", tmp / "o2", cwd=tmp, env=env)
    if marker.exists():
        return Verdict(False, f"a planted file under {folder}/ ran code (the marker file was written)")
    if "Traceback" in run.err or run.code not in (0, 2):
        return Verdict(False, f"exit {run.code}: {last_line(run.err)}")
    return Verdict(
        True, f"{len(files)} planted file(s) under {folder}/ read as a cache miss (exit {run.code})"
    )


def cache_programs_pickle(tmp: Path) -> Verdict:
    return _plant(tmp, "jaxroll-programs", ["theory", "--theory", "roberts"])


def cache_moment_tables_pickle(tmp: Path) -> Verdict:
    return _plant(tmp, "jaxroll-moment", ["theory", "--theory", "moment"])


def cache_writable_by_others(tmp: Path) -> Verdict:
    cache = tmp / "cache"
    cache.mkdir()
    os.chmod(cache, 0o777)
    run = jaxroll("ship", "show", cwd=tmp, env=_env(JAXROLL_CACHE_DIR=cache))
    if re.search(r"(?i)writable|others|world", run.err):
        return Verdict(True, f"exit {run.code}: {last_line(run.err)}")
    return Verdict(False, f"a cache folder writable by everyone used without a word (exit {run.code})")


# ----------------------------------------------------------------------------------------------------------------
# Item 8 (developer `faults`; the order of checks: this branch): output folders
# ----------------------------------------------------------------------------------------------------------------


def _debris(folder: Path) -> list[str]:
    return sorted(
        p.name
        for p in folder.parent.iterdir()
        if re.match(rf"\.{re.escape(folder.name)}\.(partial|old)-", p.name)
    )


def out_on_mount_point(tmp: Path) -> Verdict:
    mount = os.environ.get("JAXROLL_AUDIT_MOUNT")
    if not mount:
        return Verdict(None, "set JAXROLL_AUDIT_MOUNT to an empty mount point you own (a tmpfs, a volume)")
    run = jaxroll("theory", "--theory", "roberts", "--out", mount, cwd=tmp)
    left = _debris(Path(mount))
    if run.code != 0 or left:
        return Verdict(False, f"exit {run.code}, debris {left}: {last_line(run.err)}")
    return Verdict(True, "written onto the mount point, no debris")


def out_read_only(tmp: Path) -> Verdict:
    if not sys.platform.startswith("linux"):
        return Verdict(None, "uses /proc, which no user can write into")
    run = jaxroll("pdf", "--out", "/proc/jaxroll-audit", cwd=tmp)
    verdict = held_if_error(run, r"--out .*cannot be written")
    if verdict.held and "Monte Carlo:" in run.out:
        return Verdict(False, "refused only after the filter fit (the run had started)")
    return verdict


def out_full_disk(tmp: Path) -> Verdict:
    full = os.environ.get("JAXROLL_AUDIT_FULL")
    if not full:
        return Verdict(None, "set JAXROLL_AUDIT_FULL to a folder on a full (or tiny) file system")
    run = jaxroll("theory", "--theory", "roberts", "--out", Path(full) / "o", cwd=tmp)
    verdict = held_if_error(run, r"(?i)space|full")
    left = _debris(Path(full) / "o")
    return Verdict(False, f"debris left: {left}") if verdict.held and left else verdict


def sigkill_debris_cleaned(tmp: Path) -> Verdict:
    out = tmp / "o"
    proc = start("pdf", "--realizations", 2000, "--theory", "none", "--quiet", "--out", out, cwd=tmp)
    deadline = time.time() + 300
    while time.time() < deadline and not _debris(out) and proc.poll() is None:
        time.sleep(0.2)
    if proc.poll() is not None:
        return Verdict(None, "the run ended before its temporary folder appeared")
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    if not _debris(out):
        return Verdict(None, "no temporary folder was left by the killed run")
    run = jaxroll("theory", "--theory", "roberts", "--out", out, cwd=tmp)
    left = _debris(out)
    if run.code == 0 and not left:
        return Verdict(True, "the next run removed the killed run's temporary folder")
    if run.code == 0 and re.search(r"(?i)partial|left|debris|earlier", run.err):
        return Verdict(True, f"reported: {last_line(run.err)}")
    return Verdict(False, f"exit {run.code}, still there: {left}")


def out_dot_keeps_cwd(tmp: Path) -> Verdict:
    work = tmp / "work"
    work.mkdir()
    (work / "mine.txt").write_text("the user's own file\n")
    inode = work.stat().st_ino
    run = jaxroll("theory", "--theory", "roberts", "--out", ".", cwd=work)
    if run.code != 0:
        return Verdict(False, f"exit {run.code}: {last_line(run.err)}")
    same = work.stat().st_ino == inode
    kept = (work / "mine.txt").exists()
    left = [p.name for p in tmp.iterdir() if re.match(r"\.(work|\.)\.(partial|old)-", p.name)]
    if same and kept and not left and (work / "theory.json").exists():
        return Verdict(True, "written into the working directory itself; the user's file kept")
    return Verdict(False, f"working directory replaced: {not same}, user file kept: {kept}, debris: {left}")


# ----------------------------------------------------------------------------------------------------------------
# Items 9, 10, 13 (developer `faults`): calibrate as a set, Ctrl-C
# ----------------------------------------------------------------------------------------------------------------


def calibrate_killed_is_one_set(tmp: Path) -> Verdict:
    import tomllib

    records = tank_records(tmp, "captive")
    out = tmp / "o"
    first = jaxroll("calibrate", "captive", records, "--out", out, cwd=tmp)
    if first.code:
        return Verdict(False, f"the first calibration failed: {last_line(first.err)}")
    before = (out / "ship.toml").stat().st_mtime_ns
    proc = start(
        "calibrate", "captive", records, "--estimator", "ls", "--name", "second", "--out", out, cwd=tmp
    )
    while proc.poll() is None and (out / "ship.toml").stat().st_mtime_ns == before:
        time.sleep(0.02)
    if proc.poll() is None:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    ship = tomllib.loads((out / "ship.toml").read_text())
    payload = json.loads((out / "calibration.json").read_text())
    if ship["correction"]["gm_ratio"] != payload["written"]["gm_correction"]:
        return Verdict(
            False,
            f"ship.toml gm_ratio {ship['correction']['gm_ratio']} beside calibration.json's "
            f"{payload['written']['gm_correction']}",
        )
    return Verdict(True, "ship.toml and calibration.json of one run")


def ctrl_c_during_imports(tmp: Path) -> Verdict:
    # the `jaxroll` console script (`_jaxroll_console.main`: guarded before `import jaxroll`), not `python -m jaxroll`
    proc = subprocess.Popen(
        [sys.executable, str(ROOT / "_jaxroll_console.py"), "pdf", "--out", str(tmp / "o")],
        cwd=tmp,
        env=_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(0.3)
    proc.send_signal(signal.SIGINT)
    try:
        out, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        return Verdict(False, "still running 60 s after Ctrl-C")
    if proc.returncode != 130 or "Traceback" in err:
        return Verdict(False, f"exit {proc.returncode}: {last_line(err)}")
    return Verdict(True, f"exit 130: {last_line(err)}")


def ctrl_c_test_under_load(tmp: Path) -> Verdict:
    t0 = time.time()
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-n",
            "0",
            "-p",
            "no:cacheprovider",
            str(ROOT / "tests" / "test_cli.py"),
            "-k",
            "ctrl_c",
        ],
        cwd=ROOT,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=1800,
    )
    if proc.returncode == 0:
        return Verdict(
            True, f"the suite's Ctrl-C tests pass ({time.time() - t0:.0f} s, load {os.getloadavg()[0]:.1f})"
        )
    return Verdict(False, last_line(proc.stdout))


# ----------------------------------------------------------------------------------------------------------------
# Item 11: options checked before any computation (and cases added)
# ----------------------------------------------------------------------------------------------------------------


def _before_fit(tmp, *argv, pattern=r"time steps per realization"):
    run = jaxroll(*argv, "--out", tmp / "o", cwd=tmp)
    verdict = held_if_error(run, pattern)
    if verdict.held and re.search(r"Monte Carlo:|Sweep:|Sensitivities:|^maxima:", run.out, re.M):
        return Verdict(False, f"reported only after the run started: {last_line(run.err)}")
    return verdict


def dt_1e_9(tmp):
    return _before_fit(tmp, "pdf", "--dt", "1e-9")


def duration_1e12(tmp):
    return _before_fit(tmp, "maxima", "--duration", "1e12")


def risk_hours_1e9(tmp):
    return _before_fit(tmp, "risk", "--hours", "1e9")


def sensitivity_dt_1e_9(tmp):  # was an out-of-memory traceback after the filter fit
    return _before_fit(tmp, "sensitivity", "--dt", "1e-9")


def sensitivity_superposition_sea_derivative(tmp):
    return _before_fit(
        tmp,
        "sensitivity",
        "--method",
        "superposition",
        "--wrt",
        "hs",
        pattern=r"sea-parameter derivatives need the filter",
    )


# ----------------------------------------------------------------------------------------------------------------
# Item 12 (developer `hulls`): Ikeda beyond its range
# ----------------------------------------------------------------------------------------------------------------


def sgisc_box_barge(tmp: Path) -> Verdict:
    stl = prism_stl(tmp / "box.stl", [(-10, 0), (10, 0), (10, 10), (-10, 10)], 100.0)
    run = jaxroll(
        "sgisc",
        stl,
        "--draught",
        4,
        "--kg",
        5,
        "--speed-kn",
        10,
        "--lpp",
        100,
        "--x-ap",
        0,
        "--roll-period",
        10,
        "--out",
        tmp / "o",
        cwd=tmp,
    )
    if run.code == 0:
        return Verdict(True, "assessed")
    return held_if_error(
        run, r"(?i)ikeda.*--damping|--damping.*ikeda", absent=r"damping coefficients must be >= 0"
    )


# ----------------------------------------------------------------------------------------------------------------
# "Figures and words"
# ----------------------------------------------------------------------------------------------------------------


def maxima_terminal_mean(tmp: Path) -> Verdict:
    run = jaxroll(
        "maxima", "--hs", 9, "--n0", "20,100", "--realizations", 200, "--out", tmp / "o", "--quiet", cwd=tmp
    )
    if run.code:
        return Verdict(False, f"exit {run.code}: {last_line(run.err)}")
    if "∞" in run.out:
        return Verdict(False, "the terminal prints 'mean max ∞'")
    return Verdict(True, next((ln.strip()[:150] for ln in run.out.splitlines() if "mean max" in ln), "no ∞"))


def risk_ci_near_one(tmp: Path) -> Verdict:
    run = jaxroll("risk", "--realizations", 50, "--duration", 1200, "--out", tmp / "o", "--quiet", cwd=tmp)
    if run.code:
        return Verdict(False, f"exit {run.code}: {last_line(run.err)}")
    if "1.0000–1.0000" in run.out:
        return Verdict(False, "prints the interval 1.0000–1.0000")
    line = next((ln for ln in run.out.splitlines() if ln.startswith("Independent")), "")
    return Verdict(True, line[:150])


# ----------------------------------------------------------------------------------------------------------------

# ----------------------------------------------------------------------------------------------------------------
# Issue 45: the new commands as strict as the old ones (items 1-12, 17-20)
# ----------------------------------------------------------------------------------------------------------------

CALM_SCATTER = (
    "hs_m,8.5,9.5\n0.5,1,1\n1.0,1,1\n"  # every cell's theory is 0 exactly: a long-term run in seconds
)


def _longterm(tmp: Path, *argv, scatter: str = CALM_SCATTER, out: str = "out") -> Run:
    (tmp / "scatter.csv").write_text(scatter)
    return jaxroll(
        "longterm", "--scatter", tmp / "scatter.csv", "--quiet", "--out", tmp / out, *argv, cwd=tmp
    )


def _box12(tmp: Path) -> Path:
    """A 12-triangle box 120 x 20 x 12 m (one diagonal per face), whose diagonals meet the symmetry check's grid."""
    return prism_stl(tmp / "box.stl", [(-10, 0), (10, 0), (10, 12), (-10, 12)], 120.0)


def _parts(tmp: Path) -> list[Path]:
    for i in (1, 2):
        run = _longterm(tmp, "--heading", "180,150", "--part", f"{i}/2", out="parts")
        if run.code != 0:
            raise RuntimeError(f"part {i}/2: {last_line(run.err)}")
    return sorted((tmp / "parts").glob("longterm.part-*-of-2.nc"))


def _edited_part(tmp: Path, edit: str) -> Run:
    first, second = _parts(tmp)
    done = python(
        "import numpy as np\nfrom jaxroll.io import read_dataset, write_dataset\n"
        f"ds = read_dataset({str(first)!r})\n{edit}\nwrite_dataset({str(tmp / 'edited.nc')!r}, ds)\n",
        cwd=tmp,
    )
    if done.code != 0:
        raise RuntimeError(last_line(done.err))
    return jaxroll("merge", tmp / "edited.nc", second, "--out", tmp / "merged", cwd=tmp)


def merge_tripled_weights(tmp):
    return held_if_error(
        _edited_part(tmp, 'ds["weight"] = ds.weight * 3'), r"was changed since jaxroll wrote it"
    )


def merge_probability_seven(tmp):
    edit = 'ds["probability"] = ds.probability.where(~ds.computed, 7.0)'
    return held_if_error(_edited_part(tmp, edit), r"was changed since jaxroll wrote it")


def merge_other_version(tmp):
    edit = 'ds.attrs["jax_version"] = "0.4.0"'
    return held_if_error(_edited_part(tmp, edit), r"written by another jaxroll or JAX \(jax_version 0\.4\.0")


def merge_missing_variable(tmp):
    return held_if_error(_edited_part(tmp, 'ds = ds.drop_vars("seed")'), r"lacks the variables seed")


def merge_deep_config(tmp):
    edit = 'ds.attrs["config_json"] = "[" * 5000 + "]" * 5000'
    return held_if_error(_edited_part(tmp, edit), r"config_json attribute is not the JSON")


def merge_bad_part_attribute(tmp):
    return held_if_error(
        _edited_part(tmp, 'ds.attrs["part"] = "one/2"'), r"part attribute 'one/2' is not i/N"
    )


def kg_datum_without_kg(tmp):
    run = jaxroll("hydrostatics", _box12(tmp), "--lpp", "120", "--roll-period", "12", "--draught", "5",
                  "--gm", "2", "--kg-datum", "keel", "--out", tmp / "out", cwd=tmp)  # fmt: skip
    return held_if_error(run, r"--kg-datum \(it applies to --kg.*would be ignored")


def draught_datum_without_draught(tmp):
    run = jaxroll("hydrostatics", _box12(tmp), "--lpp", "120", "--roll-period", "12", "--displacement", "1e7",
                  "--kg", "6", "--draught-datum", "keel", "--out", tmp / "out", cwd=tmp)  # fmt: skip
    return held_if_error(run, r"--draught-datum \(it applies to --draught.*would be ignored")


def scatter_counts_overflow(tmp):
    run = _longterm(tmp, scatter="hs_m,8.5,9.5\n4.5,1e308,1e308\n6.5,1,1\n")
    return held_if_error(run, r"the counts sum to more than the largest number")


def longterm_speed_1e6(tmp):
    return held_if_error(_longterm(tmp, "--speed", "1e6"), r"--speed: U = 1e\+06 m/s is a Froude number")


def longterm_hours_beyond_year(tmp):
    return held_if_error(_longterm(tmp, "--hours", "10000"), r"--hours \(10000 h\) is longer than the 8766 h")


def longterm_hours_per_year_1e9(tmp):
    return held_if_error(_longterm(tmp, "--hours-per-year", "1e9"), r"--hours-per-year must be at most 8766")


def _lab_import(tmp: Path, rows: list[str], *extra) -> Run:
    (tmp / "lab.csv").write_text("\n".join(["Time [s],Roll [deg],WP1 [mm]", *rows]) + "\n")
    return jaxroll("records", "import", tmp / "lab.csv", "--kind", "roll", "--time", "1", "--roll", "2", "--wave",
                   "3", "--scale", "100", "--hs", "7", "--t01", "10", "--probe-x", "0", "--out", tmp / "o", *extra,
                   cwd=tmp)  # fmt: skip


def records_time_in_ms(tmp):
    rows = [f"{50 * k},{math.sin(0.3 * k):.4f},{math.cos(0.2 * k):.4f}" for k in range(60)]
    return held_if_error(_lab_import(tmp, rows), r"jaxroll records import: error: .*a sample every 50 s")


def records_unit_twice(tmp):
    rows = [f"{0.1 * k:.1f},{math.sin(0.3 * k):.4f},{math.cos(0.2 * k):.4f}" for k in range(60)]
    return held_if_error(_lab_import(tmp, rows, "--units", "roll=deg,roll=rad"), r"--units gives roll twice")


def cad_box_symmetric(tmp):
    run = jaxroll("hydrostatics", _box12(tmp), "--lpp", "120", "--roll-period", "12", "--draught", "5", "--kg",
                  "6", "--out", tmp / "out", cwd=tmp)  # fmt: skip
    if run.code != 0:
        return Verdict(False, f"exit {run.code}: {last_line(run.err)}")
    return Verdict(True, f"exit 0 in {run.seconds:.0f} s: the 12-triangle box is symmetric")


def longterm_seed_1e14(tmp):
    return held_if_error(
        _longterm(tmp, "--seed", str(10**14)), r"--seed must be an integer in \[0, 999999999999\]"
    )


def longterm_api_types(tmp):
    run = python(
        "import jaxroll\njaxroll.configure()\n"
        "for kw in (dict(scatter=123), dict(ships='c11'), dict(checkpoint=123)):\n"
        "    try:\n        jaxroll.longterm(**kw)\n    except ValueError as e:\n        print('ValueError', e)\n",
        cwd=tmp,
    )
    n = run.out.count("ValueError")
    return Verdict(n == 3 and "Traceback" not in run.err, f"{n} of 3 a ValueError naming the argument")


def longterm_fifo_checkpoint(tmp):
    run = _longterm(tmp, "--heading", "180", "--checkpoint", tmp / "ck")
    (unit,) = (tmp / "ck").glob("theory_*.npz")
    unit.unlink()
    os.mkfifo(unit)
    try:
        run = _longterm(tmp, "--heading", "180", "--checkpoint", tmp / "ck", out="out2")
    except subprocess.TimeoutExpired:
        return Verdict(False, "hung on the FIFO")
    return held_if_warning(run, r"is not a regular file")


def records_gzip_bomb(tmp):
    import gzip

    with gzip.open(tmp / "bomb.csv.gz", "wb", compresslevel=9) as f:
        f.write(b"Time [s],Roll [deg],WP1 [mm]\n")
        for _ in range(256):
            f.write(b"0.1,1.0,2.0\n" * 87382)  # 256 MiB of text in 0.5 MiB
    run = jaxroll("records", "import", tmp / "bomb.csv.gz", "--kind", "roll", "--time", "1", "--roll", "2",
                  "--wave", "3", "--scale", "100", "--hs", "7", "--t01", "10", "--probe-x", "0", "--out", tmp / "o",
                  cwd=tmp, timeout=300)  # fmt: skip
    return held_if_error(run, r"more than 24 MiB of text once decompressed")


def longterm_no_negative_zero(tmp):
    run = _longterm(tmp, "--heading", "180")
    ok = run.code == 0 and "per year: P = 0," in run.out and "-0" not in run.out
    return Verdict(ok, last_line(run.out) if ok else f"exit {run.code}: {last_line(run.text)}")


def checkpoint_on_a_file(tmp):
    (tmp / "afile").write_text("")
    return held_if_error(
        _longterm(tmp, "--checkpoint", tmp / "afile"), r"--checkpoint .* exists and is not a folder"
    )


def out_dangling_symlink(tmp):
    (tmp / "link").symlink_to(tmp / "nowhere" / "x")
    run = jaxroll("risk", "--realizations", "40000", "--out", tmp / "link", cwd=tmp)
    return held_if_error(run, r"--out .* is a symbolic link to .*which does not exist")


def risk_splitting_superposition(tmp):
    run = jaxroll("risk", "--estimator", "splitting", "--method", "superposition", "--realizations", "40000",
                  "--out", tmp / "out", cwd=tmp)  # fmt: skip
    verdict = held_if_error(run, r"--estimator splitting needs --method filter")
    if verdict.held and run.seconds > 20:
        return Verdict(False, f"refused after {run.seconds:.0f} s (after computing)")
    return verdict


def scatter_million_cells(tmp):
    tz = ",".join(f"{5 + 0.01 * j:.2f}" for j in range(1000))
    rows = "\n".join(f"{0.01 + 0.001 * i:.3f}," + ",".join(["1"] * 1000) for i in range(1001))
    run = _longterm(tmp, "--heading", "180", scatter=f"hs_m,{tz}\n{rows}\n")
    return held_if_error(run, r"computation cells .* of the scatter diagram .*scatter\.csv\)")


def risk_command_quoted(tmp):
    run = python(
        "import json, math, shlex, jaxroll\nfrom jaxroll.longterm import parse_scatter, risk_command\n"
        "jaxroll.configure()\n"
        f"ds = jaxroll.longterm(parse_scatter({CALM_SCATTER!r}, 'calm.csv'))\n"
        "cfg = json.loads(ds.attrs['config_json']); cfg['ships'][0]['file'] = 'my ship;touch PWNED;.toml'\n"
        "ds.attrs['config_json'] = json.dumps(cfg)\n"
        "print(risk_command(ds, dict(hs=0, tz=0, heading=0, speed=0, ship=0)))\n",
        cwd=tmp,
    )
    command = run.out.strip().splitlines()[-1] if run.out.strip() else ""
    subprocess.run(["bash", "-c", "true" + command.removeprefix("jaxroll")], cwd=tmp)
    return Verdict(bool(command) and not (tmp / "PWNED").exists(), command[-80:] or last_line(run.err))


def cache_another_program(tmp):
    code = f"""
import pathlib, jax.numpy as jnp, jaxroll
jaxroll.configure()
from jaxroll import _cache_files as files, _compiled
folder = pathlib.Path({str(tmp / "cache")!r})
_compiled.cache_dir = lambda: folder
@_compiled.cached_program
def prog(a, x, p: int):
    return a * x**p
@_compiled.cached_program
def other(a, b, c):
    return a + b + c
ref = prog(jnp.asarray(3.0), jnp.arange(4.0), 1)
other(jnp.asarray(1.0), jnp.asarray(2.0), jnp.arange(3.0))
mine, theirs = sorted(folder.glob("*.npz"), key=lambda p: p.stat().st_mtime_ns)
mine.write_bytes(files.entry_bytes(mine.stem, files.read_entry(theirs, theirs.stem)))
_compiled._LOADED.clear()
print("same" if (prog(jnp.asarray(3.0), jnp.arange(4.0), 1) == ref).all() else "different")
"""
    run = python(code, cwd=tmp)
    return Verdict(run.out.strip().endswith("same"), last_line(run.text))


def cache_path_a_file(tmp):
    (tmp / "afile").write_text("")
    run = jaxroll("ship", "show", cwd=tmp, env=_env(JAXROLL_CACHE_DIR=str(tmp / "afile")))
    verdict = held_if_warning(run, r"afile is a file, not a folder")
    if verdict.held and "others could plant" in run.err:
        return Verdict(False, "still says 'others could plant'")
    return verdict


def risk_estimator_direct_deprecated(tmp):
    run = jaxroll("risk", "--estimator", "direct", "--angle", "95", "--out", tmp / "out", cwd=tmp)
    return held_if_warning(run, r"--estimator direct is now called brute-force")


def _longterm_with_sigint(tmp: Path) -> Verdict:
    """SIGINT at random times around unit saves, 15 tries (each a fresh run resuming its checkpoint): exit 130 and
    no --out every time."""
    import random

    (tmp / "scatter.csv").write_text("hs_m,8.5,9.5\n4.5,1,2\n6.5,3,1\n")
    lost = 0
    for k in range(15):
        proc = start("longterm", "--scatter", tmp / "scatter.csv", "--heading", "180,150,120", "--quiet",
                     "--checkpoint", tmp / f"ck{k}", "--out", tmp / f"out{k}", cwd=tmp)  # fmt: skip
        deadline = time.time() + 600
        while proc.poll() is None and time.time() < deadline and not list((tmp / f"ck{k}").glob("*.npz")):
            time.sleep(0.01)
        time.sleep(random.uniform(0.0, 0.1))  # within 0.1 s of the first unit's save
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=600)
        lost += proc.returncode != 130 or (tmp / f"out{k}").exists()
    return Verdict(lost == 0, f"{lost} of 15 interrupts lost")


CASES = [
    Case("asymmetric-hull", "37.1", "a prism with one side flared read as symmetric", asymmetric_hull),
    Case(
        "captive-wave-mm-labelled-m",
        "37.2",
        "captive wave column in mm, header m: gm_ratio 4.3e-08",
        captive_wave_mm_labelled_m,
    ),
    Case(
        "roll-wave-mm-labelled-m",
        "37.2",
        "roll records' wave in mm, header m: 'SVD did not converge'",
        roll_wave_mm_labelled_m,
    ),
    Case("ship-gm0-in-mm", "37.3", "GM0 1929.9 m accepted by ship show", ship_gm0_in_mm),
    Case("ship-lpp-in-mm", "37.3", "Lpp 262 000 m accepted", ship_lpp_in_mm),
    Case("ship-c1-1e9", "37.3", "c1 = 1e9 accepted", ship_c1_1e9),
    Case("ship-vanishing-2deg", "37.3", "a3 = −50: vanishing angle 2.1° accepted", ship_vanishing_angle_2deg),
    Case("ship-b1-1e6", "37.3", "b1 = 1e6 accepted", ship_b1_1e6),
    Case(
        "pdf-lpp-in-mm-cause",
        "37.3",
        "pdf with Lpp 262 km advised --method superposition",
        pdf_lpp_in_mm_names_the_cause,
    ),
    Case("decay-negative-b2", "37.4", "b2 −0.081 clipped to 0 in ship.toml, no message", decay_negative_b2),
    Case(
        "checkpoint-edited-histogram",
        "37.5",
        "a hand-edited histogram resumed (median 7.75° → 23.4°)",
        checkpoint_edited_histogram,
    ),
    Case(
        "checkpoint-rewound-next-start",
        "37.5",
        "a rewound next_start double-counted (digest recomputed)",
        checkpoint_rewound_next_start,
    ),
    Case(
        "hs-30-beyond-breaking",
        "37.6",
        "--hs 30 at T01 10 s without a word; Roberts 2.5° vs MC 15°",
        hs_30_beyond_breaking,
    ),
    Case("cache-programs-pickle", "37.7", "a planted jaxroll-programs file ran code", cache_programs_pickle),
    Case("cache-moment-pickle", "37.7", "a planted jaxroll-moment file ran code", cache_moment_tables_pickle),
    Case(
        "cache-writable-by-others",
        "37.7",
        "a cache folder anyone can write used silently",
        cache_writable_by_others,
    ),
    Case("out-mount-point", "37.8", "--out on a mount point: EXDEV and debris", out_on_mount_point),
    Case(
        "out-read-only",
        "37.8",
        "a read-only --out reported after the computation, as a traceback",
        out_read_only,
    ),
    Case("out-full-disk", "37.8", "a full disk: ENOSPC traceback", out_full_disk),
    Case(
        "sigkill-debris",
        "37.8",
        "SIGKILL left .out.partial-* that were never cleaned",
        sigkill_debris_cleaned,
    ),
    Case("out-dot", "37.8", "--out . swapped the working directory", out_dot_keeps_cwd),
    Case(
        "calibrate-killed",
        "37.9",
        "calibrate killed mid-write left ship.toml beside an older calibration.json",
        calibrate_killed_is_one_set,
    ),
    Case("ctrl-c-imports", "37.10", "Ctrl-C during the imports printed a traceback", ctrl_c_during_imports),
    Case("dt-1e-9", "37.11", "--dt 1e-9 reported after the filter fit", dt_1e_9),
    Case("duration-1e12", "37.11", "--duration 1e12 reported after the filter fit", duration_1e12),
    Case(
        "sgisc-box-barge",
        "37.12",
        "simplified Ikeda negative: 'damping coefficients must be >= 0'",
        sgisc_box_barge,
    ),
    Case(
        "ctrl-c-test-under-load", "37.13", "the suite's Ctrl-C test failed under load", ctrl_c_test_under_load
    ),
    Case("maxima-mean-infinity", "37.F", "the terminal printed 'mean max ∞'", maxima_terminal_mean),
    Case("risk-ci-1.0000", "37.F", "risk printed the interval 1.0000–1.0000", risk_ci_near_one),
    Case(
        "ship-displacement-tonnes",
        "37+",
        "displacement in tonnes in a ship file",
        ship_displacement_in_tonnes,
    ),
    Case(
        "ship-gm-vs-roll-period",
        "37+",
        "GM0 and roll period that no radius of gyration joins",
        ship_gm_against_roll_period,
    ),
    Case(
        "ship-gm-ratio-4e-8",
        "37+",
        "a ship file carrying the slipped captive result",
        ship_gm_ratio_from_slipped_records,
    ),
    Case(
        "pdf-theories-capsizing-sea",
        "37+",
        "theories overlaid on a sea where most trials capsize",
        pdf_theories_against_capsizing_sea,
    ),
    Case("risk-hours-1e9", "37+", "--hours 1e9 reported after the amplitude Monte Carlo", risk_hours_1e9),
    Case("sensitivity-dt-1e-9", "37+", "sensitivity --dt 1e-9: out-of-memory traceback", sensitivity_dt_1e_9),
    Case(
        "merge-tripled-weights",
        "45.1",
        "a part whose weights were tripled merged (P_LT x3)",
        merge_tripled_weights,
    ),
    Case("merge-probability-7", "45.1", "a probability of 7 in a part merged", merge_probability_seven),
    Case("merge-other-jax", "45.1", "a part of another JAX version merged", merge_other_version),
    Case("kg-datum-without-kg", "45.2", "--kg-datum with --gm ignored without a word", kg_datum_without_kg),
    Case(
        "draught-datum-without-draught",
        "45.2",
        "--draught-datum with --displacement ignored",
        draught_datum_without_draught,
    ),  # fmt: skip
    Case("scatter-overflow", "45.3", "counts 1e308 + 1e308: P_LT = 0", scatter_counts_overflow),
    Case("longterm-speed-1e6", "45.4", "--speed 1e6 m/s: P = 0", longterm_speed_1e6),
    Case(
        "longterm-hours-beyond-year", "45.4", "--hours 10000 > --hours-per-year", longterm_hours_beyond_year
    ),
    Case("longterm-hours-per-year-1e9", "45.4", "--hours-per-year 1e9 accepted", longterm_hours_per_year_1e9),
    Case(
        "records-time-in-ms", "45.4", "a time column in ms labelled s (0.02 Hz) accepted", records_time_in_ms
    ),
    Case("records-unit-twice", "45.4", "a unit given twice for one column: the last won", records_unit_twice),
    Case("cad-box-symmetric", "45.5", "a 12-triangle box refused as asymmetric", cad_box_symmetric),
    Case("longterm-seed-1e14", "45.6", "--seed 1e14: OverflowError", longterm_seed_1e14),
    Case("merge-missing-variable", "45.6", "a part lacking a variable: KeyError", merge_missing_variable),
    Case("merge-deep-config", "45.6", "config_json 5000 deep: RecursionError", merge_deep_config),
    Case(
        "longterm-api-types",
        "45.6",
        "longterm(scatter=123 / ships='c11' / checkpoint=123)",
        longterm_api_types,
    ),
    Case(
        "longterm-fifo-checkpoint",
        "45.7",
        "a FIFO as a checkpoint unit hung the run",
        longterm_fifo_checkpoint,
    ),
    Case("records-gzip-bomb", "45.8", "a 0.5 MiB .csv.gz of 256 MiB: 5.6 GiB RSS", records_gzip_bomb),
    Case("longterm-negative-zero", "45.9", "'per year: P = -0'", longterm_no_negative_zero),
    Case("merge-bad-part-attribute", "45.10", "merge: 'invalid literal for int()'", merge_bad_part_attribute),
    Case(
        "checkpoint-on-a-file",
        "45.10",
        "--checkpoint a file: 'File exists' without the option",
        checkpoint_on_a_file,
    ),  # fmt: skip
    Case(
        "out-dangling-symlink",
        "45.10",
        "--out a dangling symlink refused after computing",
        out_dangling_symlink,
    ),
    Case(
        "risk-splitting-superposition",
        "45.10",
        "refused after the direct Monte Carlo, naming a function",
        risk_splitting_superposition,
    ),  # fmt: skip
    Case(
        "scatter-million-cells", "45.10", "1001 x 1000 scatter: error without the file", scatter_million_cells
    ),
    Case("risk-command-quoted", "45.11", "risk_command not shell-quoted: ';' ran touch", risk_command_quoted),
    Case("cache-another-program", "45.12", "a valid entry of another program: exit 2", cache_another_program),
    Case(
        "cache-path-a-file", "45.12", "a cache path that is a file: 'others could plant'", cache_path_a_file
    ),
    Case(
        "risk-estimator-direct",
        "45.17",
        "risk/longterm estimator names differ",
        risk_estimator_direct_deprecated,
    ),
    Case(
        "longterm-sigint-near-save",
        "45.20",
        "a SIGINT near a unit save lost (1 in 15)",
        _longterm_with_sigint,
    ),
    Case(
        "sensitivity-superposition-hs",
        "37+",
        "--method superposition --wrt hs refused only after the fit",
        sensitivity_superposition_sea_derivative,
    ),
]


def main() -> int:
    global CACHE
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "-k",
        action="append",
        default=[],
        help="run the cases whose name contains this, or whose item is this (e.g. 37.5)",
    )
    parser.add_argument("--list", action="store_true", help="list the cases and exit")
    parser.add_argument(
        "--cache", default=None, help="JAXROLL_CACHE_DIR for the commands (default: the user's)"
    )
    args = parser.parse_args()
    CACHE = args.cache
    cases = [c for c in CASES if not args.k or any(k in c.name or k == c.item for k in args.k)]
    if args.list:
        for c in cases:
            print(f"{c.item:>6}  {c.name:<32} {c.what}")
        return 0
    failed = 0
    t_all = time.time()
    for c in cases:
        tmp = Path(tempfile.mkdtemp(prefix=f"jaxroll-audit-{c.name}-"))
        t0 = time.time()
        try:
            verdict = c.run(tmp)
        except Exception as e:  # a case that cannot build its inputs fails, with the reason
            verdict = Verdict(False, f"{type(e).__name__}: {str(e)[:150]}")
        finally:
            for p in tmp.rglob("*"):  # make everything removable again (the cache case chmods)
                if p.is_dir() and not p.is_symlink():
                    p.chmod(p.stat().st_mode | stat.S_IWUSR | stat.S_IXUSR)
            shutil.rmtree(tmp, ignore_errors=True)
        word = {True: "held", False: "FAILED", None: "skipped"}[verdict.held]
        failed += verdict.held is False
        print(
            f"{word:>7}  {c.item:>6}  {c.name:<32} ({time.time() - t0:5.0f} s)  {verdict.reason}", flush=True
        )
    print(
        f"{len(cases)} cases, {failed} failed, {sum(1 for _ in cases) - failed} held or skipped, "
        f"{time.time() - t_all:.0f} s"
    )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
