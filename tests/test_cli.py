"""The command line: `jaxroll pdf` and `jaxroll ship show`, outputs and error messages."""

import json

import numpy as np
import pytest

import jaxroll
from jaxroll._cli import main


def test_help_lists_subcommands(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    for cmd in ("pdf", "ship"):
        assert cmd in out


def test_pdf_writes_figures_and_json(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["pdf", "--realizations", "6", "--duration", "600", "--out", str(out), "--seed", "3", "--quiet"])
    assert code == 0
    for name in ("pdf_linear.png", "pdf_log.png", "pdf.json"):
        assert (out / name).stat().st_size > 0
    d = json.loads((out / "pdf.json").read_text())
    assert d["jaxroll_version"] == jaxroll.__version__
    assert d["config"]["ship"]["name"] == "C11 (representative)" and "representative" in d["config"]["ship_note"]
    assert d["config"]["sea"] == {"spectrum": "ITTC", "hs_m": 7.0, "t01_s": 10.0}
    edges = np.array(d["bins_deg"])
    for method in ("zero_crossing", "envelope"):
        pdf = np.array(d[f"pdf_{method}"])
        np.testing.assert_allclose(np.sum(pdf * np.diff(edges)), 1.0, rtol=1e-12, atol=0)
        assert d["n_amplitudes"][method] > 0
        q = d["quantiles_deg"][method]
        assert 0 < q["50"] <= q["90"] <= q["99"] < 90
        assert d["mean_amplitude_deg"][method] > 0
    assert d["n_realizations"] == 6 and d["n_capsized"] + 0 == d["capsize_probability"] * 6
    assert d["filter_fit"]["order"] == 4
    assert "C11 (representative)" in capsys.readouterr().out
    # Same seed → same result.
    main(["pdf", "--realizations", "6", "--duration", "600", "--out", str(tmp_path / "again"), "--seed", "3",
          "--quiet", "--chunk-size", "4"])
    d2 = json.loads((tmp_path / "again" / "pdf.json").read_text())
    assert d2["pdf_envelope"] == d["pdf_envelope"]


def test_pdf_with_ship_file_and_superposition(tmp_path):
    ship = tmp_path / "ship.toml"
    text = jaxroll.ship_to_toml(jaxroll.c11_representative()).replace("gm_ratio = 1.0", "gm_ratio = 0.8")
    ship.write_text(text)
    code = main(["pdf", "--ship", str(ship), "--method", "superposition", "--realizations", "4", "--duration",
                 "600", "--hs", "5", "--out", str(tmp_path), "--quiet"])
    assert code == 0
    d = json.loads((tmp_path / "pdf.json").read_text())
    assert d["config"]["ship"]["correction"]["gm_ratio"] == 0.8 and "ship_note" not in d["config"]
    assert d["config"]["method"] == "superposition" and "filter_fit" not in d


@pytest.mark.parametrize(
    "argv, message",
    [
        (["pdf", "--hs", "-1"], "--hs must be a finite number > 0"),
        (["pdf", "--dt", "5"], "dt = 5.0 s is too large"),
        (["pdf", "--realizations", "0"], "--realizations must be >= 1"),
        (["pdf", "--speed", "-2"], "--speed must be >= 0"),
        (["pdf", "--filter-order", "2"], "--filter-order must be >= 3"),
        (["pdf", "--bin-width-deg", "0.33"], "--bin-width-deg must be a multiple of 0.05"),
        (["pdf", "--theory", "magic"], r"--theory: unknown method\(s\) \['magic'\]"),
        (["pdf", "--ship", "/nonexistent/ship.toml"], "does not exist"),
        (["pdf", "--duration", "0"], "--duration must be a finite number > 0"),
        (["ship", "show", "--ship", "/nonexistent.toml"], "does not exist"),
    ],
)
def test_cli_errors(argv, message, capsys, tmp_path):
    assert main([*argv, *(["--out", str(tmp_path)] if argv[0] == "pdf" else [])]) == 2
    err = capsys.readouterr().err
    assert "error:" in err
    import re

    assert re.search(message, err), err
    assert not (tmp_path / "pdf.json").exists()  # nothing half-written


def test_ship_show(capsys, tmp_path):
    assert main(["ship", "show"]) == 0
    out = capsys.readouterr().out
    assert 'name = "C11 (representative)"' in out and "vanishing_angle_deg = 71.598" in out
    assert main(["ship", "show", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["damping"]["b2"] == 0.5 and abs(d["derived"]["gz_max_m"] - 1.14) < 0.01
    # What `ship show` prints is a valid ship file.
    path = tmp_path / "s.toml"
    main(["ship", "show"])
    path.write_text(capsys.readouterr().out)
    assert jaxroll.load_ship(path).name == "C11 (representative)"


def test_maxima_command(tmp_path):
    code = main(["maxima", "--n0", "10,30", "--realizations", "6", "--out", str(tmp_path), "--quiet",
                 "--chunk-size", "6"])
    assert code == 0
    d = json.loads((tmp_path / "maxima.json").read_text())
    assert set(d["per_n0"]) == {"10", "30"}
    for k, v in d["per_n0"].items():
        assert v["n_valid"] + v["n_capsized_before"] + v["n_incomplete"] == 6
        assert 0 < v["quantiles_deg"]["50"] <= v["quantiles_deg"]["99"]
        exact = np.array(v["curves"]["mcs_amplitudes"]["exact"])
        np.testing.assert_allclose(np.trapezoid(exact, d["grid_deg"]), 1.0, atol=0.02)  # P* is a density
    # The maximum over 30 amplitudes is never below the maximum over the first 10 (same trials).
    assert d["per_n0"]["30"]["mean_deg"] >= d["per_n0"]["10"]["mean_deg"]
    for name in ("maxima_linear.png", "maxima_log.png", "maxima_N0_10.png", "maxima_N0_30.png"):
        assert (tmp_path / name).stat().st_size > 0


def test_risk_command(tmp_path, capsys):
    code = main(["risk", "--angle", "20", "--hours", "3", "--realizations", "8", "--duration", "1200",
                 "--out", str(tmp_path), "--quiet"])
    assert code == 0
    d = json.loads((tmp_path / "risk.json").read_text())
    m = d["monte_carlo"]
    assert 0 <= m["probability_ci95"][0] <= m["probability"] <= m["probability_ci95"][1] <= 1
    assert m["n_amplitudes"] > 0 and m["rate_per_s"] > 0
    direct = d["direct"]
    assert direct["n_realizations"] == 8
    assert 0 <= direct["probability_ci95"][0] <= direct["probability"] <= direct["probability_ci95"][1] <= 1
    assert direct["largest_roll_quantiles_deg"]["50"] <= direct["largest_roll_quantiles_deg"]["99"]
    assert "P(roll > 20° within 3 h)" in capsys.readouterr().out
    assert main(["risk", "--angle", "95", "--out", str(tmp_path)]) == 2
    assert "--angle must be in (0, 90)" in capsys.readouterr().err


def test_theory_command(tmp_path, capsys):
    code = main(["theory", "--theory", "roberts,esam", "--hs", "5", "--out", str(tmp_path)])
    assert code == 0
    d = json.loads((tmp_path / "theory.json").read_text())
    edges = np.array(d["bins_deg"])
    for name in ("roberts", "esam"):
        t = d["theory"][name]
        assert t["estimator"] == "envelope"
        np.testing.assert_allclose(np.sum(np.array(t["pdf"]) * np.diff(edges)), 1.0, atol=1e-3)
        assert 0 < t["quantiles_deg"]["50"] < t["quantiles_deg"]["99"]
    assert (tmp_path / "theory_log.png").stat().st_size > 0
