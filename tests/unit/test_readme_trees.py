"""The README's trees are quoted from the tree files, never written for it: a tree edited without its quote
(or a quote edited without its tree) fails here."""

import re
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BLOCK = re.compile(r"((?:[^\n]*\n){1,3})\n```yaml\n(.*?)```", re.S)
SOURCE = re.compile(r"`(trees/[\w/]+\.yaml)`")


def quoted_trees() -> list[tuple[str, str]]:
    """Each YAML block of the README with the tree file its introducing lines name (the last one named)."""
    readme = (ROOT / "README.md").read_text()
    return [(SOURCE.findall(intro)[-1], block) for intro, block in BLOCK.findall(readme)]


def is_excerpt(block: str, source: str) -> bool:
    """Whether `block` is `source` whole, or a run of its lines shifted left by one common indent."""
    if block == source:
        return True
    wanted = block.splitlines()
    lines = source.splitlines()
    for start in range(len(lines) - len(wanted) + 1):
        if textwrap.dedent("\n".join(lines[start : start + len(wanted)])).splitlines() == wanted:
            return True
    return False


def test_the_readme_quotes_trees_that_exist() -> None:
    quotes = quoted_trees()
    assert len(quotes) >= 2, "the README shows a tree and its recovery"
    for path, block in quotes:
        assert is_excerpt(block, (ROOT / path).read_text()), f"README's quote of {path} is not in that file"


def test_an_edited_quote_is_told() -> None:
    path, block = quoted_trees()[-1]
    assert not is_excerpt(block.replace("retries", "attempts"), (ROOT / path).read_text())
