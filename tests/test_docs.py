"""The documentation (issue 35, item 4): every public name has a docstring; every link and every reference to a
page or a section of docs/ leads somewhere; the Python examples of README.md and docs/*.md run.

The examples run here as the reader would paste them, with two comment directives, invisible once rendered, placed
on the line before a ```python block:

- `<!-- doctest: skip -->`: the block is not run (keep this rare: say why beside it);
- `<!-- doctest: replace "A" "B" -->` (one or more): with `JAXROLL_SMOKE=1` (the default here, as for the
  notebooks) the text A in the block is replaced by B before it runs, e.g. 10⁴ realizations by 8.

The blocks of one file run in turn in one namespace (a later block may use an earlier one's names), in a fresh
folder that holds the files the examples name (`_workspace`). The set-up every example gets is in one place,
`_namespace`: it calls `jaxroll.configure()` where that exists (the float64 and XLA settings `import jaxroll` made
by itself before).

The site itself is built by `mkdocs build --strict` in .ci/run (mkdocs.yml), which also refuses a broken link or
anchor; the link check here needs no mkdocs and also covers the references written as plain text, in the pages
and in the code's docstrings.
"""

from __future__ import annotations

import gzip
import importlib
import inspect
import os
import re
import shutil
import warnings
from importlib.resources import files
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(p for p in DOCS.glob("*.md") if p.name != "index.md")
MARKDOWN = [ROOT / "README.md", *PAGES, ROOT / "benchmarks" / "README.md"]
PUBLIC_MODULES = ["jaxroll"] + [
    f"jaxroll.{m}"
    for m in "sea ship roll laws theory extremes calibration criteria io plotting notebook".split()
]


# ------------------------------------------------------------------------------------------------------------
# Docstrings
# ------------------------------------------------------------------------------------------------------------


def _inherited_doc(cls, name: str) -> str | None:
    for base in cls.__mro__:
        if name in vars(base):
            value = vars(base)[name]
            doc = inspect.getdoc(value.fget if isinstance(value, property) else value)
            if doc:
                return doc
    return None


def test_every_public_name_has_a_docstring():
    """Every public function and class of the public modules, and every public method and property of those
    classes (or of the base they implement), has a docstring: the API reference is built from them."""
    missing = set()
    for module_name in PUBLIC_MODULES:
        module = importlib.import_module(module_name)
        for name in dir(module):
            obj = getattr(module, name)
            if name.startswith("_") or inspect.ismodule(obj):
                continue
            if not (inspect.isclass(obj) or inspect.isfunction(obj)):
                continue
            if not getattr(obj, "__module__", "").startswith("jaxroll"):
                continue
            own = vars(obj).get("__doc__") if inspect.isclass(obj) else obj.__doc__
            if not (own and own.strip()):
                missing.add(f"{obj.__module__}.{obj.__qualname__}")
            if inspect.isclass(obj):
                for attr, value in vars(obj).items():
                    if attr.startswith("_"):
                        continue
                    if isinstance(value, property | staticmethod | classmethod) or inspect.isfunction(value):
                        if not _inherited_doc(obj, attr):
                            missing.add(f"{obj.__module__}.{obj.__qualname__}.{attr}")
    assert not missing, "public names without a docstring: " + ", ".join(sorted(missing))


# ------------------------------------------------------------------------------------------------------------
# Links and references
# ------------------------------------------------------------------------------------------------------------


def _slug(text: str) -> str:
    from markdown.extensions.toc import slugify

    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link in a heading: its text
    return slugify(re.sub(r"[`*$]", "", text), "-")


def _anchors(page: Path) -> set[str]:
    """The anchors of a page: its headings' ids (as mkdocs makes them) and explicit `<a id="…">`."""
    text = re.sub(r"^```.*?^```", "", page.read_text(encoding="utf-8"), flags=re.M | re.S)
    ids = set(re.findall(r'<a id="([^"]+)"', text))
    seen: dict[str, int] = {}
    for line in text.splitlines():
        if re.match(r"#{1,6} ", line):
            slug = _slug(re.sub(r"^#+\s*", "", line).strip())
            n = seen.get(slug, 0)
            ids.add(slug if n == 0 else f"{slug}_{n}")
            seen[slug] = n + 1
    return ids


def _headings_and_bold(page: Path) -> list[str]:
    text = page.read_text(encoding="utf-8")
    heads = [re.sub(r"^#+\s*", "", ln) for ln in text.splitlines() if re.match(r"#{1,6} ", ln)]
    return heads + re.findall(r"\*\*([^*]+)\*\*", text)


@pytest.mark.parametrize("path", MARKDOWN, ids=lambda p: str(p.relative_to(ROOT)))
def test_markdown_links_lead_somewhere(path):
    """Every relative link of the page names a file that exists and, with `#anchor`, an anchor of that page."""
    text = re.sub(r"^```.*?^```", "", path.read_text(encoding="utf-8"), flags=re.M | re.S)
    broken = []
    for target in re.findall(r"(?<!\\)\]\(([^)\s]+)\)", text):  # not an escaped \](…)
        if re.match(r"[a-z]+:", target):
            continue  # http(s), mailto: checked by no one offline
        file, _, anchor = target.partition("#")
        dest = (path.parent / file).resolve() if file else path
        if not dest.exists():
            broken.append(target)
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            broken.append(target)
    assert not broken, f"{path.relative_to(ROOT)}: links that lead nowhere: {broken}"


def _reference_sources() -> list[Path]:
    return [*MARKDOWN, *sorted((ROOT / "jaxroll").rglob("*.py")), *sorted((ROOT / "benchmarks").glob("*.py"))]


