"""The site's generated reference: a mkdocs hook (`hooks:` in mkdocs.yml) that writes, at build time, a page
per control node type and leaf from their declarations, the CLI's `--help` of every command, and the
settings files as they are in the checkout; nothing in them is copied by hand, so a node, option or
setting added to the code is on the site at the next build (`tests/unit/test_docs_reference.py` checks
that every node of `pegbt tree schema` has its section).
"""

from __future__ import annotations

import argparse
import inspect
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from pegbt.executive.nodetypes import NODE_TYPES, NodeType
from pegbt.executive.params import Param, type_name
from pegbt.executive.registry import REGISTRY, BehaviourSpec

ROOT = Path(__file__).resolve().parent.parent
NODES_DIR = "reference/nodes"
NODES_NAV_MARKER = f"{NODES_DIR}/index.md"  # the nav entry the hook expands into every node's page
CLI_PAGE = "reference/cli.md"
SETTINGS_PAGE = "reference/settings.md"
HELP_COLUMNS = "100"  # argparse wraps --help to $COLUMNS: fixed, so the page does not depend on a terminal
SHAPES = {
    "composite": "composite (children run in order or together)",
    "decorator": "decorator (one child)",
    "recover": "recovery node (a main child and a recovery child)",
    "loop": "loop over a named list",
    "subtree": "subtree instance",
}


@dataclass(frozen=True)
class NodePage:
    """One reference page: its path under docs/, the nav group it belongs to, its title and its Markdown."""

    path: str
    group: str
    name: str
    markdown: str


def _cell(text: object) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _param_rows(params: tuple[Param, ...]) -> list[str]:
    if not params:
        return ["No parameters (besides `name`, which every node takes)."]
    rows = ["| parameter | type | default | allowed | blackboard | meaning |", "|---|---|---|---|---|---|"]
    for param in params:
        allowed = []
        if param.choices:
            allowed.append("one of " + ", ".join(f"`{choice}`" for choice in param.choices))
        if param.minimum is not None:
            allowed.append(f"≥ {param.minimum:g}")
        if param.maximum is not None:
            allowed.append(f"≤ {param.maximum:g}")
        board = []
        if param.blackboard:
            board.append("`$key` allowed")
        if param.names_key is not None:
            board.append(f"names key `{param.names_key('N')}` ({param.key})")
        elif param.key:
            board.append(f"is a key ({param.key})")
        default = "required" if param.required else f"`{param.default!r}`"
        cells = [
            f"`{param.name}`",
            f"`{type_name(param.type)}`",
            default,
            "; ".join(allowed),
            ", ".join(board),
        ]
        rows.append("| " + " | ".join(_cell(cell) for cell in [*cells, param.doc]) + " |")
    return rows


def _own_docstring(obj: Any) -> str:
    """The factory's own docstring (not one inherited from a leaf base class, which says nothing of it)."""
    doc = obj.__dict__.get("__doc__") if inspect.isclass(obj) else getattr(obj, "__doc__", None)
    return inspect.cleandoc(doc) if isinstance(doc, str) else ""


def _uses(name: str, usages: dict[str, list[str]]) -> list[str]:
    places = usages.get(name, [])
    if not places:
        return []
    shown = ", ".join(f"`{place}`" for place in places[:8])
    more = f" and {len(places) - 8} more" if len(places) > 8 else ""
    return ["", "## Used in", "", shown + more + "."]


def control_page(node: NodeType, usages: dict[str, list[str]]) -> NodePage:
    """The page of a control node type, from its `NodeType` declaration."""
    children = ", ".join(f"`{field}`" for field in node.child_fields) or "none (it expands a subtree)"
    lines = [
        f"# {node.name}",
        "",
        f"**Control node**: {SHAPES[node.shape]}. Children in: {children}. "
        "Declared in `pegbt/executive/nodetypes.py`.",
        "",
        node.doc[:1].upper() + node.doc[1:] + ".",
        "",
        "## Parameters",
        "",
        *_param_rows(node.params),
        *_uses(node.name, usages),
    ]
    return NodePage(f"{NODES_DIR}/{node.name}.md", "Control nodes", node.name, "\n".join(lines) + "\n")


