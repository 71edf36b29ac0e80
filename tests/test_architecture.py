"""The package's shape (docs/architecture.md): imports run downward, no module is oversized, the CLI and the
notebooks use public names only."""

import ast
import json
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PKG = ROOT / "jaxroll"
CORE = ("sea", "ship", "laws", "roll", "theory", "extremes", "calibration", "io", "criteria", "longterm")
# what each stage may import (module level and inside functions)
ALLOWED = {
    "sea": {"sea"},
    "laws": {"laws"},
    "ship": {"ship", "sea", "io"},  # io only inside functions (packaged hull file)
    "io": {"io", "ship"},
    "roll": {"roll", "sea", "ship", "laws", "extremes"},
    "theory": {"theory", "sea", "ship", "laws"},
    "extremes": {"extremes", "laws"},
    "calibration": {"calibration", "sea", "ship", "roll", "theory", "laws", "io", "extremes"},
    "criteria": {"criteria", "sea", "ship", "roll", "theory", "laws", "io"},
    "longterm": {"longterm", "sea", "ship", "roll", "theory", "laws", "io", "extremes"},
}


def _imports(path: pathlib.Path):
    tree = ast.parse(path.read_text())
    pkg_parts = path.relative_to(ROOT).with_suffix("").parts[:-1]
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg_parts[: len(pkg_parts) - node.level + 1]
                target = (*base, *(node.module.split(".") if node.module else ()))
                if not node.module:
                    for alias in node.names:
                        yield (*target, alias.name)
                    continue
                yield target
            elif node.module:
                yield tuple(node.module.split("."))
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield tuple(alias.name.split("."))


@pytest.mark.parametrize("stage", CORE)
def test_imports_run_downward(stage):
    for path in (PKG / stage).glob("*.py"):
        for target in _imports(path):
            if target[0] == "matplotlib":
                pytest.fail(f"{path.relative_to(ROOT)} imports matplotlib")
            if target[0] != "jaxroll" or len(target) < 2:
                continue
            if target[1] in (
                "__version__",
                "_atomic",
                "_cache_files",
                "_compiled",
                "_display",
                "_labels",
                "_config",
            ):  # infrastructure every stage may use (no numerics)
                continue
            assert target[1] in ALLOWED[stage], f"{path.relative_to(ROOT)} imports jaxroll.{target[1]}"


def test_no_module_is_oversized():
    big = [
        (p.relative_to(ROOT), n) for p in PKG.rglob("*.py") if (n := len(p.read_text().splitlines())) > 800
    ]
    assert not big, big


def test_cli_and_notebooks_use_public_names():
    offenders = []
    for path in (PKG / "_cli").glob("*.py"):
        for target in _imports(path):
            if target[0] != "jaxroll" or len(target) < 2 or target[1] == "_cli":
                continue
            private = [part for part in target[1:3] if part.startswith("_") and not part.startswith("__")]
            if (
                private
            ):  # a private module of jaxroll (`jaxroll._compiled`) or of a stage (`jaxroll.theory._named`)
                offenders.append((path.name, ".".join(target)))
    for nb in (ROOT / "notebooks").glob("*.ipynb"):
        for cell in json.loads(nb.read_text())["cells"]:
            src = "".join(cell["source"])
            if "jaxroll." in src and any(
                f"jaxroll.{s}._" in src or "from jaxroll._" in src for s in CORE + ("plotting",)
            ):
                offenders.append((nb.name, "private import"))
    assert not offenders, offenders


def test_notebooks_configure_jaxroll_first():
    """`import jaxroll` changes no JAX setting: every notebook opts in (`configure()`) in its first code cell, before
    any computation, as users are told to (README, docs/architecture.md)."""
    for nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        first = next(c for c in json.loads(nb.read_text())["cells"] if c["cell_type"] == "code")
        assert ".configure()" in "".join(first["source"]), nb.name
