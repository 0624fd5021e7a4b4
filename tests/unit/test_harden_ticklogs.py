"""Tick logs: the reader is total, linear and its own error type; a crash's log is read up to its last
complete record, with a warning."""

from __future__ import annotations

import gc
import json
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from pegbt.cli import main
from pegbt.executive.analysis import replay, summary, why
from pegbt.executive.btlog import export_btlog
from pegbt.executive.logfile import TickLogError, read_tick_log
from pegbt.monitor.replay import replay_messages

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def valid_log(tmp_path_factory) -> list[dict]:
    """The records of a real run of trees/example.yaml (manual clock)."""
    log = tmp_path_factory.mktemp("run") / "example.jsonl"
    tree = REPO / "trees" / "example.yaml"
    assert main(["run", str(tree), "--clock", "manual", "--quiet", "--log", str(log)]) == 0
    return [json.loads(line) for line in log.read_text().splitlines()]


def _write(path: Path, records: list, tail: str = "") -> Path:
    path.write_text("".join(json.dumps(record) + "\n" for record in records) + tail)
    return path


def _mutated(valid_log, change) -> list:
    records = json.loads(json.dumps(valid_log))
    change(records)
    return records


CASES = {
    "bb is a list": (lambda r: r[1].__setitem__("bb", [1, 2]), 2, "bb"),
    "bb is a string": (lambda r: r[1].__setitem__("bb", "x"), 2, "bb"),
    "a node without parent": (lambda r: r[0]["nodes"][3].pop("parent"), 1, "nodes[3].parent"),
    "a node without a name": (lambda r: r[0]["nodes"][2].pop("name"), 1, "nodes[2].name"),
    "an empty node table": (lambda r: r[0].__setitem__("nodes", []), 1, "nodes"),
    "NaN time": (lambda r: r[2].__setitem__("t", float("nan")), 3, "t"),
    "infinite time": (lambda r: r[2].__setitem__("t", float("inf")), 3, "t"),
    "a start time that is no time": (lambda r: r[0].__setitem__("start_time", "yesterday"), 1, "start_time"),
    "reads not a list": (lambda r: r[0]["nodes"][1].__setitem__("reads", 7), 1, "nodes[1].reads"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_malformed_records_are_tick_log_errors_with_line_and_field(tmp_path, valid_log, case):
    change, line, field = CASES[case]
    path = _write(tmp_path / "log.jsonl", _mutated(valid_log, change))
    with pytest.raises(TickLogError) as raised:
        read_tick_log(path)
    assert (raised.value.file, raised.value.line, raised.value.field) == (str(path), line, field)


def test_deep_json_and_huge_integers_are_tick_log_errors(tmp_path, valid_log):
    header = json.dumps(valid_log[0])
    for name, line in (
        (
            "deep",
            '{"type": "tick", "n": 1, "t": 0.0, "changes": [], "bb": {"x": '
            + "[" * 100_000
            + "]" * 100_000
            + "}}",
        ),
        ("huge", '{"type": "tick", "n": ' + "9" * 5000 + ', "t": 0.0, "changes": []}'),
    ):
        path = tmp_path / f"{name}.jsonl"
        path.write_text(header + "\n" + line + "\n")
        with pytest.raises(TickLogError, match="corrupt record: not JSON") as raised:
            read_tick_log(path)
        assert raised.value.line == 2 and len(str(raised.value)) < 300


def test_a_duplicated_record_does_not_double_the_counts(tmp_path, valid_log):
    once = read_tick_log(_write(tmp_path / "once.jsonl", valid_log))
    doubled = read_tick_log(_write(tmp_path / "twice.jsonl", valid_log[:3] + valid_log[2:]))
    assert len(doubled.transitions) == len(once.transitions)
    assert summary(doubled).splitlines()[4:] == summary(once).splitlines()[4:]
    assert doubled.warnings == ["line 4 repeats line 3 word for word; read once"]


@pytest.mark.parametrize("command", ["summary", "why", "replay", "export", "plot"])
def test_a_crashed_runs_log_is_read_to_its_last_complete_record_with_a_warning(
    tmp_path, valid_log, capsys, command
):
    whole = "".join(json.dumps(record) + "\n" for record in valid_log[:-1])  # no end record: the run died
    path = tmp_path / "crashed.jsonl"
    path.write_text(whole + json.dumps(valid_log[-1])[:17])
    extra = {"replay": ["--tick", "2"], "export": [str(tmp_path / "out.btlog")]}.get(command, [])
    assert main(["log", command, str(path), *extra]) == 0
    captured = capsys.readouterr()
    lines = len(valid_log)
    assert captured.err == (
        f"pegbt: warning: {path}: line {lines} was cut short (17 bytes, no newline: the run died while "
        f"writing it); read up to line {lines - 1}, tick {valid_log[-2]['n']}\n"
    )
    if command == "summary":
        assert "unfinished" in captured.out


def test_the_monitor_replays_a_crashed_runs_log_up_to_its_last_complete_record(tmp_path, valid_log):
    whole = "".join(json.dumps(record) + "\n" for record in valid_log[:-1])
    path = tmp_path / "crashed.jsonl"
    path.write_text(whole + json.dumps(valid_log[-1])[:17])
    messages = replay_messages(path)
    assert messages[0] == {"type": "mode", "mode": "replay", "log": str(path)}
    assert messages[1 : len(valid_log)] == valid_log[:-1]
    assert messages[len(valid_log)]["type"] == "causes"
    repeated = _write(tmp_path / "twice.jsonl", valid_log[:3] + valid_log[2:])
    assert replay_messages(repeated)[1 : len(valid_log) + 1] == valid_log  # read once, as `log replay` does


def test_a_recording_or_a_btlog_given_as_the_tick_log_is_named_for_what_it_is(tmp_path):
    from mcap.writer import Writer

    bt = pytest.importorskip("behaviortreepy")
    recording = tmp_path / "run.mcap"
    with recording.open("wb") as stream:  # written by the mcap library, not by pegbt
        writer = Writer(stream)
        writer.start(profile="ros2", library="test")
        writer.finish()
    factory = bt.BehaviorTreeFactory()
    factory.register_simple_action("A", lambda node: bt.NodeStatus.SUCCESS)
    tree = factory.create_tree_from_text(
        '<root BTCPP_format="4"><BehaviorTree ID="M"><A/></BehaviorTree></root>'
    )
    btlog = tmp_path / "run.btlog"
    logger = bt.FileLogger(tree, str(btlog))  # BT.CPP's own FileLogger2
    del logger
    for path, what in ((recording, "an MCAP recording"), (btlog, "a BT.CPP FileLogger2 .btlog")):
        with pytest.raises(TickLogError, match=f"not a tick log: this is {what}") as raised:
            read_tick_log(path)
        assert raised.value.file == str(path) and raised.value.line == 1


def _chain(count: int) -> dict:
    nodes = [
        {
            "id": i,
            "parent": i - 1 if i else None,
            "path": f"/n{i}",
            "name": f"n{i}",
            "type": "sequence",
            "source": "t.yaml:1:1",
            "reads": [],
            "writes": [],
        }
        for i in range(count)
    ]
    return {
        "type": "header",
        "format": "pegbt-ticklog",
        "format_version": 1,
        "start_time": "2026-01-01T00:00:00+00:00",
        "nodes": nodes,
    }


def _cpu_seconds(action: Callable[[], object], runs: int = 5) -> float:
    """The least CPU time of `runs` runs of `action`: this process's own work, not the machine's load (the
    least of several where a run is short enough for a pause of the interpreter to count), with the cyclic
    garbage collector off, whose passes grow with everything else the test process holds."""
    spent = []
    gc.collect()
    gc.disable()
    try:
        for _ in range(runs):
            start = time.process_time()
            action()
            spent.append(time.process_time() - start)
    finally:
        gc.enable()
    return min(spent)


def _refusal(path: Path) -> None:
    with pytest.raises(
        TickLogError, match="node 101 is nested 101 levels deep; trees are at most 100"
    ) as raised:
        read_tick_log(path)
    assert raised.value.field == "nodes"


def test_a_20000_node_chain_is_refused_in_time_linear_in_its_nodes(tmp_path):
    """Ten times the nodes, at most thirty times the CPU (depths walked node by node to the root would
    be a hundred times)."""
    small = _write(tmp_path / "chain2000.jsonl", [_chain(2_000)])
    large = _write(tmp_path / "chain20000.jsonl", [_chain(20_000)])
    assert _cpu_seconds(lambda: _refusal(large), runs=1) < 30 * _cpu_seconds(lambda: _refusal(small))


def _wide(tmp_path: Path, leaves: int) -> Path:
    """A root with `leaves` leaves, each failing once."""
    header = _chain(1)
    header["nodes"] += [
        {
            "id": i,
            "parent": 0,
            "path": f"/n0/l{i}",
            "name": f"l{i}",
            "type": "wait",
            "source": "t.yaml:1:1",
            "reads": [],
            "writes": [],
        }
        for i in range(1, leaves + 1)
    ]
    changes = [[i, "INVALID", "FAILURE", "no"] for i in range(1, leaves + 1)] + [
        [0, "INVALID", "FAILURE", ""]
    ]
    tick = {"type": "tick", "n": 1, "t": 0.5, "changes": changes}
    end = {"type": "end", "n": 1, "t": 0.5, "outcome": "failure"}
    return _write(tmp_path / f"wide{leaves}.jsonl", [header, tick, end])


def _analyse(path: Path, leaves: int) -> None:
    """Every command on the log: summary, why, replay and the BT.CPP export."""
    log = read_tick_log(path)
    assert f"l{leaves}" in summary(log) and "failed" in why(log) and f"l{leaves}" in replay(log, tick=1)
    btlog = path.with_suffix(".btlog")
    written = export_btlog(log, btlog)  # every failure, then BT.CPP's resets to IDLE
    assert written >= leaves + 1 and _btlog_transitions(btlog) == written


def test_a_wide_tree_is_analysed_in_time_linear_in_its_nodes(tmp_path):
    """Eight times the leaves, at most twenty-four times the CPU (an analysis quadratic in the nodes would
    be sixty-four times)."""
    small, large = _wide(tmp_path, 1_000), _wide(tmp_path, 8_000)
    assert _cpu_seconds(lambda: _analyse(large, 8_000), runs=1) < 24 * _cpu_seconds(
        lambda: _analyse(small, 1_000)
    )


def _btlog_transitions(path: Path) -> int:
    """The number of 9-byte transitions in a FileLogger2 file (BT.CPP's bt_file_logger_v2.cpp layout:
    magic, protocol byte, int32 XML length, XML, int64 start time, then the transitions)."""
    data = path.read_bytes()
    assert data.startswith(b"BTCPP4-FileLogger2")
    xml_length = int.from_bytes(data[19:23], "little")
    body = len(data) - (23 + xml_length + 8)
    assert body % 9 == 0
    return body // 9
