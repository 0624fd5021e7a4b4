"""The site's generated reference covers every node `pegbt tree schema` declares, built without mkdocs."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

from pegbt.executive.schema import schema_text

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def reference() -> ModuleType:
    spec = importlib.util.spec_from_file_location("docs_reference", ROOT / "dev" / "docs_reference.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def _schema_names() -> list[str]:
    """Every control node type and leaf as `pegbt tree schema` prints them (two-space indented entries)."""
    return re.findall(r"^  (\w+)(?: \[[^\]]*\])? -- ", schema_text(), flags=re.MULTILINE)


def test_every_node_of_the_schema_has_a_section_titled_with_its_name(reference: ModuleType) -> None:
    pages = reference.node_pages()
    titles = {re.match(r"# (\S+)\n", page.markdown).group(1) for page in pages}
    names = _schema_names()
    assert len(names) > 50
    assert [name for name in names if name not in titles] == []
    index = reference.nodes_index(pages)
    assert [name for name in names if f"[`{name}`]({name}.md)" not in index] == []


def test_a_page_shows_the_declared_parameters(reference: ModuleType) -> None:
    pages = {page.name: page for page in reference.node_pages()}
    timeout = pages["timeout"].markdown
    assert "| `seconds` | `float` | required | ≥ 0; ≤ 86400 |" in timeout
    approach = pages["approach"].markdown
    assert "one of `PSM1`, `PSM2`" in approach and "- needs resources: `robot`, `skills`" in approach
    assert "trees/shared/" in approach  # where the shipped trees use it


def test_a_node_left_out_of_the_generator_fails(
    reference: ModuleType, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(reference, "REGISTRY", [spec for spec in reference.REGISTRY if spec.name != "grasp"])
    titles = {page.name for page in reference.node_pages()}
    assert "grasp" in _schema_names() and "grasp" not in titles


def test_every_command_has_its_help(reference: ModuleType) -> None:
    page = reference.cli_page()
    for command in ("pegbt run", "pegbt tree schema", "pegbt log why", "pegbt eval", "pegbt monitor"):
        assert f"\n## {command}\n\n```text\nusage: {command} " in page
