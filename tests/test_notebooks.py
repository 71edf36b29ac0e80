"""Every notebook in notebooks/ that no other test file covers runs top to bottom in smoke mode."""

import os
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"
OWN = ["01_monte_carlo_pdf.ipynb", "02_theory_vs_monte_carlo.ipynb", "03_maximum_amplitude.ipynb"]


@pytest.mark.parametrize("name", OWN)
def test_notebook_runs_in_smoke_mode(name, tmp_path, monkeypatch):
    path = NOTEBOOKS / name
    if not path.exists():
        pytest.fail(f"{name} is missing")
    nb = nbformat.read(path, as_version=4)
    assert all(not c.get("outputs") for c in nb.cells if c.cell_type == "code"), "store notebooks without outputs"
    monkeypatch.setenv("JAXROLL_SMOKE", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(tmp_path)
    NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    assert os.environ["JAXROLL_SMOKE"] == "1"
