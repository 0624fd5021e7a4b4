"""DEVELOPERS.md's layer table is true to the imports: no module imports from a row above its own."""

from __future__ import annotations

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
Rows = list[tuple[str, ...]]  # per row, top first: module names (`pegbt.x.y`) or packages (`pegbt.x.`)


def table_rows(text: str) -> Rows:
    """The `pegbt/...` paths of each row of the layout table, as module names; a package ends in `.`."""
    rows = []
    for line in text.splitlines():
        if line.startswith("| `pegbt"):
            paths = re.findall(r"`(pegbt[^`]*)`", line.split("|")[1])
            rows.append(
                tuple(path.removesuffix(".py").removesuffix("/__init__").replace("/", ".") for path in paths)
            )
    return rows


def row_of(module: str, rows: Rows) -> int | None:
    """The row naming `module`: its own name, else the deepest package row holding it."""
    best, depth = None, -1
    for index, names in enumerate(rows):
        for name in names:
            if name == module:
                return index
            if name.endswith(".") and (module + ".").startswith(name) and len(name) > depth:
                best, depth = index, len(name)
    return best


def module_name(path: Path) -> str:
    name = ".".join(path.relative_to(REPO).with_suffix("").parts)
    return name.removesuffix(".__init__")


def imported(source: str, module: str, is_package: bool) -> list[tuple[int, str]]:
    """(line, module) of every pegbt import in `source`, relative ones resolved; `from a import b` counts
    as `a.b` when `a.b` is a module, else as `a`."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = module.split(".")
                anchor = parts if is_package else parts[:-1]
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            for alias in node.names:
                candidate = f"{base}.{alias.name}"
                exists = (REPO / Path(*candidate.split("."))).with_suffix(".py").exists() or (
                    REPO / Path(*candidate.split("."))
                ).is_dir()
                found.append((node.lineno, candidate if exists else base))
    return [(line, name) for line, name in found if name == "pegbt" or name.startswith("pegbt.")]


def upward_imports(rows: Rows, sources: dict[str, tuple[str, bool]]) -> list[str]:
    """Every import (and every module) the table does not allow, as readable lines."""
    problems = []
    for module, (source, is_package) in sorted(sources.items()):
        own = row_of(module, rows)
        if own is None:
            problems.append(f"{module}: in no row of the table")
            continue
        for line, target in imported(source, module, is_package):
            row = row_of(target, rows)
            if row is None:
                problems.append(f"{module}:{line}: imports {target}, which is in no row of the table")
            elif row < own:
                problems.append(
                    f"{module}:{line}: imports {target} (row {row + 1}) from row {own + 1}: upward"
                )
    return problems


def test_no_import_goes_up_the_layer_table():
    rows = table_rows((REPO / "DEVELOPERS.md").read_text())
    assert len(rows) > 10, "the layout table of DEVELOPERS.md was not found"
    sources = {
        module_name(path): (path.read_text(), path.name == "__init__.py")
        for path in (REPO / "pegbt").rglob("*.py")
    }
    assert upward_imports(rows, sources) == []


def test_the_check_catches_an_upward_and_an_unlisted_import():
    rows = table_rows("| `pegbt/top/` | a |\n| `pegbt/top/api.py` | b |\n| `pegbt/low.py` | c |\n")
    assert rows == [("pegbt.top.",), ("pegbt.top.api",), ("pegbt.low",)]
    sources = {
        "pegbt.low": ("from pegbt.top.api import thing\n", False),
        "pegbt.top.api": ("import pegbt.low\n", False),
        "pegbt.top.runner": ("from pegbt.top import api\nfrom pegbt.elsewhere import x\n", False),
    }
    assert upward_imports(rows, sources) == [
        "pegbt.low:1: imports pegbt.top.api (row 2) from row 3: upward",
        "pegbt.top.runner:2: imports pegbt.elsewhere, which is in no row of the table",
    ]


LEAF_KINDS = ("pegbt.behaviours.actions.", "pegbt.behaviours.conditions.")


def test_every_registered_leaf_lives_in_the_package_of_its_kind():
    """Leaves are grouped by kind (DEVELOPERS.md): the registry loads exactly the modules of `actions/` and
    `conditions/`, and every leaf it knows is defined in one of them."""
    from pegbt.executive.registry import BEHAVIOUR_MODULES, REGISTRY

    grouped = {
        module_name(path)
        for kind in ("actions", "conditions")
        for path in (REPO / "pegbt" / "behaviours" / kind).glob("*.py")
        if path.name != "__init__.py"
    }
    assert set(BEHAVIOUR_MODULES) == grouped
    modules = {spec.name: spec.factory.__module__ for spec in REGISTRY}
    misplaced = [
        f"{name}: {module}"
        for name, module in modules.items()
        if module.startswith("pegbt.") and not module.startswith(LEAF_KINDS)
    ]
    assert misplaced == []


def test_a_condition_writes_nothing_and_moves_nothing():
    """A condition only looks: it declares no blackboard write and is no motion leaf."""
    from pegbt.behaviours.base import MotionLeaf
    from pegbt.executive.registry import REGISTRY

    conditions = [spec for spec in REGISTRY if spec.factory.__module__.startswith(LEAF_KINDS[1])]
    assert {spec.name for spec in conditions} >= {"check_blackboard", "wait_blackboard", "check_placed"}
    writing = [
        spec.name
        for spec in conditions
        if spec.writes
        or any(param.key == "write" for param in spec.params)
        or (isinstance(spec.factory, type) and issubclass(spec.factory, MotionLeaf))
    ]
    assert writing == []