def leaf_page(spec: BehaviourSpec, usages: dict[str, list[str]]) -> NodePage:
    """The page of a leaf behaviour, from its registry declaration and its factory's own docstring."""
    module = spec.factory.__module__
    group = "Conditions" if ".conditions." in module else "Actions"
    source = module.replace(".", "/") + ".py"
    lines = [
        f"# {spec.name}",
        "",
        f"**Leaf** ({group[:-1].lower()}): `{spec.factory.__qualname__}` in `{source}`.",
        "",
        spec.doc[:1].upper() + spec.doc[1:] + ".",
        "",
        "## Parameters",
        "",
        *_param_rows(spec.params),
    ]
    keys = [(label, value) for label, value in (("reads", spec.reads), ("writes", spec.writes)) if value]
    if keys or spec.resources:
        lines += ["", "## Blackboard and resources", ""]
        lines += [f"- {label}: " + ", ".join(f"`{key}`" for key in value) for label, value in keys]
        if spec.resources:
            lines.append("- needs resources: " + ", ".join(f"`{resource}`" for resource in spec.resources))
    docstring = _own_docstring(spec.factory)
    if docstring:
        lines += ["", "## How it works", "", docstring]
    lines += _uses(spec.name, usages)
    return NodePage(f"{NODES_DIR}/{spec.name}.md", group, spec.name, "\n".join(lines) + "\n")


def _walk_nodes(node: yaml.Node, names: set[str]) -> Iterator[tuple[str, int]]:
    """(node type or leaf name, line) for every tree node under a composed YAML `tree:` value."""
    if isinstance(node, yaml.MappingNode):
        if len(node.value) == 1 and node.value[0][0].value in names:
            yield node.value[0][0].value, node.start_mark.line + 1
        for _, value in node.value:
            yield from _walk_nodes(value, names)
    elif isinstance(node, yaml.SequenceNode):
        for item in node.value:
            yield from _walk_nodes(item, names)


def tree_usages(trees: Path = ROOT / "trees") -> dict[str, list[str]]:
    """Where each node type and leaf appears in the shipped tree files (`trees/shared/sense.yaml:12`)."""
    names = set(NODE_TYPES) | {spec.name for spec in REGISTRY}
    usages: dict[str, list[str]] = {}
    for path in sorted(trees.rglob("*.yaml")):
        document = yaml.compose(path.read_text())
        if not isinstance(document, yaml.MappingNode):
            continue
        roots = []
        for key, value in document.value:
            if key.value == "tree":
                roots.append(value)
            elif key.value == "subtrees" and isinstance(value, yaml.MappingNode):
                for _, definition in value.value:
                    if isinstance(definition, yaml.MappingNode):
                        roots += [tree for field, tree in definition.value if field.value == "tree"]
        for root in roots:
            for name, line in _walk_nodes(root, names):
                place = f"{path.relative_to(trees.parent)}:{line}"
                if place not in usages.setdefault(name, []):
                    usages[name].append(place)
    return usages


def node_pages() -> list[NodePage]:
    """Every control node type's page, then every leaf's, in the order `pegbt tree schema` lists them."""
    usages = tree_usages()
    return [control_page(node, usages) for node in NODE_TYPES.values()] + [
        leaf_page(spec, usages) for spec in REGISTRY
    ]


def nodes_index(pages: list[NodePage]) -> str:
    """The overview page: every node by group, with its one-line doc."""
    docs = {node.name: node.doc for node in NODE_TYPES.values()} | {spec.name: spec.doc for spec in REGISTRY}
    lines = [
        "# Tree nodes",
        "",
        "Every node a tree file can use, generated from the declarations `pegbt tree schema` prints: the",
        "control node types (`pegbt/executive/nodetypes.py`) and the leaves of the behaviour registry",
        "(`pegbt/executive/registry.py`). How to write a tree is in [Writing and editing",
        "trees](../../guides/trees.md).",
    ]
    for group in ("Control nodes", "Actions", "Conditions"):
        lines += ["", f"## {group}", "", "| node | what it does |", "|---|---|"]
        for page in pages:
            if page.group == group:
                lines.append(f"| [`{page.name}`]({page.name}.md) | {_cell(docs[page.name])} |")
    return "\n".join(lines) + "\n"


