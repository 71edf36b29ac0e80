"""griffe extensions for the API reference (mkdocs.yml names them).

- `RedundantAliasesArePublic`: a name re-exported as `from ._module import Name as Name` (the explicit re-export of
  PEP 484, which every jaxroll `__init__.py` uses, as diffrax and equinox do) is public.
- `UnitsAreNotLinks`: a unit in brackets after a bracketed quantity, `E[φ²] [rad²]`, is text, not a Markdown
  reference link (Python-Markdown would read `[φ²] [rad²]` as one); the docstrings keep their plain form.
"""

import ast
import re

import griffe


class RedundantAliasesArePublic(griffe.Extension):
    def on_alias_instance(self, *, node, alias, agent, **kwargs) -> None:
        if isinstance(node, ast.ImportFrom) and any(a.asname == a.name == alias.name for a in node.names):
            alias.public = True


class UnitsAreNotLinks(griffe.Extension):
    def on_instance(self, *, node, obj, agent, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = re.sub(r"\] \[(?!`)", r"] \\[", obj.docstring.value)
