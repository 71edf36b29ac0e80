"""mkdocs hooks: the home page is README.md (docs/index.md is its placeholder), whose links to the pages are relative
to the repository's root (`docs/theory.md`, as GitHub shows them); on the site they are relative to docs/."""

import re
from pathlib import Path


def on_page_markdown(markdown: str, page, config, files) -> str:
    if page.file.src_uri != "index.md":
        return markdown
    readme = (Path(config["config_file_path"]).parent / "README.md").read_text(encoding="utf-8")
    return re.sub(r"\]\(docs/", "](", readme)
