"""Tree files: every reader total (size, depth, time, names) and includes confined."""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest
from executive_helpers import write_tree

from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.executive.loader import check_tree


def _check_within(path: Path, seconds: float = 20.0) -> list[PegbtError]:
    """`check_tree(path)`, which must return (not hang) within `seconds`."""
    result: list[list[PegbtError]] = []
    worker = threading.Thread(target=lambda: result.append(check_tree(path)), daemon=True)
    worker.start()
    worker.join(seconds)
    if worker.is_alive() and path.is_fifo():
        with open(path, "w"):  # unblock a reader stuck on the FIFO so the test process can end
            pass
    assert result, f"check_tree({path}) did not return within {seconds} s"
    return result[0]


def test_dev_zero_and_a_fifo_are_refused_without_reading_them(tmp_path):
    (tmp_path / "zero.yaml").symlink_to("/dev/zero")
    os.mkfifo(tmp_path / "fifo.yaml")
    for name in ("zero.yaml", "fifo.yaml"):
        (error,) = _check_within(tmp_path / name)
        assert "regular file" in error.message and error.file == str(tmp_path / name)


def test_a_long_path_component_is_an_error_not_an_oserror(tmp_path):
    long_name = tmp_path / ("x" * 255 + "y.yaml")
    (error,) = check_tree(long_name)
    assert "too long" in error.message
    path = write_tree(tmp_path, f"include: [{'x' * 300}.yaml]\ntree: {{wait: {{seconds: 1.0}}}}\n")
    (error,) = check_tree(path)
    assert error.line == 1 and error.field == "include" and "too long" in error.message


def _chain_of_subtrees(count: int) -> str:
    lines = ["subtrees:"]
    for index in range(count):
        body = "{wait: {seconds: 1.0}}" if index == count - 1 else f"{{subtree: {{use: s{index + 1}}}}}"
        lines.append(f"  s{index}: {{tree: {body}}}")
    return "\n".join(lines + ["tree: {subtree: {use: s0}}", ""])


def test_600_nested_subtrees_are_one_located_error(tmp_path):
    path = write_tree(tmp_path, _chain_of_subtrees(600))
    errors = _check_within(path)
    assert len(errors) == 1 and "nested more than 100 nodes deep" in errors[0].message
    assert errors[0].file == str(path) and errors[0].line > 1


def test_600_nested_includes_are_a_located_error(tmp_path):
    for index in range(600):
        text = f"include: [f{index + 1}.yaml]\n" if index < 599 else ""
        (tmp_path / f"f{index}.yaml").write_text(
            text + f"subtrees:\n  s{index}: {{tree: {{wait: {{seconds: 1.0}}}}}}\n"
        )
    path = write_tree(tmp_path, "include: [f0.yaml]\ntree: {subtree: {use: s0}}\n")
    errors = _check_within(path)
    assert [error.message for error in errors] == ["includes nested more than 32 files deep"]


def _siblings(count: int) -> str:
    """Block style: flow brackets past 10,000 switch YAML to its slower pure-Python parser."""
    return "tree:\n  sequence:\n" + "".join("    - wait:\n        seconds: 0.0\n" for _ in range(count))


def test_naming_unnamed_siblings_takes_linear_time(tmp_path, monkeypatch):
    """Counted, not timed: how often a name is looked up among its siblings (quadratic naming made
    12,000 unnamed `wait`s look up 72 million names, 19 s)."""
    from pegbt.executive import resolve

    lookups = []

    def counting(self, name):
        lookups.append(name)
        return dict.__contains__(self, name)

    monkeypatch.setattr(resolve.Siblings, "__contains__", counting)
    path = write_tree(tmp_path, _siblings(3_000), name="s3000.yaml")
    assert check_tree(path) == []
    assert len(lookups) < 3 * 3_000  # quadratic naming: 4.5 million


def test_includes_stay_in_the_trees_folder_unless_allowed_and_never_echo_a_file(tmp_path, capsys):
    secret = tmp_path / "secret.txt"
    secret.write_text("root:$6$supersecrethash:19000:0:99999:7:::\n")
    folder = tmp_path / "trees"
    folder.mkdir()
    tree = write_tree(folder, f"include: [{secret}, ../secret.txt]\ntree: {{wait: {{seconds: 1.0}}}}\n")
    assert main(["tree", "check", str(tree)]) == 2
    err = capsys.readouterr().err
    assert err.count("is outside the tree's folder") == 2 and "--allow-include-outside" in err
    assert main(["tree", "check", "--allow-include-outside", str(tree)]) == 2
    err = capsys.readouterr().err
    assert "not a tree file" in err and "supersecret" not in err and "root:" not in err
    (folder / "shared").mkdir()
    write_tree(folder / "shared", "subtrees:\n  w: {tree: {wait: {seconds: 1.0}}}\n", name="w.yaml")
    inside = write_tree(folder, "include: [shared/w.yaml]\ntree: {subtree: {use: w}}\n", name="ok.yaml")
    assert check_tree(inside) == []


@pytest.mark.parametrize(
    "text", ["tree: {wait: {seconds: 1.0}}\n", "subtrees:\n  x: {tree: {wait: {seconds: 1.0}}}\n"]
)
def test_a_symlink_out_of_the_folder_is_outside_too(tmp_path, text):
    outside = tmp_path / "elsewhere.yaml"
    outside.write_text(
        text if text.startswith("subtrees") else "subtrees:\n  x: {tree: {wait: {seconds: 1.0}}}\n"
    )
    folder = tmp_path / "trees"
    folder.mkdir()
    (folder / "link.yaml").symlink_to(outside)
    tree = write_tree(folder, "include: [link.yaml]\ntree: {subtree: {use: x}}\n")
    assert any("outside the tree's folder" in error.message for error in check_tree(tree))
    assert check_tree(tree, allow_include_outside=True) == []
