"""`pegbt log export` of a tick log whose nodes BT.CPP could not read (found by `pegbt bench fuzz`'s
btlog_files reader): a type that is not an XML name, a parameter the BT.CPP node needs missing or not a
number. Each is one `PegbtError` naming the log and node, not an XML ParseError or a KeyError."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.errors import PegbtError
from pegbt.executive.btlog import export_btlog
from pegbt.executive.logfile import read_tick_log
from tests.ticklog_helpers import changed_log, example_records


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> list[dict]:
    return example_records(tmp_path_factory.mktemp("log"))


def _export(tmp_path: Path, records: list[dict], change) -> PegbtError:
    log, node = changed_log(tmp_path, records, change)
    with pytest.raises(PegbtError) as raised:
        export_btlog(read_tick_log(log), tmp_path / "out.btlog")
    assert raised.value.file == str(log) and raised.value.field == f"node {node['id']}"
    return raised.value


def test_a_type_that_is_no_xml_name_is_refused_naming_the_node(tmp_path: Path, records) -> None:
    def change(nodes: list[dict]) -> dict:
        leaf = next(node for node in nodes if not node.get("children"))
        leaf["type"] = "9" * 50
        return leaf

    assert "is not an XML name" in _export(tmp_path, records, change).message


def test_a_subtree_without_its_use_is_refused_naming_the_node(tmp_path: Path, records) -> None:
    def change(nodes: list[dict]) -> dict:
        subtree = next(node for node in nodes if node["type"] == "subtree")
        subtree["params"] = {}
        return subtree

    assert "cannot be written for BT.CPP: KeyError 'use'" in _export(tmp_path, records, change).message


@pytest.mark.parametrize("kind", ["subtree", "scripted"])
def test_a_name_with_a_control_character_is_refused_naming_the_node(tmp_path: Path, records, kind) -> None:
    def change(nodes: list[dict]) -> dict:
        node = next(node for node in nodes if node["type"] == kind)
        node["name"] += "\x01"  # no XML 1.0 document can carry it, not even as &#1;
        return node

    assert "a character XML cannot carry" in _export(tmp_path, records, change).message
