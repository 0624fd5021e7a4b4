"""Tick logs: what the runner records (transitions, blackboard, halts, crashes) and what analysis reads back."""

from __future__ import annotations

import json

import numpy as np
import py_trees
import pytest
from executive_helpers import build_text, motion_class

from pegbt.clock import ManualClock
from pegbt.errors import PegbtError
from pegbt.executive.analysis import replay, summary, why
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.runner import run
from pegbt.executive.ticklog import TickLogWriter

FAILING = """
blackboard: {force: 2.5, limit: 1.0}
subtrees:
  grasp:
    args: {arm: str}
    tree:
      sequence:
        name: grasp ${arm}
        children:
          - set_blackboard: {name: aim, key: target, value: "block for ${arm}"}
          - retry:
              attempts: 2
              child:
                scripted: {name: close jaw, outcomes: [running, failure], message: "jaw of ${arm} slipped"}
tree:
  sequence:
    name: task
    children:
      - log: {name: hello, message: start}
      - selector:
          name: pick either arm
          children:
            - subtree: {use: grasp, args: {arm: PSM1}}
            - check_blackboard: {name: force ok, key: force, op: "<", value: 1.0}
      - log: {name: never, message: unreachable}
"""


def run_logged(tmp_path, text, *, timeout=None, clock=None):
    clock = clock or ManualClock()
    built = build_text(tmp_path, text, clock)
    path = tmp_path / "run.jsonl"
    result = run(built, period=0.1, timeout=timeout, log=TickLogWriter(path, built, clock_kind="manual"))
    return result, path


