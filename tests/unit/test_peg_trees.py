"""The peg-transfer trees: they check clean, and a tree that misuses a behaviour is caught before it runs."""

from __future__ import annotations

from pathlib import Path

import pytest
from executive_helpers import with_shared_trees

from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.executive.loader import check_tree, load_tree

REPO = Path(__file__).resolve().parents[2]
TREES = ["unilateral", "bilateral", "handover", "calibrate_collect"]


@pytest.mark.parametrize("name", TREES)
def test_peg_trees_check_clean(name):
    assert check_tree(REPO / "trees" / f"{name}.yaml") == []


def test_peg_trees_name_their_transfers_in_the_reference_order():
    loaded = load_tree(REPO / "trees" / "unilateral.yaml")
    begins = [
        (node.params["pick"], node.params["place"])
        for node in loaded.root.walk()
        if node.type == "begin_transfer"
    ]
    assert begins == [
        (1, 7),
        (0, 6),
        (3, 8),
        (2, 9),
        (5, 11),
        (4, 10),
        (7, 1),
        (6, 0),
        (8, 3),
        (9, 2),
        (11, 5),
        (10, 4),
    ]
    handover = load_tree(REPO / "trees" / "handover.yaml")
    arms = {node.params["arms"] for node in handover.root.walk() if node.type == "begin_transfer"}
    assert arms == {"PSM2→PSM1", "PSM1→PSM2"}
    assert {"robot", "skills"} <= set(loaded.resource_users())


def test_a_behaviour_with_wrong_parameters_is_caught_by_check_and_load(tmp_path, capsys):
    tree = tmp_path / "bad.yaml"
    with_shared_trees(tree.parent)
    tree.write_text(
        "include: [shared/one_transfer.yaml]\n"
        "tree:\n"
        "  sequence:\n"
        "    - transfer: {arm: PSM3, place: 12, speed: 2}\n"
        "    - select_grasp: {arm: PSM1}\n"
    )
    messages = "\n".join(str(error) for error in check_tree(tree))
    assert (
        f"{tree}:4:18: arm: /sequence/transfer: parameter 'arm' should be one of 'PSM1', 'PSM2'; found 'PSM3'"
        in messages
    )
    assert f"{tree}:4:29: place: /sequence/transfer: parameter 'place' should be one of 0, 1," in messages
    assert f"{tree}:4:40: speed: /sequence/transfer: transfer has no field 'speed'" in messages
    assert f"{tree}:5:7: peg: /sequence/select_grasp: missing required parameter 'peg'" in messages
    assert "reads blackboard key '/blocks', which no node writes" in messages
    with pytest.raises(PegbtError):
        load_tree(tree)
    assert main(["run", str(tree), "--log", str(tmp_path / "bad.jsonl")]) == 2
    assert "PSM3" in capsys.readouterr().err
    assert not (tmp_path / "bad.jsonl").exists()  # nothing ran, nothing connected
