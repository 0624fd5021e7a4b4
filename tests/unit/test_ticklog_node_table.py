"""The tick log's node table as the analyses read it (found by `pegbt bench fuzz`'s tick_logs reader): a
second root is refused naming the node, not a ValueError in `log why`; a node written without its `reads`
or `writes` (a log from another writer) reads as one that reads and writes nothing, not a KeyError."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.executive.analysis import replay, summary, why
from pegbt.executive.logfile import TickLogError, read_tick_log
from tests.ticklog_helpers import changed_log, example_records


@pytest.fixture(scope="module")
def records(tmp_path_factory: pytest.TempPathFactory) -> list[dict]:
    return example_records(tmp_path_factory.mktemp("log"))


def _written(tmp_path: Path, records: list[dict], change) -> Path:
    return changed_log(tmp_path, records, change)[0]


def test_a_second_root_is_refused_naming_the_node(tmp_path: Path, records) -> None:
    recover = next(node for node in records[0]["nodes"] if node["type"] == "recover")
    child = next(node for node in records[0]["nodes"] if node["parent"] == recover["id"])

    def change(nodes: list[dict]) -> None:
        nodes[child["id"]]["parent"] = None

    log = _written(tmp_path, records, change)
    with pytest.raises(TickLogError) as refused:
        read_tick_log(log)
    assert refused.value.field == f"nodes[{child['id']}].parent" and "bad parent" in refused.value.message


def test_a_node_without_its_keys_reads_as_reading_and_writing_nothing(tmp_path: Path, records) -> None:
    def change(nodes: list[dict]) -> None:
        for node in nodes:
            del node["reads"], node["writes"]

    log = read_tick_log(_written(tmp_path, records, change))
    assert all(node["reads"] == [] and node["writes"] == [] for node in log.nodes)
    assert why(log) and summary(log) and replay(log, tick=1)
