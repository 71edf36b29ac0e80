"""Every notebook in notebooks/ that no other test file covers runs top to bottom in smoke mode."""

import pytest
from helpers import NOTEBOOKS, run_notebook

OWN = ["01_monte_carlo_pdf.ipynb", "02_theory_vs_monte_carlo.ipynb", "03_maximum_amplitude.ipynb"]


def test_every_notebook_is_run_by_a_test():
    tested = {
        *OWN,
        "04_calibration.ipynb",
        "05_hydrostatics.ipynb",
        "06_vulnerability.ipynb",
        "07_longterm.ipynb",
        "08_yaw.ipynb",
    }  # 04-08 run by test_calibration, test_hydrostatics, test_sgisc, test_longterm, test_yaw
    assert {p.name for p in NOTEBOOKS.glob("*.ipynb")} == tested


@pytest.mark.parametrize("name", OWN)
def test_notebook_runs_in_smoke_mode(name, tmp_path, monkeypatch):
    run_notebook(name, tmp_path, monkeypatch)
