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
    "ship": {"ship", "sea"},  # the model reads no file: io/ reads and writes hull files
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
            if target[1] in INFRASTRUCTURE:  # infrastructure every stage may use (no numerics)
                continue
            # `from .. import __version__` (the package root) is refused too: `jaxroll._version` has it
            assert target[1] in ALLOWED[stage], f"{path.relative_to(ROOT)} imports jaxroll.{target[1]}"


#: Modules every stage may import: no numerics, and they import no stage and not the package root.
INFRASTRUCTURE = ("_atomic", "_cache_files", "_compiled", "_config", "_display", "_labels", "_version")


def test_infrastructure_imports_no_stage():
    """`_labels` (the labelled results), `_compiled`, `_version`, … import no stage (`io` included: the netCDF
    writer imports `_labels`, not the other way round) and not the package root."""
    for name in INFRASTRUCTURE:
        paths = sorted((PKG / name).glob("*.py")) if (PKG / name).is_dir() else [PKG / f"{name}.py"]
        for path in paths:
            for target in _imports(path):
                if target[0] == "jaxroll" and len(target) >= 2:
                    assert target[1] in INFRASTRUCTURE, (
                        f"{path.relative_to(ROOT)} imports jaxroll.{target[1]}"
                    )


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


def test_lazy_names_are_the_typed_imports():
    """`import jaxroll` imports its names on first use (`jaxroll._NAMES`); the `if TYPE_CHECKING:` block of
    jaxroll/__init__.py writes the same imports out for type checkers and the documentation. Both list the same
    names from the same modules, and every name resolves to the object its module defines."""
    import importlib

    import jaxroll

    tree = ast.parse((PKG / "__init__.py").read_text())
    block = next(
        n for n in tree.body if isinstance(n, ast.If) and ast.unparse(n.test).endswith("TYPE_CHECKING")
    )
    typed, modules = {}, set()
    for node in block.body:
        for alias in node.names:
            assert alias.asname == alias.name, f"re-export {alias.name} as itself"
            if node.module is None:  # `from . import theory as theory`: a subpackage
                modules.add(alias.name)
            else:
                typed[alias.name] = node.module
    assert typed == jaxroll._LAZY
    assert modules <= set(jaxroll._SUBPACKAGES)
    for name, module in jaxroll._LAZY.items():
        assert getattr(jaxroll, name) is getattr(importlib.import_module(f"jaxroll.{module}"), name), name
    for name in set(jaxroll._SUBPACKAGES) - {"longterm"}:  # `jaxroll.longterm` is the function
        assert getattr(jaxroll, name) is importlib.import_module(f"jaxroll.{name}"), name
    assert set(jaxroll._LAZY) | set(jaxroll._SUBPACKAGES) <= set(dir(jaxroll))
    with pytest.raises(AttributeError, match="has no attribute 'no_such_name'"):
        jaxroll.no_such_name  # noqa: B018


def test_the_package_namespace_is_its_public_names():
    """`dir(jaxroll)` and `jaxroll.__all__` list jaxroll's names, not the modules its `__init__` uses (`importlib`,
    `sys`, `types`, `TYPE_CHECKING` were listed until 0.2)."""
    import jaxroll

    assert set(jaxroll.__all__) == {
        "configure",
        "single_threaded_blas",
        *jaxroll._LAZY,
        *jaxroll._SUBPACKAGES,
    }
    assert sorted(dir(jaxroll)) == sorted([*jaxroll.__all__, "__version__"])
    public = {n for n in vars(jaxroll) if not n.startswith("_")}
    assert public <= set(jaxroll.__all__), public - set(jaxroll.__all__)
    for name in ("importlib", "sys", "types", "typing", "TYPE_CHECKING", "annotations"):
        assert name not in dir(jaxroll) and not hasattr(jaxroll, name), name


def test_the_hydrostatics_command_imports_only_what_it_uses():
    """`import jaxroll` and the `jaxroll hydrostatics` command's modules leave the Monte Carlo, the theories, the
    calibration, the criteria and the long-term stage unimported, and the libraries only they use (issue 36: the
    command's fixed cost); `jaxroll.longterm` stays the function when its subpackage is imported later."""
    import subprocess
    import sys

    code = """
import sys
import jaxroll
from jaxroll._cli import build_parser
build_parser("hydrostatics")
import jaxroll.io, jaxroll.plotting, jaxroll.ship
stages = ("roll", "theory", "calibration", "criteria", "longterm", "extremes", "laws", "notebook")
print(sorted(m for m in sys.modules if m.split(".")[0] in ("diffrax", "matplotlib", "xarray", "pandas")
             or m.split(".")[:2] in [["jaxroll", s] for s in stages]))
import jaxroll.longterm
print(callable(jaxroll.longterm), jaxroll.longterm is sys.modules["jaxroll.longterm"].longterm)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split("\n")[:2] == ["[]", "True True"]
