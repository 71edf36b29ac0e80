"""Scale-out: sharding over devices and processes, checkpoint/resume, and the `jaxroll sweep` map.

Multi-device runs happen in child processes: `JAX_NUM_CPU_DEVICES` must be set before JAX
initialises, and this process already has one CPU device. The problem is built once here and pickled to them.
"""

import json
import os
import pickle
import socket
import subprocess
import sys
import textwrap

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_labelled_output, default_problem

import jaxroll
from jaxroll import monte_carlo_max_roll, realization_mesh, wilson_interval
from jaxroll._cli import main
from jaxroll.roll._sharding import CHECKPOINT_FILE, _content_digest

N = 7  # odd: divides neither 2 nor 4 devices, so every sharded run pads its last chunk
DURATION = 300.0
# Per-realization float sums (zero-crossing, φ², envelope) whose value depends on the exact trajectory.
FLOAT_FIELDS = ("sum_zc", "sumsq_zc", "sum_env", "sumsq_env", "sum_phi2", "sum_phi4")

CHILD = textwrap.dedent(
    """
    import pickle, sys
    import jax
    nproc, pid = int(sys.argv[1]), int(sys.argv[2])
    port, problem_file, out = sys.argv[3:6]
    if nproc > 1:
        jax.distributed.initialize(f"localhost:{port}", num_processes=nproc, process_id=pid)
    import numpy as np
    import jaxroll
    from jaxroll import monte_carlo_max_roll

    jaxroll.configure()  # float64, platform-independent math: results independent of the devices, bit for bit

    problem = pickle.load(open(problem_file, "rb"))
    key = jax.random.key(11)
    results = {"device_count": jax.device_count()}
    for devices, chunk in [(1, 2), (2, 4), (4, 5)] if nproc == 1 else []:
        s = jaxroll.monte_carlo_amplitudes(problem, key, num_realizations=7, duration=300.0, chunk_size=chunk,
                                           devices=devices)
        tag = f"amp_{devices}_{chunk}"
        results[f"{tag}_counts_zero_crossing"] = s.counts_zero_crossing
        results[f"{tag}_counts_envelope"] = s.counts_envelope
        results[f"{tag}_capsized"] = s.capsized
        results[f"{tag}_capsize_time"] = s.capsize_time
        for k, v in s.per_realization.items():
            results[f"{tag}_{k}"] = v
    for devices, chunk in [(1, 2), (4, 8), (4, 4)] if nproc == 1 else [(None, 8)]:
        m = monte_carlo_max_roll(problem, key, angle_deg=12.0, num_realizations=7, duration=300.0,
                                 chunk_size=chunk, devices=devices)
        tag = f"max_{devices}_{chunk}"
        results[f"{tag}_phi"] = m.max_abs_phi_deg
        results[f"{tag}_n_exceeded"] = m.n_exceeded
        results[f"{tag}_capsized"] = m.capsized
    if nproc == 1:  # the sharded histogram chunk as compiled: each device keeps to its own realizations
        import jax.numpy as jnp
        from jaxroll.roll._monte_carlo import simulate_chunk
        from jaxroll.roll._observers import AmplitudeHistogram
        from jaxroll.roll._sharding import _compiled, _global_array, realization_mesh
        mesh = realization_mesh(4)
        along = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("realizations"))
        args = (_global_array(np.arange(8), along), _global_array(np.ones(8, bool), along))
        text = _compiled(simulate_chunk, mesh).jitted.lower(
            problem, key, *args, AmplitudeHistogram(), 600, jnp.float32).compile().compiled.as_text()
        results["hlo_collectives"] = np.array([text.count(" all-gather("), text.count(" all-reduce(")])
    np.savez(f"{out}/results_{pid}.npz", **results)
    """
)


def _child_env(devices_per_process: int) -> dict:
    env = {
        k: v for k, v in os.environ.items() if k != "JAX_NUM_CPU_DEVICES"
    }  # set for xdist workers (conftest)
    env["JAX_NUM_CPU_DEVICES"] = str(devices_per_process)
    env["JAX_PLATFORMS"] = "cpu"
    return env


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def problem():
    return default_problem(7.0)


