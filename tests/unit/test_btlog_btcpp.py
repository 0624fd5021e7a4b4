"""`pegbt log export` against BehaviorTree.CPP itself (behaviortreepy: BT.CPP 4.8 with its `FileLogger2`).

A tree of nodes BT.CPP has runs in pegbt on scripted leaves; its export is compared with the file BT.CPP's
own `FileLogger` writes when BT.CPP runs the exported XML with leaves that replay what pegbt's leaves did.
Both files are read by the small reader below, written from `src/loggers/bt_file_logger_v2.cpp`.
"""

from __future__ import annotations

import datetime
import gc
import struct
import time
from xml.etree import ElementTree

import pytest
from executive_helpers import build_text

from pegbt.clock import ManualClock
from pegbt.errors import PegbtError
from pegbt.executive.btlog import export_btlog
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.runner import run
from pegbt.executive.ticklog import TickLogWriter

bt = pytest.importorskip("behaviortreepy")

PERIOD = 0.02
TREE = """
subtrees:
  place:
    args: {who: str}
    tree:
      sequence:
        name: place ${who}
        children:
          - inverter: {child: {scripted: {name: blocked, outcomes: [failure]}}}
          - force_success:
              child:
                timeout: {name: limit, seconds: 0.05, child: {scripted: {name: stuck, outcomes: [running]}}}
tree:
  sequence:
    name: task
    children:
      - scripted: {name: approach, outcomes: [running, running, success]}
      - selector:
          name: pick either
          memory: true
          children:
            - scripted: {name: left, outcomes: [failure]}
            - retry:
                name: again
                attempts: 3
                child: {scripted: {name: right, outcomes: [failure, running, success]}}
      - selector:
          name: reactive
          children:
            - scripted: {name: blocked too, outcomes: [failure]}
            - scripted: {name: at once, outcomes: [success]}
      - parallel:
          children:
            - scripted: {name: p1, outcomes: [running, success]}
            - scripted: {name: p2, outcomes: [running, running, running, success]}
      - subtree: {use: place, args: {who: me}, name: put}
      - subtree: {use: place, args: {who: you}, name: put again}  # other names: a definition of its own
      - retry:
          name: start over
          attempts: 2
          child:
            sequence:
              name: both
              children:  # restarted from the first child after a failure: BT.CPP's Sequence, not SequenceWithMemory
                - scripted: {name: first, outcomes: [success, running, success]}
                - scripted: {name: second, outcomes: [failure, success]}
      - repeat:
          times: 2
          child: {scripted: {name: twice, outcomes: [running, success, running, running, success]}}
"""


def read_btlog(data: bytes) -> tuple[bytes, int, str, int, list[tuple[int, int, int]]]:
    """(magic, protocol, XML, first µs, [(µs, uid, status)]) as `FileLogger2` lays them out."""
    magic, protocol = data[:18], data[18]
    (size,) = struct.unpack_from("<i", data, 19)
    xml = data[23 : 23 + size].decode("utf-8")
    (first,) = struct.unpack_from("<q", data, 23 + size)
    body = data[31 + size :]
    assert len(body) % 9 == 0
    records = [
        (int.from_bytes(body[i : i + 6], "little"), *struct.unpack_from("<HB", body, i + 6))
        for i in range(0, len(body), 9)
    ]
    return magic, protocol, xml, first, records


def tree_nodes(xml: str) -> list[tuple[str, str, str | None, str, str]]:
    """Every node under a `BehaviorTree`: (tree ID, its _fullpath, name, tag, _uid), in document order.

    BT.CPP writes a `SubTree`'s instance name only in `_fullpath`; pegbt also gives it as `name`, which
    BT.CPP's parser reads (so BT.CPP, loading pegbt's XML, names the instance as pegbt does)."""
    nodes = []
    for tree in ElementTree.fromstring(xml).findall("BehaviorTree"):
        for element in tree.iter():
            if element is not tree:
                name = element.get("_fullpath") if element.tag == "SubTree" else element.get("name")
                nodes.append((tree.get("ID"), tree.get("_fullpath"), name, element.tag, element.get("_uid")))
    return nodes


def activations(log, node: int) -> list[list[tuple[int, str]]]:
    """Each start of a leaf in pegbt's run: its statuses with the tick they began."""
    runs: list[list[tuple[int, str]]] = []
    for change in log.transitions:
        if change.node != node or change.after == "INVALID":
            continue
        if change.before != "RUNNING" or not runs:
            runs.append([])
        runs[-1].append((change.n, change.after))
    return runs