def test_plain_references_to_pages_and_sections_lead_somewhere():
    """`docs/x.md`, `docs/x.md, "Section"` and `docs/x.md §N` written as text (in the pages and in the code) name a
    page that exists and a section it has (a heading, a bold paragraph title or an `<a id>` anchor)."""
    broken = []
    pattern = re.compile(
        r"docs/(?P<page>[A-Za-z_]+\.md)(?:[\]`)]*(?:,\s*|\s+)(?:\(?\"(?P<q>[^\"]{1,80})\"|§\s?(?P<num>\d+)))?"
    )
    for source in _reference_sources():
        text = source.read_text(encoding="utf-8")
        for m in pattern.finditer(text):
            page = DOCS / m.group("page")
            where = f"{source.relative_to(ROOT)}: {m.group(0)!r}"
            if not page.exists():
                broken.append(where)
                continue
            if m.group("q"):
                wanted = re.sub(r"\s+", " ", m.group("q")).lower()
                if not any(wanted in re.sub(r"\s+", " ", h).lower() for h in _headings_and_bold(page)) and (
                    _slug(wanted) not in _anchors(page)
                ):
                    broken.append(where)
            elif m.group("num") and not any(
                re.match(rf"{m.group('num')}\.\s", h) for h in _headings_and_bold(page)
            ):
                broken.append(where)
    assert not broken, "references that lead nowhere:\n" + "\n".join(broken)


# ------------------------------------------------------------------------------------------------------------
# The examples run
# ------------------------------------------------------------------------------------------------------------

_DIRECTIVE = re.compile(r"<!--\s*doctest:\s*(?P<body>.*?)\s*-->")


def python_blocks(path: Path) -> list[tuple[int, str, bool, list[tuple[str, str]]]]:
    """(line, code, skip, replacements) of each ```python block of a Markdown file, with its directives."""
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks = []
    i = 0
    while i < len(lines):
        if lines[i].strip() == "```python":
            start = i
            j = i + 1
            while j < len(lines) and lines[j].strip() != "```":
                j += 1
            skip, replace = False, []
            k = start - 1
            while k >= 0 and _DIRECTIVE.fullmatch(lines[k].strip()):
                body = _DIRECTIVE.fullmatch(lines[k].strip()).group("body")
                if body == "skip":
                    skip = True
                elif body.startswith("replace"):
                    pair = re.findall(r'"((?:[^"\\]|\\.)*)"', body)
                    assert len(pair) == 2, f"{path.name}:{k + 1}: replace takes two quoted strings"
                    replace.append(tuple(p.replace('\\"', '"') for p in pair))
                else:
                    raise AssertionError(f"{path.name}:{k + 1}: unknown doctest directive {body!r}")
                k -= 1
            blocks.append((start + 1, "\n".join(lines[start + 1 : j]), skip, replace))
            i = j
        i += 1
    return blocks


def _workspace(folder: Path) -> None:
    """The files the examples name, in the folder they run in: example records (one file and a folder of them),
    a hull file, a lab's CSV export of a record."""
    import jaxroll

    records = Path(str(files("jaxroll") / "data" / "records"))
    shutil.copy(records / "roll" / "roll_H7_T10_r01.csv.gz", folder)
    shutil.copytree(records / "roll", folder / "runs" / "roll")
    hull = jaxroll.c11_hull()
    from jaxroll.io import hull_to_toml

    (folder / "my_hull.toml").write_text(hull_to_toml(hull))
    text = gzip.decompress((records / "roll" / "roll_H7_T10_r01.csv.gz").read_bytes()).decode()
    rows = [ln.split(",") for ln in text.splitlines() if not ln.startswith("#")][1:]
    lab = ["Time [s];Roll [deg];WP1 [mm];Status"] + [
        ";".join(x.replace(".", ",") for x in r) + ";ok" for r in rows
    ]
    (folder / "run3.csv").write_text("\n".join(lab) + "\n")


def _namespace() -> dict:
    """What every example starts from: jaxroll configured as its own docs tell a user to."""
    import jaxroll

    if hasattr(jaxroll, "configure"):
        jaxroll.configure()
    return {"__name__": "__doc_example__"}


EXAMPLE_FILES = [p for p in [ROOT / "README.md", *PAGES] if python_blocks(p)]


@pytest.mark.parametrize("path", EXAMPLE_FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_python_examples_run(path, tmp_path, monkeypatch):
    import jax
    import matplotlib

    matplotlib.use("Agg")
    smoke = os.environ.get("JAXROLL_SMOKE", "1") == "1"
    monkeypatch.setenv("JAXROLL_SMOKE", "1" if smoke else "0")
    monkeypatch.chdir(tmp_path)
    _workspace(tmp_path)
    settings = {
        s: getattr(jax.config, s)
        for s in ("jax_compilation_cache_dir", "jax_persistent_cache_min_compile_time_secs")
    }
    namespace = _namespace()
    try:
        # what a user's session has: standard dtype promotion (the tests run strict), warnings shown, not raised
        with jax.numpy_dtype_promotion("standard"), warnings.catch_warnings(record=True):
            warnings.simplefilter("always")
            for line, code, skip, replace in python_blocks(path):
                if skip:
                    continue
                if smoke:
                    for old, new in replace:
                        assert old in code, f"{path.name}:{line}: replace target {old!r} is not in the block"
                        code = code.replace(old, new)
                try:
                    exec(compile(code, f"{path.name}:{line}", "exec"), namespace)
                except Exception as e:
                    raise AssertionError(
                        f"{path.relative_to(ROOT)}, the block at line {line} failed:\n{code}"
                    ) from e
    finally:
        for name, value in settings.items():
            jax.config.update(name, value)