@pytest.fixture(scope="module")
def child_files(problem, tmp_path_factory):
    folder = tmp_path_factory.mktemp("children")
    (folder / "child.py").write_text(CHILD)
    with open(folder / "problem.pkl", "wb") as f:
        pickle.dump(problem, f)
    return folder


@pytest.fixture(scope="module")
def four_devices(child_files):
    """Results of one process with 4 CPU devices: the same Monte Carlo on 1, 2 and 4 of them."""
    out = child_files / "single"
    out.mkdir()
    cmd = [
        sys.executable,
        str(child_files / "child.py"),
        "1",
        "0",
        "0",
        str(child_files / "problem.pkl"),
        str(out),
    ]
    proc = subprocess.run(cmd, env=_child_env(4), capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    with np.load(out / "results_0.npz") as data:
        return dict(data)


def _assert_same(results, tag, ref="amp_1_2", float_rtol=0.0):
    """Integer-valued outputs bit for bit; per-realization float sums to `float_rtol`."""
    for name in (
        "counts_zero_crossing",
        "counts_envelope",
        "capsized",
        "capsize_time",
        "n_zc",
        "n_env",
        "n_samples",
    ):
        np.testing.assert_array_equal(results[f"{tag}_{name}"], results[f"{ref}_{name}"], err_msg=name)
    for name in FLOAT_FIELDS:
        np.testing.assert_allclose(
            results[f"{tag}_{name}"], results[f"{ref}_{name}"], rtol=float_rtol, atol=0, err_msg=name
        )


def test_sharded_equals_single_device(four_devices):
    r = four_devices
    assert r["device_count"] == 4
    # no device gathers the others' roll histories (the envelope FFT of the whole chunk on every device, as XLA's
    # sharding propagation once chose); the statistics are added across devices by all-reduces
    all_gather, all_reduce = r["hlo_collectives"]
    assert all_gather == 0 and all_reduce >= 1
    assert r["amp_1_2_counts_zero_crossing"].sum() > 0 and r["amp_1_2_counts_envelope"].sum() > 0
    # Two realizations per device per chunk, as in the 1-device run with chunks of 2: bit for bit, except the
    # float64 envelope sums, which XLA may reduce in another order once partitioned (≤ 1e-13 relative).
    for tag in ("amp_2_4", "amp_4_5"):  # chunk 5 on 4 devices is rounded up to 8, one padded realization
        _assert_same(r, tag, float_rtol=1e-13)
        for name in ("sum_zc", "sumsq_zc", "sum_phi2", "sum_phi4"):
            np.testing.assert_array_equal(r[f"{tag}_{name}"], r[f"amp_1_2_{name}"], err_msg=name)
    # The dedicated max-|φ| Monte Carlo (integer counts summed on device): bit for bit.
    np.testing.assert_array_equal(r["max_4_8_phi"], r["max_1_2_phi"])
    np.testing.assert_array_equal(r["max_4_8_capsized"], r["max_1_2_capsized"])
    assert r["max_4_8_n_exceeded"] == r["max_1_2_n_exceeded"] > 0
    # One realization per device and chunk is padded to two (XLA compiles a batch of one differently, which in
    # float32 moved φ by ~3e-7): bit for bit as well.
    np.testing.assert_array_equal(r["max_4_4_phi"], r["max_1_2_phi"])
    np.testing.assert_array_equal(r["max_4_4_capsized"], r["max_1_2_capsized"])
    assert r["max_4_4_n_exceeded"] == r["max_1_2_n_exceeded"]


def test_two_processes_equal_one(four_devices, child_files):
    """Two processes × two CPU devices joined by jax.distributed give the 4-device results exactly."""
    out = child_files / "multi"
    out.mkdir()
    port = str(_free_port())
    procs = [
        subprocess.Popen(
            [
                sys.executable,
                str(child_files / "child.py"),
                "2",
                str(pid),
                port,
                str(child_files / "problem.pkl"),
                str(out),
            ],
            env=_child_env(2),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for pid in (0, 1)
    ]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err[-3000:]
    for pid in (0, 1):  # every process gets the whole per-realization array and the global counts
        with np.load(out / f"results_{pid}.npz") as r:
            assert r["device_count"] == 4
            np.testing.assert_array_equal(r["max_None_8_phi"], four_devices["max_4_8_phi"])
            np.testing.assert_array_equal(r["max_None_8_capsized"], four_devices["max_4_8_capsized"])
            assert r["max_None_8_n_exceeded"] == four_devices["max_4_8_n_exceeded"]


# ----------------------------------------------------------------------------------------------------------
# Checkpoints (one device, in this process)
# ----------------------------------------------------------------------------------------------------------


class Interrupt(Exception):
    pass


def _amplitudes(problem, seed=5, **kwargs):
    return jaxroll.monte_carlo_amplitudes(
        problem, jax.random.key(seed), num_realizations=5, duration=DURATION, chunk_size=2, **kwargs
    )


def _assert_identical(a, b):
    np.testing.assert_array_equal(a.counts_zero_crossing, b.counts_zero_crossing)
    np.testing.assert_array_equal(a.counts_envelope, b.counts_envelope)
    np.testing.assert_array_equal(a.capsized, b.capsized)
    np.testing.assert_array_equal(a.capsize_time, b.capsize_time)
    assert a.per_realization.keys() == b.per_realization.keys()
    for k in a.per_realization:
        np.testing.assert_array_equal(a.per_realization[k], b.per_realization[k], err_msg=k)


@pytest.fixture(scope="module")
def uninterrupted(problem):
    return _amplitudes(problem)


@pytest.fixture(scope="module")
def finished_checkpoint(problem, uninterrupted, tmp_path_factory):
    """A checkpoint directory left by a run interrupted after 2 chunks and then resumed to the end."""
    folder = tmp_path_factory.mktemp("checkpoint")

    def stop_after_two_chunks(done):
        if done >= 4:
            raise Interrupt

    with pytest.raises(Interrupt):
        _amplitudes(problem, checkpoint=folder, checkpoint_every=1, progress=stop_after_two_chunks)
    with np.load(folder / CHECKPOINT_FILE) as data:
        assert int(data["next_start"]) == 4 and data["per/sum_zc"].shape == (4,)
    calls = []
    resumed = _amplitudes(problem, checkpoint=folder, checkpoint_every=1, progress=calls.append)
    assert calls == [4, 5]  # the checkpoint's 4 once it is read, then only the last chunk ran
    return folder, resumed


def test_resume_equals_uninterrupted_run(problem, uninterrupted, finished_checkpoint):
    folder, resumed = finished_checkpoint
    _assert_identical(resumed, uninterrupted)
    # A finished run returns its result at once from the checkpoint (no chunk runs — the one progress call is the
    # checkpoint's, all realizations done —, same answer).
    calls = []
    again = _amplitudes(problem, checkpoint=folder, progress=calls.append)
    assert calls == [5]
    _assert_identical(again, uninterrupted)


def test_truncated_checkpoint_is_refused(problem, finished_checkpoint, tmp_path):
    data = (finished_checkpoint[0] / CHECKPOINT_FILE).read_bytes()
    (tmp_path / CHECKPOINT_FILE).write_bytes(data[: len(data) // 2])
    with pytest.raises(
        ValueError, match=r"is unreadable \(truncated or corrupted.*Delete .* another checkpoint"
    ):
        _amplitudes(problem, checkpoint=tmp_path)


@pytest.mark.parametrize(
    "change, message",
    [
        ("seed", r"belongs to a different run: the random key \(seed\)"),
        ("hs", r"belongs to a different run: the problem \(ship, sea state"),
        ("duration", r"belongs to a different run: the run settings"),
    ],
)
def test_foreign_checkpoint_is_refused(problem, finished_checkpoint, tmp_path, change, message):
    (tmp_path / CHECKPOINT_FILE).write_bytes((finished_checkpoint[0] / CHECKPOINT_FILE).read_bytes())
    kwargs = {}
    if change == "seed":
        kwargs["seed"] = 6
    elif change == "hs":
        problem = jaxroll.RollProblem.from_sea(jaxroll.c11_representative(), jaxroll.ITTC(5.0, 10.0))
    with pytest.raises(ValueError, match=message + r".*Delete .* or pass another checkpoint directory"):
        if change == "duration":
            jaxroll.monte_carlo_amplitudes(
                problem,
                jax.random.key(5),
                num_realizations=5,
                duration=400.0,
                chunk_size=2,
                checkpoint=tmp_path,
            )
        else:
            _amplitudes(problem, checkpoint=tmp_path, **kwargs)


def _read_checkpoint(folder):
    with np.load(folder / CHECKPOINT_FILE) as data:
        return {k: data[k] for k in data.files}


def _write_checkpoint(folder, contents, *, digest="recompute"):
    """Write `contents` as a checkpoint with its content digest recomputed (as an editor who knows the format
    would), kept as it was read ("keep"), or without one ("none")."""
    contents = dict(contents)
    if digest == "recompute":
        contents.pop("digest")
        contents["digest"] = np.array(_content_digest(contents))
    elif digest == "none":
        contents.pop("digest")
    np.savez(folder / CHECKPOINT_FILE, **contents)


def test_checkpoint_without_a_statistic_this_run_records_is_refused(problem, tmp_path):
    """A checkpoint written by a jaxroll whose observer recorded fewer per-realization statistics (here: no
    `sum_env_first_half`, as before the stationarity check) is refused on resume, not completed with zeros for
    the realizations it holds."""

    def stop_after_two_chunks(done):
        if done >= 4:
            raise Interrupt

    with pytest.raises(Interrupt):
        _amplitudes(problem, checkpoint=tmp_path, checkpoint_every=1, progress=stop_after_two_chunks)
    contents = {k: v for k, v in _read_checkpoint(tmp_path).items() if k != "per/sum_env_first_half"}
    assert int(contents["next_start"]) == 4  # interrupted after two chunks of two
    _write_checkpoint(tmp_path, contents)
    with pytest.raises(
        ValueError,
        match=r"records other statistics than this run \(only in the checkpoint: none; "
        r"only in this run: sum_env_first_half\).*Delete",
    ):
        _amplitudes(problem, checkpoint=tmp_path)


@pytest.mark.parametrize(
    "edit, digest, message",
    [
        # issue 37: a hand-edited histogram moved the median from 7.75° to 23.4°, silently
        (
            "histogram",
            "keep",
            r"has been changed since jaxroll wrote it \(its content digest does not match\)",
        ),
        (
            "histogram",
            "recompute",
            r"is inconsistent \(the zero-crossing histogram holds \d+ amplitudes \(merged included\), "
            r"the realizations \d+; next start 5\)",
        ),
        # a rewound next_start (per-realization arrays cut to match) double-counted: n_amplitudes 1.17 M → 1.76 M
        (
            "next_start",
            "recompute",
            r"is inconsistent \(the zero-crossing histogram .*the envelope histogram .*next start 4\)",
        ),
        ("envelope", "recompute", r"is inconsistent \(the envelope histogram holds"),
        ("capsized", "recompute", r"is inconsistent \(a capsized realization has amplitudes"),
        ("none", "none", r"has no content digest: it was written by an older jaxroll"),
    ],
)
def test_edited_checkpoint_is_refused(problem, finished_checkpoint, tmp_path, edit, digest, message):
    """Issue 37 item 5: a checkpoint carries a content digest, and its totals must add up to its per-realization
    records; an edited one is refused, not resumed."""
    contents = _read_checkpoint(finished_checkpoint[0])
    if edit == "histogram":
        contents["summed/counts_zero_crossing"] = contents["summed/counts_zero_crossing"].copy()
        contents["summed/counts_zero_crossing"][400:500] += 50.0
    elif edit == "envelope":
        contents["summed/counts_envelope"] = contents["summed/counts_envelope"] * 2
    elif edit == "next_start":
        contents["next_start"] = np.array(4)
        contents = {k: (v[:4] if k.startswith("per/") else v) for k, v in contents.items()}
    elif edit == "capsized":
        contents["per/capsized"] = np.ones_like(contents["per/capsized"])
    _write_checkpoint(tmp_path, contents, digest=digest)
    with pytest.raises(ValueError, match=message + r".*Delete .* or pass another checkpoint directory"):
        _amplitudes(problem, checkpoint=tmp_path)


def test_edited_streaming_checkpoints_are_refused(problem, tmp_path):
    """The maxima and largest-roll observers check their checkpoints too (counts against maxima, n_exceeded against
    the trials)."""
    kw = dict(num_realizations=4, duration=DURATION, chunk_size=2, checkpoint_every=1)
    maxima = jaxroll.monte_carlo_maxima(
        problem, jax.random.key(1), n0=(2, 4), discard=0.0, checkpoint=tmp_path / "mx", **kw
    )
    roll = monte_carlo_max_roll(problem, jax.random.key(1), angle_deg=3.0, checkpoint=tmp_path / "mr", **kw)
    again = jaxroll.monte_carlo_maxima(
        problem, jax.random.key(1), n0=(2, 4), discard=0.0, checkpoint=tmp_path / "mx", **kw
    )  # an unedited checkpoint is accepted
    np.testing.assert_array_equal(again.maxima_deg, maxima.maxima_deg)
    contents = _read_checkpoint(tmp_path / "mx")
    contents["per/maxima"] = contents["per/maxima"].copy()
    contents["per/maxima"][0, 1] = contents["per/maxima"][0, 0] / 2  # N0 = 4's maximum below N0 = 2's
    _write_checkpoint(tmp_path / "mx", contents)
    with pytest.raises(ValueError, match=r"is inconsistent \(.*maximum of more amplitudes is below"):
        jaxroll.monte_carlo_maxima(
            problem, jax.random.key(1), n0=(2, 4), discard=0.0, checkpoint=tmp_path / "mx", **kw
        )
    contents = _read_checkpoint(tmp_path / "mr")
    contents["summed/n_exceeded"] = contents["summed/n_exceeded"] + 1
    _write_checkpoint(tmp_path / "mr", contents)
    with pytest.raises(
        ValueError,
        match=rf"is inconsistent \(n_exceeded = {roll.n_exceeded + 1}, but "
        rf"{roll.n_exceeded} trials exceeded the angle",
    ):
        monte_carlo_max_roll(problem, jax.random.key(1), angle_deg=3.0, checkpoint=tmp_path / "mr", **kw)


def test_pdf_cli_checkpoint(tmp_path, capsys):
    argv = [
        "pdf",
        "--realizations",
        "5",
        "--duration",
        "300",
        "--chunk-size",
        "2",
        "--seed",
        "5",
        "--quiet",
        "--theory",
        "none",
        "--checkpoint",
        str(tmp_path / "ck"),
    ]
    assert main([*argv, "--out", str(tmp_path / "a")]) == 0
    assert (tmp_path / "ck" / CHECKPOINT_FILE).is_file()
    assert main([*argv, "--out", str(tmp_path / "b")]) == 0
    a, b = (json.loads((tmp_path / d / "pdf.json").read_text()) for d in "ab")
    for key in ("pdf_zero_crossing", "pdf_envelope", "mean_amplitude_deg", "n_capsized", "roll_moments"):
        assert a[key] == b[key]
    assert (
        main([*argv[:-2], "--seed", "6", "--checkpoint", str(tmp_path / "ck"), "--out", str(tmp_path)]) == 2
    )
    assert "belongs to a different run" in capsys.readouterr().err


def test_every_cpu_core_is_a_device_unless_the_user_chose():
    code = "import os, jax, jaxroll; jaxroll.configure(); print(jax.device_count(), len(os.sched_getaffinity(0)))"
    env = {k: v for k, v in os.environ.items() if k not in ("JAX_NUM_CPU_DEVICES", "XLA_FLAGS")}
    env["JAX_PLATFORMS"] = "cpu"
    devices, cores = map(
        int,
        subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
        ).stdout.split(),
    )
    assert devices == cores
    env["JAX_NUM_CPU_DEVICES"] = "1"
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    ).stdout
    assert out.split()[0] == "1"


def test_small_loops_compile_as_one_function():
    # jaxroll.configure()'s XLA_FLAGS (tests/conftest.py, before JAX started here): a loop over a 32 kB carry —
    # over XLA's default 1 kB, under jaxroll's 4 MB — is compiled as one function (a "small call"), not kernel by
    # kernel (the user's own flags are kept: tests/test_configure.py)
    def loop(x):
        return jax.lax.fori_loop(0, 10, lambda i, x: jnp.sin(x) * 1.01, x)

    x = jnp.ones(4096)
    assert "xla_cpu_small_call" in jax.jit(loop).lower(x).compile().as_text()
    want = np.ones(4096)
    for _ in range(10):
        want = np.sin(want) * 1.01
    np.testing.assert_allclose(np.asarray(jax.jit(loop)(x)), want, rtol=1e-14)  # and computed right


def test_devices_argument():
    assert realization_mesh().devices.size == jax.device_count()
    assert realization_mesh(1).devices.size == 1
    n = jax.device_count()
    with pytest.raises(
        ValueError, match=f"`devices` = {n + 1} must be between 1 and the number of devices, {n}"
    ):
        realization_mesh(n + 1)
    with pytest.raises(ValueError, match="distinct devices from jax.devices"):
        realization_mesh([])


# ----------------------------------------------------------------------------------------------------------
# Sweep
# ----------------------------------------------------------------------------------------------------------


def test_wilson_interval_matches_scipy():
    stats = pytest.importorskip("scipy.stats")
    for k, n in ((0, 10), (3, 10), (10, 10), (17, 200)):
        ci = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
        lo, hi = wilson_interval(k, n)
        np.testing.assert_allclose([lo, hi], [ci.low, ci.high], rtol=1e-12, atol=1e-15)
    with pytest.raises(ValueError, match="`confidence` must be in"):
        wilson_interval(1, 2, confidence=1.0)


def test_max_roll_exceedance(problem):
    stats = monte_carlo_max_roll(
        problem, jax.random.key(1), angle_deg=15.0, num_realizations=5, duration=DURATION, chunk_size=4
    )
    assert stats.n_realizations == 5 and stats.max_abs_phi_deg.shape == (5,)
    assert stats.exceedances(15.0) == stats.n_exceeded  # host recount = on-device count
    assert stats.exceedances(1.0) == 5 and stats.exceedances(89.0) == stats.n_capsized
    lo, hi = stats.exceedance_interval()
    assert lo <= stats.exceedance_probability() <= hi
    with pytest.raises(ValueError, match="`angle_deg` must be in"):
        monte_carlo_max_roll(problem, jax.random.key(1), angle_deg=80.0)


def test_sweep_cli_writes_map_and_json(tmp_path, capsys):
    out = tmp_path / "sweep"
    argv = [
        "sweep",
        "--hs",
        "7,5",
        "--t01",
        "10,12",
        "--realizations",
        "5",
        "--duration",
        "300",
        "--angle",
        "15",
        "--chunk-size",
        "4",
        "--seed",
        "1",
        "--quiet",
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    assert (out / "sweep.png").stat().st_size > 0
    d = json.loads((out / "sweep.json").read_text())
    assert d["jaxroll_version"] == jaxroll.__version__
    assert d["grid"] == {
        "axes": ["heading", "speed_m_s", "hs_m", "t01_s"],
        "heading": ["head"],
        "speed_m_s": [0.0],
        "hs_m": [5.0, 7.0],
        "t01_s": [10.0, 12.0],
    }
    assert d["config"]["angle_deg"] == 15.0 and d["config"]["realizations"] == 5
    assert "representative" in d["config"]["ship_note"]
    for name in ("capsize", "exceedance"):
        p = np.array(d[f"{name}_probability"])
        ci = np.array(d[f"{name}_ci"])
        assert p.shape == (1, 1, 2, 2) and ci.shape == (1, 1, 2, 2, 2)
        assert np.all((ci[..., 0] <= p) & (p <= ci[..., 1]))
    counts = np.array(d["n_exceeded"])
    np.testing.assert_array_equal(np.array(d["exceedance_probability"]), counts / 5)
    assert np.all(counts >= np.array(d["n_capsized"]))
    assert len(d["points"]) == 4 and d["points"][0]["hs_m"] == 5.0
    assert_labelled_output(out, "sweep")
    # The 7 m, T01 = 10 s point equals the stand-alone Monte Carlo with the same seed (common random numbers).
    problem = jaxroll.RollProblem.from_sea(jaxroll.c11_representative(), jaxroll.ITTC(7.0, 10.0))
    stats = monte_carlo_max_roll(
        problem, jax.random.key(1), angle_deg=15.0, num_realizations=5, duration=300.0, chunk_size=4
    )
    assert counts[0, 0, 1, 0] == stats.n_exceeded
    # The closing line names the worst point, or says there was no capsize / exceedance anywhere (with the bound).
    printed = capsys.readouterr().out
    if np.sum(d["n_capsized"]) == 0:
        bound = d["points"][0]["capsize_ci"][1]
        assert f"no capsize at any of the 4 points (P(capsize) < {bound:.3g} at each, 95 %)" in printed
    if counts.max():
        assert f"largest P(max |φ| > 15°) {counts.max() / 5:.3f}" in printed


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--hs", "5,x"], "--hs must be a comma-separated list of numbers"),
        (["--t01", "0"], "--t01 values must be finite and > 0"),
        (["--speed", "-1"], "--speed values must be finite and >= 0"),
        (["--heading", "bow"], "--heading must be head, following, beam or a list such as head,following"),
        (["--angle", "80"], "--angle must be below the angle of vanishing stability"),
        (["--devices", "999"], "--devices must be between 1 and "),
        (["--discard", "400"], r"--discard must be in \[0, --duration\)"),
        (["--dt", "5"], "dt = 5.0 s is too large"),
        (["--chunk-size", "0"], "--chunk-size must be >= 1; got 0"),
    ],
)
def test_sweep_cli_errors(extra, message, tmp_path, capsys):
    import re

    assert main(["sweep", "--duration", "300", "--out", str(tmp_path), *extra]) == 2
    assert re.search(message, capsys.readouterr().err)


def test_chunk_size_from_memory_budget():
    """Issue 13: the chunk is cut to a memory budget so a small dt cannot exhaust memory (`--dt 0.01` asked 30 GB)."""
    from jaxroll.roll._sharding import (
        BYTES_PER_REALIZATION_STEP,
        chunk_size_for_memory,
        default_memory_budget,
    )

    steps = int(1800 / 0.01)
    budget = 2 * 2**30
    chunk = chunk_size_for_memory(1000, steps, budget)
    assert 1 <= chunk < 1000 and chunk * steps * BYTES_PER_REALIZATION_STEP <= budget
    assert chunk_size_for_memory(1000, 100, 2**40) == 1000  # never above the asked chunk
    assert chunk_size_for_memory(1000, 10**9, 1.0) == 1  # always at least one realization
    # a cut chunk keeps its shape while the budget moves a little (free memory varies between calls; on a GPU
    # each new shape cost a 6-7 s compilation): three significant binary digits, within 25 % of what fits
    per = 526_336  # the histogram observer at 7200 steps
    cuts = {chunk_size_for_memory(100_000, 7200, b, per) for b in np.linspace(31.9e9, 33.9e9, 50)}
    assert cuts == {57_344}
    for budget_b in (1e8, 3.3e9, 4.7e10):
        fit = int(budget_b // per)
        assert 0.75 * fit < chunk_size_for_memory(10**6, 7200, budget_b, per) <= fit
    assert default_memory_budget() > 0
    with pytest.raises(ValueError, match="memory_budget"):
        chunk_size_for_memory(10, 10, 0.0)
    # Observers state their own peak bytes per realization: the streaming ones (maxima, max roll) do not keep
    # the series, so a long run is not cut to tiny chunks (measured: 0.74 B/step at 72 000 steps).
    from jaxroll.roll._observers import AmplitudeHistogram, FirstMaxima, MaxRoll

    steps = 72_000
    hist = AmplitudeHistogram().bytes_per_realization(steps)
    assert hist == steps * BYTES_PER_REALIZATION_STEP + 65_536
    for streaming in (FirstMaxima(), MaxRoll()):
        assert streaming.bytes_per_realization(steps) < hist / 20
    assert chunk_size_for_memory(1000, steps, 2**30, MaxRoll().bytes_per_realization(steps)) == 1000
    assert chunk_size_for_memory(1000, steps, 2**30, hist) == 224  # 229 fit, rounded down to 3 binary digits


class _FakeAccelerator:
    """A GPU as `default_chunk_size` and `default_memory_budget` see it: a platform and memory statistics [bytes]."""

    platform = "gpu"

    def __init__(self, limit, in_use):
        self.stats = None if limit is None else {"bytes_limit": limit, "bytes_in_use": in_use}

    def memory_stats(self):
        return self.stats


def test_chunks_are_sized_for_the_devices(monkeypatch):
    """Issue 15: on GPUs a chunk is wide enough to fill every device (1e5 realizations per device with the
    histogram observer, 2.5e5 streaming) and is cut to 0.9 of the smallest free device memory × the device count,
    not to the host's memory; on a CPU the default is 500 per core (device) for both and a quarter of the host's memory."""
    import types

    from jaxroll import default_chunk_size, default_memory_budget
    from jaxroll.roll import _sharding
    from jaxroll.roll._observers import AmplitudeHistogram, FirstMaxima, MaxRoll
    from jaxroll.roll._sharding import chunk_size_for_memory

    assert jax.devices()[0].platform == "cpu"
    cores = len(jax.devices())  # each CPU core a device
    assert default_chunk_size(AmplitudeHistogram.keeps_history) == 500 * cores
    assert (
        default_chunk_size(FirstMaxima.keeps_history)
        == default_chunk_size(MaxRoll.keeps_history)
        == 500 * cores
    )
    assert default_chunk_size(True, devices=1) == 500
    # and the command line's --chunk-size help says so
    from jaxroll._cli import build_parser

    commands = build_parser()._subparsers._group_actions[0].choices
    for name, observer in (("pdf", AmplitudeHistogram), ("maxima", FirstMaxima), ("risk", MaxRoll)):
        option = next(a for a in commands[name]._actions if "--chunk-size" in a.option_strings)
        per_core = default_chunk_size(observer.keeps_history) // len(jax.devices())
        assert f"default: {per_core} per CPU core" in option.help
    host = default_memory_budget()
    assert 0 < host < 2**50

    gpus = [_FakeAccelerator(80e9, 20e9), _FakeAccelerator(80e9, 10e9)]  # free 60 and 70 GB (H100s' pools)
    mesh = types.SimpleNamespace(devices=np.array(gpus, dtype=object))
    monkeypatch.setattr(_sharding, "realization_mesh", lambda devices=None: mesh)
    assert default_chunk_size(True) == 2 * 100_000 and default_chunk_size(False) == 2 * 250_000
    budget = default_memory_budget()
    assert budget == 0.9 * 60e9 * 2  # the fuller device bounds both shares
    assert default_memory_budget(0.5) == 0.5 * 60e9 * 2
    # the paper protocol (7200 steps) fits whole; at dt = 0.05 s (72 000 steps) the histogram chunk is cut
    hist = AmplitudeHistogram()
    assert (
        chunk_size_for_memory(default_chunk_size(True), 7200, None, hist.bytes_per_realization(7200))
        == 200_000
    )
    cut = chunk_size_for_memory(default_chunk_size(True), 72_000, None, hist.bytes_per_realization(72_000))
    assert cut == 20_480  # 23 108 fit, rounded down to three significant binary digits
    # a device that reports no memory statistics: the host's memory, as on a CPU
    mesh.devices = np.array([_FakeAccelerator(None, None)] * 2, dtype=object)
    assert default_memory_budget() == pytest.approx(host, rel=0.2)