class Replay:
    """BT.CPP leaves that return, tick by tick, what the pegbt leaf with the same uid returned.

    Each activation is replayed from the tick BT.CPP starts it: BT.CPP's `Timeout` fires on wall time, so
    on a loaded machine it may end its child a tick later than pegbt's clock did, and every later leaf then
    starts a tick later too."""

    def __init__(self, log) -> None:
        self.tick = 0
        self.pending = {node["id"] + 1: activations(log, node["id"]) for node in log.nodes}
        self.current: dict[int, list[tuple[int, str]]] = {}
        self.errors: list[str] = []

    def start(self, node) -> object:
        uid = node.uid()
        if not self.pending[uid]:
            self.errors.append(f"uid {uid} ticked more often in BT.CPP than in pegbt")
            return bt.NodeStatus.FAILURE
        activation = self.pending[uid].pop(0)
        shift = self.tick - activation[0][0]
        self.current[uid] = [(n + shift, status) for n, status in activation]
        return self.running(node)

    def running(self, node) -> object:
        statuses = self.current[node.uid()]
        status = statuses[0][1]
        for tick, later in statuses:
            if tick <= self.tick:
                status = later
        return getattr(bt.NodeStatus, status)


def leaf_ports_dropped(xml: str) -> str:
    """behaviortreepy's Python actions declare no ports: leaves keep only their name and _uid."""
    root = ElementTree.fromstring(xml)
    for tree in root.findall("BehaviorTree"):
        for element in tree.iter():
            if element.tag == "scripted":
                for name in set(element.keys()) - {"name", "_uid"}:
                    del element.attrib[name]
    return ElementTree.tostring(root, encoding="unicode")


def test_export_matches_the_file_btcpp_writes_for_the_same_run(tmp_path):
    clock = ManualClock()
    built = build_text(tmp_path, TREE, clock)
    log_path = tmp_path / "run.jsonl"
    result = run(built, period=PERIOD, log=TickLogWriter(log_path, built, clock_kind="manual"))
    assert result.outcome == "success"
    log = read_tick_log(log_path)
    ours = tmp_path / "pegbt.btlog"
    export_btlog(log, ours)
    magic, protocol, xml, first_us, records = read_btlog(ours.read_bytes())
    start = datetime.datetime.fromisoformat(log.header["start_time"]).timestamp()
    assert abs(first_us / 1e6 - start) < 1e-3

    factory = bt.BehaviorTreeFactory()
    replay = Replay(log)
    factory.register_simple_stateful_action("scripted", replay.start, replay.running)
    tree = factory.create_tree_from_text(leaf_ports_dropped(xml).replace('msec="50"', 'msec="70"'))
    theirs = tmp_path / "btcpp.btlog"
    logger = bt.FileLogger(tree, str(theirs))
    status = bt.NodeStatus.RUNNING
    while status == bt.NodeStatus.RUNNING and replay.tick < log.last_n + 100:
        replay.tick += 1
        status = tree.tick_exactly_once()
        time.sleep(PERIOD)  # BT.CPP's Timeout fires on wall time
    time.sleep(0.05)  # the logger's writer thread drains its queue every 10 ms
    del logger
    gc.collect()
    assert status == bt.NodeStatus.SUCCESS and not replay.errors
    their_magic, their_protocol, their_xml, _, their_records = read_btlog(theirs.read_bytes())

    assert (magic, protocol) == (their_magic, their_protocol) == (b"BTCPP4-FileLogger2", 1)
    assert [tree.get("ID") for tree in ElementTree.fromstring(xml).findall("BehaviorTree")] == [
        "MainTree",
        "place",
        "place_2",
    ]
    assert tree_nodes(xml) == tree_nodes(their_xml)  # each instance of `place` keeps its own names
    assert len(tree_nodes(xml)) == len(log.nodes)
    ours_sequence = [(uid, status) for _, uid, status in records]
    assert ours_sequence == [(uid, status) for _, uid, status in their_records]
    assert [t for t, _, _ in records] == sorted(t for t, _, _ in records)
    assert records[-1] == (round(log.last_t * 1e6), 1, 0)  # the root reset at the run's end (pegbt's clock)
    uid = {node["name"]: node["id"] + 1 for node in log.nodes}
    assert (uid["left"], 3) in ours_sequence and (uid["right"], 3) in ours_sequence  # a failure, a retry
    assert ours_sequence.count((uid["twice"], 1)) == 2  # a leaf running over several ticks, twice
    assert ours_sequence.count((uid["first"], 2)) == 2  # the sequence ran its first child again
    assert (uid["stuck"], 0) in ours_sequence and (uid["limit"], 3) in ours_sequence  # timed out: halted


