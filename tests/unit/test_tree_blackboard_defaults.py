"""Included tree files declare their own blackboard defaults: the including tree's value wins, and two
included files that disagree on a key are an error naming file, line and field."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.errors import PegbtError
from pegbt.executive.loader import check_tree, load_tree

SHARED = "subtrees:\n  idle:\n    tree: {wait: {seconds: 0.0}}\n"


def _files(tmp_path: Path, tree_blackboard: str, second: str = "") -> Path:
    (tmp_path / "a.yaml").write_text("blackboard: {/speed: 1, /arm_ok: true}\n" + SHARED)
    (tmp_path / "b.yaml").write_text(second + "subtrees:\n  other:\n    tree: {wait: {seconds: 0.0}}\n")
    tree = tmp_path / "tree.yaml"
    tree.write_text("include: [a.yaml, b.yaml]\n" + tree_blackboard + "tree:\n  subtree: {use: idle}\n")
    return tree


def test_an_included_files_defaults_apply_unless_the_tree_sets_the_key(tmp_path):
    loaded = load_tree(_files(tmp_path, "blackboard: {/speed: 2}\n"))
    assert loaded.initial_blackboard == {"/speed": 2, "/arm_ok": True}


def test_two_included_files_agreeing_on_a_default_is_no_conflict(tmp_path):
    loaded = load_tree(_files(tmp_path, "", second="blackboard: {/arm_ok: true}\n"))
    assert loaded.initial_blackboard == {"/speed": 1, "/arm_ok": True}


def test_two_included_files_with_different_defaults_are_an_error_naming_both(tmp_path):
    tree = _files(tmp_path, "", second="blackboard:\n  /speed: 3\n")
    messages = [str(error) for error in check_tree(tree)]
    assert len(messages) == 1
    assert messages[0].startswith(f"{tmp_path / 'b.yaml'}:2:")
    assert "/speed" in messages[0] and f"{tmp_path / 'a.yaml'}:1:" in messages[0]
    with pytest.raises(PegbtError):
        load_tree(tree)


def test_the_tree_setting_the_key_settles_a_conflict(tmp_path):
    loaded = load_tree(_files(tmp_path, "blackboard: {/speed: 5}\n", second="blackboard: {/speed: 3}\n"))
    assert loaded.initial_blackboard["/speed"] == 5
