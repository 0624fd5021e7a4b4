"""The simulator's log reads back as it was written, and a torn or foreign file is named by its line."""

from __future__ import annotations

import pytest

from pegbt.errors import PegbtError
from pegbt.sim.log import SimLog, read_sim_log


def test_what_the_log_wrote_reads_back(tmp_path):
    path = tmp_path / "sim.jsonl"
    log = SimLog(path)
    log.record(0.5, "fault", fault="slip", arm="PSM1")
    log.record(1.25, "place", block=2, peg=7)
    log.close()
    assert read_sim_log(path) == [
        {"time": 0.5, "kind": "fault", "fault": "slip", "arm": "PSM1"},
        {"time": 1.25, "kind": "place", "block": 2, "peg": 7},
    ]


@pytest.mark.parametrize(
    "text, line, words",
    [
        (
            '{"time": 0.5, "kind": "start"}\n{"time": 1.0, "ki',
            2,
            "not a log entry",
        ),  # a simulator killed mid-write
        ('{"time": 0.5, "kind": "start"}\n\n[1, 2]\n', 3, "expected a JSON object"),
    ],
)
def test_a_torn_or_foreign_log_names_its_line(tmp_path, text, line, words):
    path = tmp_path / "sim.jsonl"
    path.write_text(text)
    with pytest.raises(PegbtError, match=words) as raised:
        read_sim_log(path)
    assert raised.value.line == line and raised.value.file == str(path)


def test_a_missing_log_is_named(tmp_path):
    with pytest.raises(PegbtError, match="cannot read the simulator's log"):
        read_sim_log(tmp_path / "none.jsonl")