def test_exported_xml_uses_btcpp_builtins_and_declares_the_rest(tmp_path):
    text = """
    tree:
      sequence:
        name: task
        memory: false
        children:
          - recover: {main: {scripted: {name: pick, outcomes: [success]}}, recovery: {wait: {seconds: 0.1}}}
          - guard: {key: ok, child: {log: {message: go}}}
          - parallel: {policy: one, children: [{wait: {seconds: 0.1}}, {wait: {seconds: $delay}}]}
    blackboard: {ok: true, delay: 0.2}
    """
    built = build_text(tmp_path, text)
    log_path = tmp_path / "run.jsonl"
    run(built, period=0.1, log=TickLogWriter(log_path, built, clock_kind="manual"))
    out = tmp_path / "run.btlog"
    export_btlog(read_tick_log(log_path), out)
    root = ElementTree.fromstring(read_btlog(out.read_bytes())[2])
    main = root.find("BehaviorTree")
    assert [child.tag for child in main.find("ReactiveSequence")] == ["recover", "guard", "Parallel"]
    parallel = main.find("ReactiveSequence/Parallel")
    assert (parallel.get("success_count"), parallel.get("failure_count")) == ("1", "1")
    assert parallel[1].get("seconds") == "{delay}"
    models = {
        model.get("ID"): (model.tag, {port.get("name") for port in model})
        for model in root.find("TreeNodesModel")
    }
    assert models["recover"] == ("Control", {"retries"})
    assert models["guard"] == ("Decorator", {"key", "op", "value"})
    assert models["wait"] == ("Action", {"seconds"}) and models["log"][0] == "Action"
    assert not {"ReactiveSequence", "Parallel"} & set(models)


@pytest.mark.parametrize("name", ["run.log", "run.BTLOG", ".btlog", "run.btlog.txt", "run.btlog"])
def test_export_takes_the_names_btcpps_file_logger_takes(tmp_path, name):
    built = build_text(tmp_path, "tree: {scripted: {name: once, outcomes: [success]}}")
    log_path = tmp_path / "run.jsonl"
    run(built, period=PERIOD, log=TickLogWriter(log_path, built, clock_kind="manual"))
    factory = bt.BehaviorTreeFactory()
    factory.register_simple_action("A", lambda node: bt.NodeStatus.SUCCESS)
    tree = factory.create_tree_from_text(
        '<root BTCPP_format="4"><BehaviorTree ID="M"><A/></BehaviorTree></root>'
    )
    try:
        logger = bt.FileLogger(tree, str(tmp_path / name))
        del logger
        btcpp_takes = True
    except RuntimeError as error:
        assert "extension must be [.btlog]" in str(error)
        btcpp_takes = False
    out = tmp_path / "pegbt" / name
    out.parent.mkdir()
    try:
        export_btlog(read_tick_log(log_path), out)
        pegbt_takes = True
    except PegbtError as error:
        assert error.file == str(out) and error.field == "OUT" and ".btlog" in error.message
        pegbt_takes = False
    assert pegbt_takes == btcpp_takes == out.exists()


HALTED = """
tree:
  sequence:
    name: task
    children:
      - scripted: {name: first, outcomes: [success]}
      - selector:
          name: either
          memory: true
          children:
            - scripted: {name: fails, outcomes: [failure]}
            - parallel:
                children:
                  - scripted: {name: p1, outcomes: [running]}
                  - scripted: {name: p2, outcomes: [running, success]}
      - scripted: {name: never, outcomes: [success]}
"""


def test_a_run_halted_by_its_timeout_exports_what_btcpps_halt_tree_logs(tmp_path):
    built = build_text(tmp_path, HALTED, ManualClock())
    log_path = tmp_path / "run.jsonl"
    result = run(built, period=PERIOD, timeout=0.1, log=TickLogWriter(log_path, built, clock_kind="manual"))
    assert result.outcome == "timeout"
    log = read_tick_log(log_path)
    ours = tmp_path / "pegbt.btlog"
    export_btlog(log, ours)
    _, _, xml, _, records = read_btlog(ours.read_bytes())
    factory = bt.BehaviorTreeFactory()
    replay = Replay(log)
    factory.register_simple_stateful_action("scripted", replay.start, replay.running)
    tree = factory.create_tree_from_text(leaf_ports_dropped(xml))
    theirs = tmp_path / "btcpp.btlog"
    logger = bt.FileLogger(tree, str(theirs))
    for _ in range(result.ticks):
        replay.tick += 1
        assert tree.tick_exactly_once() == bt.NodeStatus.RUNNING
    tree.halt_tree()  # what a timeout or Ctrl-C does to the whole tree
    time.sleep(0.05)  # the logger's writer thread drains its queue every 10 ms
    del logger
    gc.collect()
    uid = {node["name"]: node["id"] + 1 for node in log.nodes}
    ours_sequence = [(uid, status) for _, uid, status in records]
    assert ours_sequence == [(uid, status) for _, uid, status in read_btlog(theirs.read_bytes())[4]]
    assert ours_sequence[-7:] == [(uid[name], 0) for name in ("first", "fails", "p1", "p2")] + [
        (uid["parallel"], 0),
        (uid["either"], 0),
        (uid["task"], 0),
    ]  # children reset before their parents
    assert not replay.errors and (uid["never"], 1) not in ours_sequence
