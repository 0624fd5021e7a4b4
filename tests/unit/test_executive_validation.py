"""`pegbt tree check` semantics: every problem found in one pass, each located at FILE:LINE:COLUMN."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from executive_helpers import write_tree

from pegbt.errors import PegbtError
from pegbt.executive.loader import check_tree, load_tree

REPO = Path(__file__).resolve().parents[2]


def lines_of(errors: list[PegbtError]) -> list[int]:
    return [error.line for error in errors]


FIVE_ERRORS = """\
tree:
  sequence:
    name: five errors
    children:
      - wiat: {seconds: 1}
      - wait: {seconds: soon}
      - retry: {attempts: 3, child: {scripted: {outcomes: [succes]}}}
      - log: {}
      - check_blackboard: {key: never_written}
"""


def test_five_errors_are_reported_with_their_lines_in_one_run(tmp_path):
    path = write_tree(tmp_path, FIVE_ERRORS)
    errors = check_tree(path)
    messages = [str(error) for error in errors]
    assert lines_of(errors) == [5, 6, 7, 8, 9], messages
    assert "unknown node type or behaviour 'wiat' (did you mean 'wait'?)" in messages[0]
    assert "'seconds' should be a float; found 'soon'" in messages[1]
    assert "'outcomes' should be one of 'success', 'failure', 'running'; found ['succes']" in messages[2]
    assert "missing required parameter 'message'" in messages[3]
    assert "never_written" in messages[4] and "no node writes" in messages[4]
    for error in errors:
        assert str(error).startswith(f"{path}:{error.line}:{error.column}: ")
        assert "/five errors" in str(error)
    with pytest.raises(PegbtError) as raised:
        load_tree(path)
    assert [error.line for error in raised.value.errors] == [5, 6, 7, 8, 9]


@pytest.mark.parametrize(
    ("text", "line", "expected"),
    [
        ("tree:\n  sequence:\n    children: []\n", 3, "needs `children:`, a non-empty list"),
        ("tree:\n  inverter: {}\n", 2, "needs `child:`"),
        ("tree:\n  wait: {seconds: 1, seconds: 2}\n", 2, "duplicate key 'seconds'"),
        (
            "tree:\n  sequence:\n    - wait: {seconds: 1}\n      log: {message: x}\n",
            3,
            "a node is a mapping with one key",
        ),
        (
            "tree:\n  sequence:\n    - wait: {name: a, seconds: 1}\n    - wait: {name: a, seconds: 1}\n",
            4,
            "duplicate name 'a'",
        ),
        ("tree:\n  sequence:\n    - wait: {name: a/b, seconds: 1}\n", 3, "without '/'"),
        ("tree:\n  retry: {attempts: 0, child: wait}\n", 2, "a number >= 1"),
        ("tree:\n  retry: {attempts: true, child: {wait: {seconds: 1}}}\n", 2, "should be an int"),
        (
            "tree:\n  parallel: {policy: some, children: [{wait: {seconds: 1}}]}\n",
            2,
            "one of 'all', 'one', 'selected'",
        ),
        (
            "tree:\n  parallel:\n    policy: selected\n    selected: [b]\n    children: [{wait: {name: a, seconds: 1}}]\n",
            4,
            "'b' is not a child",
        ),
        ("tree:\n  log: {message: $x}\n", 2, "does not take blackboard references"),
        ("tree:\n  wait: {seconds: $delay}\n", 2, "reads blackboard key '/delay'"),
        ("tree:\n  log: {message: '${arm}'}\n", 2, "not inside a subtree"),
        ("tre:\n  wait: {seconds: 1}\n", 1, "did you mean 'tree'"),
        ("- a\n- b\n", 1, "expected a mapping with keys"),
        ("tree: [\n", 2, "YAML syntax"),
        ("tree: 5\n", 1, "a node is a mapping with one key"),
        ("tree:\n  subtree: {use: nowhere}\n", 2, "unknown subtree 'nowhere'"),
        ("include: [missing.yaml]\ntree: {wait: {seconds: 1}}\n", 1, "included file"),
        ("tree:\n  scripted: {outcomes: []}\n", 2, "at least 1 item"),
        ("tree:\n  scripted: {outcomes: [sucess]}\n", 2, "one of 'success'"),
        ("tree:\n  !!python/object:os.system x: 1\n", 2, "not supported"),
        ("tree:\n  1: x\n", 2, "mapping keys must be plain strings"),
        ("", 1, "the file is empty"),
    ],
)
def test_single_problem_is_located(tmp_path, text, line, expected):
    errors = check_tree(write_tree(tmp_path, text))
    assert errors, "expected an error"
    assert any(error.line == line and expected in error.message for error in errors), [str(e) for e in errors]


SUBTREES = """\
subtrees:
  transfer:
    args:
      arm: str
      speed: {type: float, default: 0.1}
    tree:
      sequence:
        name: transfer ${arm}
        children:
          - set_blackboard: {key: pose, value: "${arm}"}
          - wait: {seconds: "${speed}"}
          - log: {message: "${arme}"}