def records(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_why_names_the_leaves_that_caused_a_scripted_failure(tmp_path):
    result, path = run_logged(tmp_path, FAILING)
    assert result.outcome == "failure"
    text = why(read_tick_log(path))
    chain = text.split("causal chain")[1].split("recoveries:")[0]
    assert "/task (sequence) failed" in chain
    assert "/task/pick either arm (selector) failed" in chain
    assert "retry (retry) failed at t=0.200 s, tick 3: final failure [status: 2 failure from 2]" in chain
    # a node failing on consecutive ticks is one transition: the leaf has been failing since tick 2
    assert "close jaw (scripted) failed at t=0.100 s, tick 2: jaw of PSM1 slipped  <- failed here" in chain
    assert "force ok (check_blackboard) failed" in chain and "<- failed here" in chain.split("force ok")[1]
    assert "blackboard it reads: /force=2.5" in chain
    assert "tree.yaml:14:17" in chain  # the scripted leaf's definition, inside the subtree
    assert "never" not in chain and "hello" not in chain


def test_the_log_records_transitions_blackboard_writes_and_sources(tmp_path):
    _, path = run_logged(tmp_path, FAILING)
    header, *events = records(path)
    nodes = {node["path"]: node for node in header["nodes"]}
    leaf = nodes["/task/pick either arm/grasp PSM1/grasp PSM1/retry/close jaw"]
    assert leaf["source"].endswith("tree.yaml:14:17") and leaf["type"] == "scripted"
    assert nodes["/task/pick either arm/force ok"]["reads"] == ["/force"]
    assert nodes["/task/pick either arm/grasp PSM1/grasp PSM1/aim"]["writes"] == ["/grasp_PSM1/target"]
    assert header["blackboard"] == {"/force": 2.5, "/limit": 1.0}
    first = events[0]
    assert (
        first["type"] == "tick" and first["n"] == 1 and first["bb"]["/grasp_PSM1/target"] == "block for PSM1"
    )
    assert [leaf["id"], "INVALID", "RUNNING", ""] in first["changes"]
    failures = [
        change
        for event in events
        if event["type"] == "tick"
        for change in event["changes"]
        if change[0] == leaf["id"] and change[2] == "FAILURE"
    ]
    assert failures == [[leaf["id"], "RUNNING", "FAILURE", "jaw of PSM1 slipped"]]
    assert events[-1] == {
        "type": "end",
        "n": 3,
        "t": pytest.approx(0.2),
        "outcome": "failure",
        "overruns": 0,
        "work": {"jobs": 0, "compute_s": 0.0, "waited_s": 0.0, "by_kind": {}},
    }
    assert all(
        event["type"] != "tick" or event["changes"] or "bb" in event for event in events
    )  # only ticks that changed


def test_blackboard_arrays_are_logged_as_short_lists(tmp_path):
    built = build_text(tmp_path, "tree: {scripted: {outcomes: [running]}}")
    path = tmp_path / "arrays.jsonl"
    writer = TickLogWriter(path, built, clock_kind="manual")
    py_trees.blackboard.Blackboard.set("/pose", np.array([0.1, 0.2, 0.3]))
    py_trees.blackboard.Blackboard.set("/cloud", np.zeros((100, 3)))
    writer.tick_logged()
    writer.tick(1, 0.0, 1e-4)
    py_trees.blackboard.Blackboard.set(
        "/pose", np.array([0.1, 0.2, 0.3])
    )  # new object, same value: no record
    writer.tick_logged()
    writer.tick(2, 0.1, 1e-4)
    writer.close()
    ticks = records(path)[1:]
    assert len(ticks) == 1
    assert ticks[0]["bb"]["/pose"] == [0.1, 0.2, 0.3]
    assert ticks[0]["bb"]["/cloud"] == {"shape": [100, 3], "dtype": "float64", "head": [0.0] * 8}


class InterruptingClock(ManualClock):
    """Raises KeyboardInterrupt (as Ctrl-C would) while the runner waits for the third tick."""

    def __init__(self) -> None:
        super().__init__()
        self.waits = 0

    def wait(self, seconds: float) -> None:
        self.waits += 1
        if self.waits == 2:
            raise KeyboardInterrupt
        super().wait(seconds)


def test_ctrl_c_halts_running_behaviours_and_is_logged(tmp_path):
    motion_class().terminated.clear()
    result, path = run_logged(
        tmp_path, "tree: {sequence: [{test_motion: {name: move}}]}", clock=InterruptingClock()
    )
    assert result.outcome == "interrupted" and result.ticks == 2
    assert motion_class().terminated == [("move", py_trees.common.Status.INVALID)]
    halt, end = records(path)[-2:]
    assert halt["type"] == "halt" and halt["reason"] == "interrupt"
    assert [1, "RUNNING", "INVALID", ""] in halt["changes"]
    assert end["outcome"] == "interrupted"
    assert "halted: interrupt" in why(read_tick_log(path))


def test_a_timeout_halts_the_tree(tmp_path):
    result, path = run_logged(tmp_path, "tree: {test_motion: {name: move}}", timeout=0.35)
    assert result.outcome == "timeout" and result.ticks == 5  # ticks at t = 0, 0.1, ... 0.4 >= 0.35
    assert records(path)[-2]["reason"] == "timeout"


def test_a_crash_is_logged_and_raised(tmp_path):
    with pytest.raises(RuntimeError, match="behaviour bug"):
        run_logged(tmp_path, "tree: {parallel: [{test_motion: {name: move}}, {test_crash: {name: bug}}]}")
    crash, halt, end = records(tmp_path / "run.jsonl")[-3:]
    assert (
        crash["type"] == "crash"
        and "RuntimeError: behaviour bug" in crash["error"]
        and "Traceback" in crash["traceback"]
    )
    assert halt["reason"] == "crash" and end["outcome"] == "crash"


RECOVERED = """
tree:
  recover:
    name: pick with recovery
    retries: 2
    main: {scripted: {name: pick, outcomes: [failure, running, success], message: missed}}
    recovery: {wait: {name: re-sense, seconds: 0.15}}
"""


def test_why_reports_recoveries_that_helped(tmp_path):
    result, path = run_logged(tmp_path, RECOVERED)
    assert result.outcome == "success"
    text = why(read_tick_log(path))
    assert "the run succeeded; failures below were recovered" in text
    assert (
        "/pick with recovery: main failed at t=0.000 s (pick: missed); recovery success at t=0.200 s; "
        "main was retried and succeeded at t=0.300 s: it helped" in text
    )


def test_replay_shows_every_status_at_a_tick(tmp_path):
    _, path = run_logged(tmp_path, RECOVERED)
    log = read_tick_log(path)
    lines = replay(log, tick=1).splitlines()  # the wait's hint lets the runner skip the tick at 0.1 s
    assert lines[0].startswith("after tick 1 of 3")
    assert lines[1] == "[R] pick with recovery  -- main failed; running recovery 1 of 2"
    assert lines[2] == "    [F] pick  -- missed"
    assert lines[3] == "    [R] re-sense  -- waiting 0.15 s"
    assert replay(log, time=0.25).splitlines()[2] == "    [R] pick"


def test_summary_counts_and_times(tmp_path):
    _, path = run_logged(tmp_path, RECOVERED)
    text = summary(read_tick_log(path))
    assert "outcome:  success" in text and "duration: 0.300 s over 3 ticks" in text
    row = next(line for line in text.splitlines() if line.split()[:2] == ["pick", "1"])
    assert row.split()[1:5] == ["1", "1", "0", "0.100"]


@pytest.mark.parametrize(
    ("damage", "line", "expected"),
    [
        (lambda lines: [lines[0][:10]], 1, "truncated record"),  # a cut last record is only a warning
        (lambda lines: lines[:2] + ["{not json"] + lines[2:], 3, "corrupt record: not JSON"),
        (lambda lines: [lines[0].replace("pegbt-ticklog", "other")] + lines[1:], 1, "not a pegbt tick log"),
        (
            lambda lines: lines[:1] + [lines[1].replace('"RUNNING"', '"WALKING"', 1)] + lines[2:],
            2,
            "corrupt status change",
        ),
        (lambda lines: lines[:1] + [lines[1].replace('"n":1', '"n":"one"')] + lines[2:], 2, "expected int"),
        (lambda lines: lines + ['{"type":"tick","n":9,"t":1}'], "last", "record after the end record"),
        (lambda lines: lines + ["[]"], "last", "expected a JSON object"),
        (lambda lines: [], 1, "empty"),
    ],
)
def test_damaged_logs_give_located_errors(tmp_path, damage, line, expected):
    _, path = run_logged(tmp_path, RECOVERED)
    lines = damage(path.read_text().splitlines())
    path.write_text("\n".join(lines) + ("" if expected == "truncated record" else "\n"))
    with pytest.raises(PegbtError) as raised:
        read_tick_log(path)
    assert expected in raised.value.message
    assert raised.value.line == (len(lines) if line == "last" else line)


def test_a_failing_setup_is_logged_as_a_crash(tmp_path):
    with pytest.raises(PegbtError, match="provides no resource 'counter'"):
        run_logged(tmp_path, "blackboard: {step: 1}\ntree: {test_counting: {name: count}}")
    crash, halt, end = records(tmp_path / "run.jsonl")[-3:]
    assert crash["n"] == 0 and "PegbtError" in crash["error"] and end["outcome"] == "crash"


def test_why_shows_a_guard_that_stopped_holding_and_the_child_it_halted(tmp_path):
    result, path = run_logged(
        tmp_path,
        """
    blackboard: {safe: true}
    tree:
      parallel:
        policy: one
        children:
          - guard: {name: while safe, key: safe, child: {wait: {name: move, seconds: 5}}}
          - sequence:
              - wait: {seconds: 0.1}
              - set_blackboard: {name: collision, key: safe, value: false}
              - wait: {seconds: 5}
    """,
    )
    assert result.outcome == "failure"
    text = why(read_tick_log(path))
    assert (
        "while safe (guard) failed at t=0.200 s, tick 3: guard: /safe == True no longer holds (value False)  <- failed here"
        in text
    )
    assert "blackboard it reads: /safe=false" in text
    assert "halted child: /parallel/while safe/move (waiting 5 s)" in text
