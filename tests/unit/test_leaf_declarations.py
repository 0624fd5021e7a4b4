"""The leaves are declared apart from their implementations (`pegbt.behaviours.leaves`), so a tree is
checked without importing them: each declaration must still name a real implementation, and the facts a
declaration repeats from the code behind it must agree with that code."""

from __future__ import annotations

import py_trees
import pytest

from pegbt.behaviours import leaves
from pegbt.behaviours.actions import generic
from pegbt.calibration import collect
from pegbt.executive.nodebuild import BUILDERS
from pegbt.executive.nodetypes import NODE_TYPES
from pegbt.executive.registry import REGISTRY
from pegbt.executive.resolve import absolute_key


def test_every_declared_leaf_names_a_factory_in_its_module():
    declared = [spec for spec in REGISTRY if isinstance(spec.implementation, str)]
    assert len(declared) >= 40
    for spec in declared:
        module = spec.implementation.partition(":")[0]
        assert callable(spec.factory), spec.name
        assert spec.factory.__module__ == module, spec.name


def test_what_a_declaration_repeats_agrees_with_the_code_behind_it():
    assert leaves.SETTLE == collect.SETTLE_S
    assert leaves.DESIGNS == tuple(collect.DESIGNS)
    assert set(leaves.OUTCOMES) == set(generic._STATUSES)


def test_every_control_node_but_subtree_has_a_builder():
    assert set(BUILDERS) == set(NODE_TYPES) - {"subtree"}


@pytest.mark.parametrize(
    ("namespace", "key"),
    [
        ("/", "foo"),
        ("/", "/foo"),
        ("/foo", "bar"),
        ("/foo/", "bar"),
        ("/foo", "/foo/bar"),
        ("/foo", "/bar"),
        ("/foo", "foo/bar"),
        ("/PSM1", "grasp/"),
        ("/a/b", "c.d"),
        ("/a//", "/x.y"),
    ],
)
def test_the_validator_names_a_key_as_py_trees_does_when_the_tree_runs(namespace, key):
    expected = py_trees.blackboard.Blackboard.absolute_name(namespace, key).split(".", 1)[0]
    assert absolute_key(namespace, key) == expected