"""


def test_subtree_argument_problems(tmp_path):
    write_tree(tmp_path, SUBTREES, "shared.yaml")
    path = write_tree(
        tmp_path,
        """\
    include: [shared.yaml]
    tree:
      sequence:
        - subtree: {use: transfer, args: {arm: PSM1, sped: 2}}
        - subtree: {use: transfer, args: {speed: fast}}
        - subtree: {use: transfr, args: {arm: PSM2}}
    """,
    )
    errors = check_tree(path)
    text = "\n".join(str(error) for error in errors)
    assert "no argument 'sped' (did you mean 'speed'?)" in text
    assert "argument 'speed' should be a float" in text
    assert "needs argument 'arm'" in text
    assert "unknown subtree 'transfr' (did you mean 'transfer'?)" in text
    assert f"{tmp_path / 'shared.yaml'}:12:" in text and "unknown subtree argument 'arme'" in text
    assert (
        sum("unknown subtree argument 'arme'" in str(error) for error in errors) == 1
    )  # one report per place


def test_a_subtree_file_on_its_own_is_checked_with_unbound_arguments(tmp_path):
    path = write_tree(tmp_path, SUBTREES, "shared.yaml")
    errors = check_tree(path)
    assert [(error.line, "arme" in error.message) for error in errors] == [(12, True)]


def test_include_cycles_are_refused(tmp_path):
    write_tree(tmp_path, "include: [b.yaml]\nsubtrees: {a: {tree: {wait: {seconds: 1}}}}\n", "a.yaml")
    write_tree(tmp_path, "include: [a.yaml]\nsubtrees: {b: {tree: {wait: {seconds: 1}}}}\n", "b.yaml")
    errors = check_tree(tmp_path / "a.yaml")
    assert len(errors) == 1
    assert errors[0].file == str(tmp_path / "b.yaml") and errors[0].line == 1
    assert "include cycle: a.yaml -> b.yaml -> a.yaml" in errors[0].message


def test_duplicate_subtree_definitions_across_files(tmp_path):
    write_tree(tmp_path, "subtrees: {t: {tree: {wait: {seconds: 1}}}}\n", "one.yaml")
    path = write_tree(
        tmp_path, "include: [one.yaml]\nsubtrees:\n  t: {tree: {wait: {seconds: 2}}}\n", "two.yaml"
    )
    errors = check_tree(path)
    assert [error.line for error in errors] == [3]
    assert "already defined at" in errors[0].message


def test_recursive_subtrees_are_refused(tmp_path):
    path = write_tree(
        tmp_path,
        """\
    subtrees:
      loop: {tree: {subtree: {use: loop, name: again}}}
    tree: {subtree: {use: loop}}
    """,
    )
    errors = check_tree(path)
    assert any("instantiates itself: loop -> loop" in error.message for error in errors)


def test_instances_may_not_share_a_namespace(tmp_path):
    path = write_tree(
        tmp_path,
        """\
    subtrees:
      t: {tree: {set_blackboard: {key: x, value: 1}}}
    tree:
      sequence:
        - subtree: {use: t, name: first, namespace: same}
        - subtree: {use: t, name: second, namespace: same}
    """,
    )
    errors = check_tree(path)
    assert [error.line for error in errors] == [6]
    assert "namespace '/same' is already used" in errors[0].message


def test_keys_are_checked_per_namespace(tmp_path):
    path = write_tree(
        tmp_path,
        """\
    subtrees:
      writer: {tree: {set_blackboard: {key: pose, value: 1}}}
      reader: {tree: {check_blackboard: {key: pose}}}
    tree:
      sequence:
        - subtree: {use: writer}
        - subtree: {use: reader}
        - check_blackboard: {key: /writer/pose, value: 1}
    """,
    )
    errors = check_tree(path)
    assert (
        len(errors) == 1
        and "'/reader/pose'" in errors[0].message
        and "did you mean '/writer/pose'" in errors[0].message
    )


def test_the_real_trees_are_valid():
    for path in (REPO / "trees" / "example.yaml", REPO / "trees" / "shared" / "transfer.yaml"):
        assert check_tree(path) == []


def test_the_readme_example_is_a_valid_tree(tmp_path):
    readme = (REPO / "docs" / "guides" / "trees.md").read_text()  # the README section moved there
    example = readme.split("## Behaviour trees")[1].split("```yaml\n")[1].split("```")[0]
    shutil.copytree(
        Path(__file__).resolve().parents[2] / "trees" / "shared", tmp_path / "shared"
    )  # what it includes
    errors = check_tree(write_tree(tmp_path, example))
    assert errors == [], [str(error) for error in errors]
