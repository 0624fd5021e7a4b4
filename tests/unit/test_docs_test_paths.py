"""The docs cite the test that shows each behaviour; a test file moved between tiers must not leave the
citation pointing nowhere (mkdocs checks links, not paths quoted as code)."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CITED = re.compile(r"tests/[A-Za-z0-9_/]+\.py")


def test_every_test_file_the_docs_cite_exists() -> None:
    pages = [REPO / "README.md", REPO / "DEVELOPERS.md", *sorted((REPO / "docs").rglob("*.md"))]
    missing = sorted(
        f"{page.relative_to(REPO)}: {path}"
        for page in pages
        for path in set(CITED.findall(page.read_text(encoding="utf-8")))
        if not (REPO / path).is_file()
    )
    assert not missing, missing
