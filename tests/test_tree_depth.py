"""How deep the shipped trees nest: control levels (composites, decorators, `recover`, `for_each`) on the
deepest path from the root to a leaf, subtree instances expanded (an instance itself is no level).

The goal is 6 levels; the peg-transfer trees are not there yet (the shared `sense` subtree alone nests 5,
and a transfer's recovery runs it inside a `recover` inside a loop), so this holds each file to what it
nests today: a change that nests deeper fails here and must say why by raising the figure."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.executive.loader import load_tree
from pegbt.executive.spec import NodeSpec

REPO = Path(__file__).resolve().parents[1]
DEPTHS = {"unilateral": 13, "bilateral": 15, "handover": 14, "example": 5, "calibrate_collect": 0}


def control_depth(spec: NodeSpec) -> int:
    """Control levels on the deepest path below and including `spec`."""
    own = 1 if spec.children and spec.type != "subtree" else 0
    return own + max((control_depth(child) for child in spec.children), default=0)


def test_every_tree_file_is_measured():
    assert {path.stem for path in (REPO / "trees").glob("*.yaml")} == set(DEPTHS)


@pytest.mark.parametrize("name", sorted(DEPTHS))
def test_no_tree_nests_deeper_than_it_does_today(name):
    assert control_depth(load_tree(REPO / "trees" / f"{name}.yaml").root) <= DEPTHS[name]


def test_decorators_and_loops_count_and_subtree_instances_expand(tmp_path):
    tree = tmp_path / "tree.yaml"
    tree.write_text(
        "lists: {items: [{}, {}]}\n"
        "subtrees:\n"
        "  inner:\n"
        "    tree: {force_success: {child: {sequence: [{wait: {seconds: 0}}]}}}\n"
        "tree:\n"
        "  sequence:\n"
        "    - wait: {seconds: 0}\n"
        "    - for_each: {list: items, use: inner}\n"
    )
    assert control_depth(load_tree(tree).root) == 4  # sequence, for_each, force_success, sequence
