"""How deep the shipped tree files nest, as a person reads them: no definition deeper than 6 control levels.

A definition is a file's `tree` or one of its `subtrees`. Its depth is the number of control nodes
(composites, decorators, `recover`, `for_each`) on its deepest path; a `subtree` call is a leaf of the
file it is written in, and so is the subtree a `for_each` runs, as a `<SubTree ID=.../>` element is in a
BehaviorTree.CPP or Nav2 XML file (BehaviorTree.CPP's include/behaviortree_cpp/decorators/subtree_node.h).
Deeper logic gets a name: a subtree of its own, with a `doc` that says what it does.
(The expanded tree, every call inlined, is bounded by the loader: `pegbt.executive.spec.MAX_TREE_DEPTH`.)"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest

from pegbt.executive.document import TreeDocument, load_document
from pegbt.executive.nodetypes import NODE_TYPES
from pegbt.executive.problems import Problems
from pegbt.yamlfile import Located

REPO = Path(__file__).resolve().parents[2]
TREE_FILES = sorted((REPO / "trees").rglob("*.yaml"))
MAX_LEVELS = 6


@dataclass(frozen=True)
class Depth:
    """A definition's control levels and the control nodes on its deepest path, outermost first."""

    levels: int
    path: tuple[str, ...]


def node_depth(node: Located) -> Depth:
    """Control levels on the deepest path from `node` down, as written (subtree calls not expanded)."""
    if not node.is_map or len(node.value) != 1:
        return Depth(0, ())  # a leaf written as its bare type, e.g. `- capture`
    ((type_name, body),) = node.value.items()
    node_type = NODE_TYPES.get(type_name)
    if node_type is None or node_type.shape == "subtree":
        return Depth(0, ())
    fields = body.value if body.is_map else {}
    name = fields["name"].value if "name" in fields else ""
    label = (
        f"{type_name} {name!r} (line {node.mark.line})" if name else f"{type_name} (line {node.mark.line})"
    )
    if body.is_list:
        children = body.value
    elif node_type.shape == "composite":
        children = fields["children"].value if "children" in fields and fields["children"].is_list else []
    else:
        children = [fields[key] for key in node_type.child_fields if key in fields]
    deepest = max((node_depth(child) for child in children), key=_levels, default=Depth(0, ()))
    return Depth(1 + deepest.levels, (label, *deepest.path))


def _levels(depth: Depth) -> int:
    return depth.levels


def definitions(path: Path) -> dict[str, Located]:
    """The definitions written in `path` itself (not those of its includes), each by name; `tree` for the root."""
    problems = Problems()
    document: TreeDocument = load_document(path, problems)
    problems.raise_if_any()
    own = {name: document.subtrees[name].body for name in document.own_subtrees}
    return own | ({"tree": document.tree} if document.tree is not None else {})


def test_every_tree_file_is_measured():
    assert {path.relative_to(REPO / "trees").as_posix() for path in TREE_FILES} >= {
        "handover.yaml",
        "unilateral.yaml",
        "bilateral.yaml",
        "shared/handover.yaml",
        "shared/one_transfer.yaml",
        "shared/sense.yaml",
    }


@pytest.mark.parametrize("path", TREE_FILES, ids=lambda path: path.relative_to(REPO / "trees").as_posix())
def test_no_definition_nests_deeper_than_six_levels(path):
    too_deep = {
        name: depth
        for name, body in definitions(path).items()
        if (depth := node_depth(body)).levels > MAX_LEVELS
    }
    assert not too_deep, "\n".join(
        f"{path.relative_to(REPO)}: {name} nests {depth.levels} control levels (at most {MAX_LEVELS}): "
        + " > ".join(depth.path)
        for name, depth in too_deep.items()
    )


def _write(tmp_path: Path, text: str) -> Path:
    tree = tmp_path / "tree.yaml"
    tree.write_text(text)
    return tree


def test_seven_levels_are_too_deep_and_the_path_is_named(tmp_path):
    tree = _write(
        tmp_path,
        "subtrees:\n"
        "  deep:\n"
        "    tree:\n"
        "      sequence:\n"
        "        name: one\n"
        "        children:\n"
        "          - wait: {seconds: 0}\n"
        "          - selector:\n"
        "              - retry:\n"
        "                  attempts: 2\n"
        "                  child:\n"
        "                    recover:\n"
        "                      main: {wait: {seconds: 0}}\n"
        "                      recovery:\n"
        "                        timeout:\n"
        "                          seconds: 1\n"
        "                          child:\n"
        "                            parallel:\n"
        "                              name: six\n"
        "                              children:\n"
        "                                - force_success: {child: {wait: {seconds: 0}}}\n"
        "                                - wait: {seconds: 0}\n",
    )
    depths = {name: node_depth(body) for name, body in definitions(tree).items()}
    assert depths["deep"].levels == 7
    assert depths["deep"].path == (
        "sequence 'one' (line 4)",
        "selector (line 8)",
        "retry (line 9)",
        "recover (line 12)",
        "timeout (line 15)",
        "parallel 'six' (line 18)",
        "force_success (line 21)",
    )
    assert depths["deep"].levels > MAX_LEVELS


def test_a_subtree_call_and_a_loop_body_are_leaves_of_the_file_they_are_written_in(tmp_path):
    tree = _write(
        tmp_path,
        "lists: {items: [{}, {}]}\n"
        "subtrees:\n"
        "  inner:\n"
        "    tree: {force_success: {child: {sequence: [{wait: {seconds: 0}}, capture]}}}\n"
        "tree:\n"
        "  sequence:\n"
        "    - subtree: {use: inner}\n"
        "    - for_each: {list: items, use: inner}\n",
    )
    depths = {name: node_depth(body).levels for name, body in definitions(tree).items()}
    assert depths == {"inner": 2, "tree": 2}  # sequence > for_each; the calls add nothing


def test_only_a_files_own_definitions_are_its(tmp_path):
    (tmp_path / "shared.yaml").write_text("subtrees:\n  inner:\n    tree: {inverter: {child: capture}}\n")
    tree = _write(tmp_path, "include: [shared.yaml]\ntree: {subtree: {use: inner}}\n")
    assert {name: node_depth(body).levels for name, body in definitions(tree).items()} == {"tree": 0}
