"""A short fuzz of the command line (issue 13): any mix of options and ship-file fields either exits 2 with a
message, or writes JSON without NaN and without invented numbers. Bounded: few examples, tiny runs."""

import json
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings, strategies as st

import jaxroll
from jaxroll._cli import main

# hypothesis draws the option mixes; derandomized (reproducible in CI) and bounded to a few tiny runs each.
MAX_EXAMPLES = 8
FUZZ = settings(
    max_examples=MAX_EXAMPLES,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


NUMBERS = ["nan", "inf", "-1", "0"]


def _check_outcome(code, err, path):
    if code == 2:
        assert "error:" in err and "Traceback" not in err, err
        assert not path.exists()
        return None
    assert code == 0, err
    text = path.read_text()
    assert "NaN" not in text and "Infinity" not in text
    return json.loads(text)


def _check_amplitudes(d):
    edges = np.asarray(d["bins_deg"], float)
    for est in ("zero_crossing", "envelope"):
        if d["n_amplitudes"][est] == 0:  # nothing measured: nothing reported, and a reason
            assert d[f"pdf_{est}"] is None and d["quantiles_deg"][est] is None
            assert d["mean_amplitude_deg"][est] is None and d["reason"]
            continue
        pdf = np.asarray(d[f"pdf_{est}"], float)
        assert np.all(pdf >= 0)
        assert np.sum(pdf * np.diff(edges)) == pytest.approx(1 - d["mass_beyond_grid"][est], abs=1e-9)
        q = d["quantiles_deg"][est]
        assert 0 <= q["50"] <= q["90"] <= q["99"] <= 90
        assert 0 <= d["mean_amplitude_deg"][est] <= 90
    assert d["n_capsized"] + d["n_survivors"] == d["n_realizations"]


def _ship_file(tmp_path, b1, gm_ratio, a3_scale):
    ship = jaxroll.c11_representative()
    text = jaxroll.ship_to_toml(ship)
    lines = []
    for line in text.splitlines():
        key = line.split("=")[0].strip()
        if key == "b1" and b1 is not None:
            line = f"b1 = {b1}"
        elif key == "gm_ratio" and gm_ratio is not None:
            line = f"gm_ratio = {gm_ratio}"
        elif key == "a3" and a3_scale is not None:
            line = f"a3 = {float(line.split('=')[1]) * a3_scale!r}"
        lines.append(line)
    path = tmp_path / "ship.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


@FUZZ
@pytest.mark.filterwarnings("ignore:dt = .* may bias:UserWarning")
# runs that pass every check, so that the outputs themselves are checked
@example(hs="7", duration="600", discard="100", phi0="5", dt="0.5", bin_width="1", ship=None)
@example(hs="12", duration="600", discard="0", phi0="-3", dt="0.5", bin_width="2", ship=(0.0, 0.8, 3.0))
@given(
    hs=st.sampled_from(["3", "7", "12", *NUMBERS]),
    duration=st.sampled_from(["600", "20", *NUMBERS]),
    discard=st.sampled_from(["0", "100", "590", "700", "nan", "-5"]),
    phi0=st.sampled_from(["5", "-3", "0", "80", "nan"]),
    dt=st.sampled_from(["0.5", "5", "nan"]),
    bin_width=st.sampled_from(["1", "2", "0.33", "nan"]),
    ship=st.sampled_from(
        [
            None,
            (0.0, 0.8, None),
            (-0.01, None, None),
            ("nan", None, None),
            (None, 0.0, None),
            (None, "-1", None),
            (None, None, 3.0),
        ]
    ),
)
def test_fuzz_pdf(tmp_path_factory, capsys, hs, duration, discard, phi0, dt, bin_width, ship):
    tmp = tmp_path_factory.mktemp("pdf")
    argv = [
        "pdf",
        "--realizations",
        "3",
        "--chunk-size",
        "3",
        "--quiet",
        "--theory",
        "none",
        "--out",
        str(tmp / "out"),
        "--hs",
        hs,
        "--duration",
        duration,
        "--discard",
        discard,
        "--phi0-deg",
        phi0,
        "--dt",
        dt,
        "--bin-width-deg",
        bin_width,
    ]
    if ship is not None:
        argv += ["--ship", str(_ship_file(tmp, *ship))]
    code = main(argv)
    err = capsys.readouterr().err
    d = _check_outcome(code, err, tmp / "out" / "pdf.json")
    if d is not None:
        assert math.isfinite(float(hs)) and float(hs) > 0 and float(phi0) != 0
        _check_amplitudes(d)


@FUZZ
@pytest.mark.filterwarnings("ignore:dt = .* may bias:UserWarning")
@given(
    hs=st.sampled_from(["3", "7", *NUMBERS]),
    t01=st.sampled_from(["10", "8", *NUMBERS]),
    speed=st.sampled_from(["0", "3", "-2", "nan"]),
    theory=st.sampled_from(["roberts", "esam", "roberts,esam", "", "magic"]),
    bin_width=st.sampled_from(["1", "0.5", "0.07"]),
)
def test_fuzz_theory(tmp_path_factory, capsys, hs, t01, speed, theory, bin_width):
    tmp = tmp_path_factory.mktemp("theory")
    code = main(
        [
            "theory",
            "--out",
            str(tmp / "out"),
            "--hs",
            hs,
            "--t01",
            t01,
            "--speed",
            speed,
            "--theory",
            theory,
            "--bin-width-deg",
            bin_width,
        ]
    )
    err = capsys.readouterr().err
    d = _check_outcome(code, err, tmp / "out" / "theory.json")
    if d is not None:
        edges = np.asarray(d["bins_deg"], float)
        for t in d["theory"].values():
            pdf = np.asarray(t["pdf"], float)
            assert np.all(pdf >= 0)
            assert np.sum(pdf * np.diff(edges)) == pytest.approx(1 - t["mass_beyond_grid"], abs=2e-3)
            q = t["quantiles_deg"]
            assert 0 < q["50"] <= q["90"] <= q["99"] <= 90
