"""docs/errors.md documents every error and warning the command line can print (checked against the code)."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "errors.md"


def _normalize(text: str) -> str:
    return re.sub(r"\s+", " ", text.replace("`", "")).strip()


def _messages():
    """(where, first literal fragment of >= 6 characters) of every `CLIError(...)` and `warnings.warn(...)`."""
    out = []
    for path in sorted((ROOT / "jaxroll").rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call) or not node.args:
                continue
            f = node.func
            is_cli = isinstance(f, ast.Name) and f.id == "CLIError"
            is_warn = (
                isinstance(f, ast.Attribute) and f.attr == "warn" and getattr(f.value, "id", "") == "warnings"
            )
            if not (is_cli or is_warn):
                continue
            literals = [
                n.value
                for n in ast.walk(node.args[0])
                if isinstance(n, ast.Constant) and isinstance(n.value, str)
            ]
            fragment = next((s.strip() for s in literals if len(s.strip()) >= 6), None)
            if fragment is not None:
                out.append((f"{path.relative_to(ROOT)}:{node.lineno}", _normalize(fragment)[:60].strip()))
    return out


MESSAGES = _messages()


def test_messages_found():
    assert len(MESSAGES) > 40  # the extraction works


@pytest.mark.parametrize("where, fragment", MESSAGES, ids=[w for w, _ in MESSAGES])
def test_every_error_and_warning_is_documented(where, fragment):
    doc = _normalize(DOC.read_text(encoding="utf-8"))
    assert fragment in doc, f"{where}: message starting {fragment!r} is not in docs/errors.md"


def test_errors_doc_is_linked_from_readme():
    assert "docs/errors.md" in (ROOT / "README.md").read_text(encoding="utf-8")