def nodes_nav(pages: list[NodePage]) -> list[Any]:
    """The nav section of the node pages: the overview, then one group per kind."""
    groups: list[Any] = [NODES_NAV_MARKER]
    for group in ("Control nodes", "Actions", "Conditions"):
        groups.append({group: [{page.name: page.path} for page in pages if page.group == group]})
    return groups


def _commands(parser: argparse.ArgumentParser) -> Iterator[argparse.ArgumentParser]:
    yield parser
    for action in parser._actions:  # argparse keeps its subcommands here and nowhere public
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield from _commands(sub)


def cli_page() -> str:
    """Every command's `--help`, as `pegbt COMMAND --help` prints it."""
    from pegbt.cli import build_parser

    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = HELP_COLUMNS
    try:
        parsers = list(_commands(build_parser()))
        helps = [(parser.prog, parser.format_help()) for parser in parsers]
    finally:
        if previous is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = previous
    lines = [
        "# Command line",
        "",
        "Every `pegbt` command's `--help`, generated from the parser at build time. Bad input is one line",
        "naming file, line, column and field, and exit status 2 (see [exit codes](bad-input.md)).",
    ]
    for prog, text in helps:
        lines += ["", f"## {prog}", "", "```text", text.rstrip(), "```"]
    return "\n".join(lines) + "\n"


def settings_page(skills: Path = ROOT / "skills") -> str:
    """Each settings file under skills/ as it is in the checkout (their comments are their documentation)."""
    lines = [
        "# Settings files",
        "",
        "The declarative settings under `skills/`, shown as they are in the checkout. Each fact is written in",
        "one file; every file is read by `pegbt/yamlfile.py`, so an error names its file, line, column and",
        "field. The run's options (`pegbt run --NAME`) are in the [command line](cli.md#pegbt-run).",
    ]
    for path in sorted(skills.glob("*.yaml")):
        lines += ["", f"## {path.name}", "", "```yaml", path.read_text().rstrip(), "```"]
    models = sorted(path.relative_to(skills.parent) for path in (skills / "calibration").rglob("*.json"))
    if models:
        lines += [
            "",
            "## calibration models",
            "",
            "Trained calibration models (`pegbt calibrate train`), read by `pegbt run --calibration DIR`:",
            "",
        ]
        lines += [f"- `{model}`" for model in models]
    return "\n".join(lines) + "\n"


# mkdocs hooks ---------------------------------------------------------------------------------------------


def _expand_nav(items: list[Any], pages: list[NodePage]) -> bool:
    for index, item in enumerate(items):
        if isinstance(item, dict):
            ((title, value),) = item.items()
            if value == NODES_NAV_MARKER:
                items[index] = {title: nodes_nav(pages)}
                return True
            if isinstance(value, list) and _expand_nav(value, pages):
                return True
    return False


_PAGES: list[NodePage] = []


def on_config(config: Any) -> Any:
    """Put every node's page in the nav, where mkdocs.yml names the nodes' overview."""
    _PAGES[:] = node_pages()
    if not _expand_nav(config["nav"], _PAGES):
        raise ValueError(f"mkdocs.yml's nav has no entry {NODES_NAV_MARKER!r} for the node pages")
    return config


def on_files(files: Any, config: Any) -> Any:
    """Add the generated pages to the site's files."""
    from mkdocs.structure.files import File

    generated = {page.path: page.markdown for page in _PAGES}
    generated[NODES_NAV_MARKER] = nodes_index(_PAGES)
    generated[CLI_PAGE] = cli_page()
    generated[SETTINGS_PAGE] = settings_page()
    for path, markdown in generated.items():
        files.append(File.generated(config, path, content=markdown))
    return files
