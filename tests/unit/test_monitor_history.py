"""A live run's history on the monitor: a page that connects late sees what `pegbt log replay` shows after the
last tick, the run's first failure and the world, from a snapshot whose size does not grow with the run."""

from __future__ import annotations

import json
import tracemalloc
from pathlib import Path

from pegbt.bench.monitor_limits import example_records, synthetic_run
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.runoptions import RunOptions
from pegbt.executive.session import run_tree_file
from pegbt.monitor.history import History
from pegbt.monitor.replay import replay_messages

EXAMPLE = Path(__file__).resolve().parents[2] / "trees" / "example.yaml"


def page_state(texts: list[str]) -> dict:
    """What the page's RunState holds after applying every message (state.js, setBase and apply)."""
    status: list[str] = []
    feedback: list[str] = []
    blackboard: dict = {}
    failures: list[list] = []
    for message in (json.loads(text) for text in texts):
        if message["type"] == "header":
            status = ["INVALID"] * len(message["nodes"])
            feedback = [""] * len(message["nodes"])
            blackboard = dict(message.get("blackboard") or {})
        elif message["type"] == "snapshot":
            status, feedback = list(message["status"]), list(message["feedback"])
            blackboard, failures = dict(message["blackboard"]), list(message["failures"])
        elif message["type"] in ("tick", "halt", "crash", "end"):
            for node, _, after, text in message.get("changes") or ():
                status[node], feedback[node] = after, text
                if after == "FAILURE":
                    failures.append([node, message["n"]])
            blackboard.update(message.get("bb") or {})
            for key in message.get("bb_unset") or ():
                blackboard.pop(key, None)
    return {"status": status, "feedback": feedback, "blackboard": blackboard, "failures": failures}


def test_a_late_page_sees_the_last_tick_and_the_first_failure_as_the_log_has_them(tmp_path):
    log_path = tmp_path / "example.jsonl"
    run_tree_file(RunOptions(EXAMPLE, log_path, clock="manual"))
    log = read_tick_log(log_path, keep_records=True)
    history = History(window=2, world_window=1)
    for message in replay_messages(log):
        history.add(message, json.dumps(message))
    texts = history.snapshot()
    events = [record for record in log.records if record["type"] in ("tick", "end")]
    shown = page_state(texts)
    status, feedback = ["INVALID"] * len(log.nodes), [""] * len(log.nodes)
    for change in log.transitions:
        status[change.node], feedback[change.node] = change.after, change.feedback
    assert shown["status"] == status and shown["feedback"] == feedback
    assert shown["blackboard"] == json.loads(json.dumps(log.blackboard_at(log.last_n)))
    first = next(change for change in log.transitions if change.after == "FAILURE")
    assert first.n < events[-2]["n"]  # it left the window: the snapshot keeps it
    assert min(shown["failures"], key=lambda failure: failure[1])[:2] == [first.node, first.n]
    kinds = [json.loads(text)["type"] for text in texts]
    assert kinds[:3] == ["mode", "header", "snapshot"] and "causes" in kinds


def test_two_minutes_of_ticking_keep_no_more_than_twenty_seconds_did(tmp_path):
    """Both past the windows (10 s of ticks, 5 s of world samples); the whole hour is `pegbt bench
    monitor-limits` (tracing every allocation is slow)."""
    header, records = example_records(tmp_path)
    tracemalloc.start()
    try:
        history = History()
        history.add(header, json.dumps(header))
        n, _ = synthetic_run(history, 20, records)
        twenty_seconds = tracemalloc.get_traced_memory()[0]
        synthetic_run(history, 100, records, start=n)
        two_minutes = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert two_minutes < twenty_seconds * 1.1, (twenty_seconds, two_minutes)
    assert two_minutes < 1024 * 1024  # the windows and the tree's state; everything kept would be 5 MB
