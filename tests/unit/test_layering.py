"""DEVELOPERS.md's layer table is true to the imports: no module imports from a row above its own."""

from __future__ import annotations

import ast
import graphlib
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
    """Leaves are grouped by kind (DEVELOPERS.md): the declarations name exactly the modules of `actions/`
    and `conditions/` as implementations, and every leaf the registry knows is defined in one of them."""
    from pegbt.executive.registry import REGISTRY

    grouped = {
        module_name(path)
        for kind in ("actions", "conditions")
        for path in (REPO / "pegbt" / "behaviours" / kind).glob("*.py")
        if path.name != "__init__.py"
    }
    declared = {
        spec.implementation.partition(":")[0] for spec in REGISTRY if isinstance(spec.implementation, str)
    }
    assert declared == grouped
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


def import_graph(sources: dict[str, tuple[str, bool]]) -> dict[str, dict[str, int]]:
    """For each pegbt module, the pegbt modules it imports (a package as its `__init__`) and the line of the
    first such import: every import counts, inside functions and under `TYPE_CHECKING` too."""
    graph: dict[str, dict[str, int]] = {}
    for module, (source, is_package) in sources.items():
        edges = graph.setdefault(module, {})
        for line, target in imported(source, module, is_package):
            if target in sources and target != module:
                edges.setdefault(target, line)
    return graph


def import_cycle(graph: dict[str, dict[str, int]]) -> list[str]:
    """One cycle of imports, as `module:line: imports target` lines; empty when there is none."""
    try:
        graphlib.TopologicalSorter(graph).prepare()
    except graphlib.CycleError as error:
        cycle = error.args[1]  # [a, ..., a], each importing the one before it
        return [
            f"{cycle[i + 1]}:{graph[cycle[i + 1]][cycle[i]]}: imports {cycle[i]}"
            for i in range(len(cycle) - 1)
        ]
    return []


def test_no_import_cycle_among_pegbt_modules():
    sources = {
        module_name(path): (path.read_text(), path.name == "__init__.py")
        for path in (REPO / "pegbt").rglob("*.py")
    }
    assert import_cycle(import_graph(sources)) == []


def test_the_check_finds_a_cycle_through_a_function_and_type_checking():
    sources = {
        "pegbt.a": ("def f():\n    import pegbt.b\n", False),
        "pegbt.b": ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import pegbt.c\n", False),
        "pegbt.c": ("from pegbt.a import f\n", False),
        "pegbt.d": ("import pegbt.a\n", False),
    }
    cycle = import_cycle(import_graph(sources))
    assert sorted(cycle) == [
        "pegbt.a:2: imports pegbt.b",
        "pegbt.b:3: imports pegbt.c",
        "pegbt.c:1: imports pegbt.a",
    ]


def imported_tests(source: str) -> list[tuple[int, str]]:
    """(line, module) of every import of a test module (`test_*`) in `source`."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = [node.module or ""] + [f"{node.module or ''}.{alias.name}" for alias in node.names]
        else:
            continue
        found += [
            (node.lineno, name) for name in names if any(p.startswith("test_") for p in name.split("."))
        ]
    return found


def test_no_test_module_imports_another():
    """Shared test code lives in helper modules (`tests/*_helpers.py`) and `conftest.py`: a test module
    imported by another breaks it when renamed or moved to another tier, and runs as a second module object."""
    problems = [
        f"{path.relative_to(REPO)}:{line}: imports {name}"
        for path in sorted((REPO / "tests").rglob("*.py"))
        for line, name in imported_tests(path.read_text())
    ]
    assert problems == []
    assert imported_tests("from tests.test_eval_why import short_task\nimport test_perception_grasp\n") == [
        (1, "tests.test_eval_why"),
        (1, "tests.test_eval_why.short_task"),
        (2, "test_perception_grasp"),
    ]


def test_every_test_module_is_in_a_tier():
    """A test module sits in `tests/unit/`, `tests/integration/` or `tests/system/`, never loose in `tests/`."""
    assert sorted(path.name for path in (REPO / "tests").glob("test_*.py")) == []
