"""Tree parameters: only finite numbers within a stated physical range reach a behaviour."""

from __future__ import annotations

import typing

import pytest
from executive_helpers import write_tree

from pegbt.executive.loader import check_tree
from pegbt.executive.nodetypes import NODE_TYPES
from pegbt.executive.registry import REGISTRY

HUGE_HEX = "0x" + "f" * 5000


@pytest.mark.parametrize(
    ("text", "line", "column", "field", "expected"),
    [
        (
            "tree:\n  timeout:\n    seconds: .nan\n    child: {wait: {seconds: 1.0}}\n",
            3,
            5,
            "seconds",
            "finite",
        ),
        (
            "tree:\n  timeout:\n    seconds: .inf\n    child: {wait: {seconds: 1.0}}\n",
            3,
            5,
            "seconds",
            "finite",
        ),
        (
            "tree:\n  timeout:\n    seconds: 1.0e+300\n    child: {wait: {seconds: 1.0}}\n",
            3,
            5,
            "seconds",
            "<= ",
        ),
        ("tree:\n  wait: {seconds: .nan}\n", 2, 10, "seconds", "finite"),
        ("tree:\n  wait: {seconds: -.inf}\n", 2, 10, "seconds", "finite"),
        ("tree:\n  rise: {arm: PSM1, height: .nan}\n", 2, 21, "height", "finite"),
        ("tree:\n  rise: {arm: PSM1, height: 1.0e+300}\n", 2, 21, "height", "<= "),
        ("tree:\n  rise: {arm: PSM1, height: .inf}\n", 2, 21, "height", "finite"),
        ("tree:\n  rise: {arm: PSM1, height: 0.01, keep_apart: .nan}\n", 2, 35, "keep_apart", "finite"),
        (
            "tree:\n  retry: {attempts: " + HUGE_HEX + ", child: {wait: {seconds: 1.0}}}\n",
            2,
            11,
            "attempts",
            "beyond 64 bits",
        ),
        ("tree:\n  wait: {seconds: " + HUGE_HEX + "}\n", 2, 10, "seconds", "at most 1e300"),
        ("tree:\n  set_blackboard: {key: x, value: .nan}\n", 2, 28, "value", "finite"),
    ],
)
def test_absurd_numbers_are_refused_at_check_with_file_line_column_and_field(
    tmp_path, text, line, column, field, expected
):
    path = write_tree(tmp_path, text)
    errors = check_tree(path)
    assert len(errors) == 1, [str(error) for error in errors]
    (error,) = errors
    assert (error.file, error.line, error.column, error.field) == (str(path), line, column, field)
    assert expected in error.message
    assert len(str(error)) < 400


def _numeric(kind: object) -> bool:
    return kind in (int, float) or (
        typing.get_origin(kind) is list and typing.get_args(kind)[0] in (int, float)
    )


def test_every_numeric_parameter_states_its_range():
    params = [(f"node {node.name}", param) for node in NODE_TYPES.values() for param in node.params]
    params += [
        (f"behaviour {spec.name}", param)
        for spec in REGISTRY
        if getattr(spec.factory, "__module__", "").startswith("pegbt.")
        for param in spec.params
    ]
    unbounded = [
        f"{owner}.{param.name}"
        for owner, param in params
        if _numeric(param.type) and not param.choices and (param.minimum is None or param.maximum is None)
    ]
    assert unbounded == []
