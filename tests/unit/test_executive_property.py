"""Property: any YAML document, and any mutation of the real trees, either loads or fails with a located PegbtError."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pegbt.errors import PegbtError
from pegbt.executive.loader import load_tree
from pegbt.executive.nodetypes import NODE_TYPES

TREES = Path(__file__).resolve().parents[2] / "trees"
WORDS = list(NODE_TYPES) + [
    "wait",
    "log",
    "scripted",
    "set_blackboard",
    "check_blackboard",
    "tree",
    "subtrees",
    "include",
    "blackboard",
    "children",
    "child",
    "name",
    "seconds",
    "message",
    "outcomes",
    "main",
    "recovery",
    "use",
    "args",
    "key",
    "value",
    "$x",
    "${arm}",
    "success",
    "failure",
]

scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-5, 5),
    st.floats(allow_nan=False, width=32),
    st.sampled_from(WORDS),
    st.text(max_size=8),
)
documents = st.recursive(
    scalars,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.sampled_from(WORDS), inner, max_size=4)
    ),
    max_leaves=30,
)


def assert_loads_or_locates(path: Path) -> None:
    try:
        load_tree(path)
    except PegbtError as error:
        for each in getattr(error, "errors", [error]):
            assert each.line is not None and each.line >= 1, f"no line number: {each}"
            assert each.file is not None, f"no file: {each}"


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(document=documents, wrap=st.booleans())
def test_random_yaml_documents(document, wrap):
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "random.yaml"
        path.write_text(yaml.safe_dump({"tree": document} if wrap else document), encoding="utf-8")
        assert_loads_or_locates(path)


MUTATIONS = ("delete", "duplicate", "indent", "dedent", "replace", "insert", "truncate")


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    name=st.sampled_from(["example.yaml", "shared/transfer.yaml"]),
    edits=st.lists(
        st.tuples(
            st.sampled_from(MUTATIONS),
            st.integers(0, 10_000),
            st.sampled_from(["{", "]", ":", "-", " ", "x", "$", "'", "\t", "&a", "*a", "\x00"]),
        ),
        min_size=1,
        max_size=3,
    ),
)
def test_mutated_real_trees(name, edits):
    with tempfile.TemporaryDirectory() as directory:
        shutil.copytree(TREES, Path(directory) / "trees")
        path = Path(directory) / "trees" / name
        lines = path.read_text(encoding="utf-8").split("\n")
        for kind, position, token in edits:
            index = position % len(lines)
            line = lines[index]
            column = position % (len(line) + 1)
            if kind == "delete":
                del lines[index]
            elif kind == "duplicate":
                lines.insert(index, line)
            elif kind == "indent":
                lines[index] = "  " + line
            elif kind == "dedent":
                lines[index] = line[2:]
            elif kind == "replace":
                lines[index] = line[:column] + token + line[column + 1 :]
            elif kind == "insert":
                lines[index] = line[:column] + token + line[column:]
            else:
                lines = lines[:index]
            if not lines:
                lines = [""]
        path.write_text("\n".join(lines), encoding="utf-8")
        assert_loads_or_locates(Path(directory) / "trees" / "example.yaml")
        assert_loads_or_locates(path)
