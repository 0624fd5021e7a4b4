"""`for_each`: a subtree run once per item of a named list; the transfer orders written once and read by
every tree, giver and receiver of the handover from the same list."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from executive_helpers import build_text, node
from py_trees.common import Status

from pegbt.cli import main
from pegbt.clock import ManualClock
from pegbt.executive.causes import failure_chains
from pegbt.executive.loader import check_tree, load_tree
from pegbt.executive.logfile import read_tick_log

REPO = Path(__file__).resolve().parents[2]

JOBS = """
lists:
  jobs: [{outcome: success, unused: 1}, {outcome: failure}, {outcome: success}]
subtrees:
  job:
    args: {outcome: {type: str, default: success}, n: int, who: str}
    tree: {scripted: {name: "job ${n} by ${who}", outcomes: ["${outcome}"], message: "job ${n} broke"}}
tree:
  for_each: {name: jobs, list: jobs, use: job, args: {who: me}, on_failure: ON_FAILURE}
"""


def _ticks_until_done(built) -> Status:
    for _ in range(10):
        built.root.tick_once()
        if built.root.status != Status.RUNNING:
            return built.root.status
    return built.root.status


def test_a_loop_that_goes_on_runs_every_item_and_succeeds(tmp_path):
    built = build_text(tmp_path, JOBS.replace("ON_FAILURE", "continue"), ManualClock())
    assert _ticks_until_done(built) == Status.SUCCESS
    statuses = [node(built, f"job {n} by me").status for n in (1, 2, 3)]
    assert statuses == [Status.SUCCESS, Status.FAILURE, Status.SUCCESS]
    assert [entry.spec.name for entry in built.nodes if entry.spec.type == "subtree"] == [
        "1: outcome success",
        "2: outcome failure",
        "3: outcome success",
    ]


def test_a_loop_that_stops_fails_with_the_item_and_runs_no_further(tmp_path):
    built = build_text(tmp_path, JOBS.replace("ON_FAILURE", "stop"), ManualClock())
    assert _ticks_until_done(built) == Status.FAILURE
    assert node(built, "job 3 by me").status == Status.INVALID


def test_log_why_tells_the_failed_item_the_loop_went_on_without(tmp_path, capsys):
    tree = tmp_path / "jobs.yaml"
    tree.write_text(JOBS.replace("ON_FAILURE", "continue"))
    log = tmp_path / "jobs.jsonl"
    assert main(["run", str(tree), "--clock", "manual", "--log", str(log), "--quiet"]) == 0
    [chain] = failure_chains(read_tick_log(log))
    assert (chain.handled, chain.by, chain.first_cause.feedback) == ("given up", "/jobs", "job 2 broke")


@pytest.mark.parametrize(
    ("loop", "message"),
    [
        ("{list: job, use: job}", "unknown list 'job' (did you mean 'jobs'?)"),
        ("{list: jobs, use: job, from: 2, to: 4}", "items 2 to 4 are not in list 'jobs' of 3 item(s)"),
        ("{list: jobs, use: jobb}", "unknown subtree 'jobb' (did you mean 'job'?)"),
    ],
)
def test_a_bad_loop_is_a_located_error(tmp_path, loop, message):
    tree = tmp_path / "bad.yaml"
    tree.write_text(
        JOBS.replace("{name: jobs, list: jobs, use: job, args: {who: me}, on_failure: ON_FAILURE}", loop)
    )
    errors = [str(error) for error in check_tree(tree)]
    assert len(errors) == 1 and errors[0].startswith(f"{tree}:9:") and message in errors[0]


def test_an_item_with_a_badly_typed_argument_is_an_error_at_the_item(tmp_path):
    tree = tmp_path / "bad.yaml"
    tree.write_text(JOBS.replace("{outcome: failure}", "{outcome: 5}").replace("ON_FAILURE", "stop"))
    errors = [str(error) for error in check_tree(tree)]
    assert any(
        error.startswith(f"{tree}:3:") and "argument 'outcome' should be a str; found 5 (int)" in error
        for error in errors
    )


def test_a_number_that_is_no_number_in_a_list_no_tree_uses_is_a_located_error(tmp_path):
    orders = tmp_path / "orders.yaml"
    orders.write_text("lists:\n  spare:\n    - {pick: 1, place: 7}\n    - {pick: .nan, place: 6}\n")
    errors = [str(error) for error in check_tree(orders)]
    assert len(errors) == 1 and errors[0].startswith(f"{orders}:4:")
    assert "pick" in errors[0] and "finite" in errors[0]


def test_an_item_position_beyond_any_count_is_refused_as_its_parameter_not_a_traceback(tmp_path):
    tree = tmp_path / "bad.yaml"
    tree.write_text(JOBS.replace("on_failure: ON_FAILURE}", "to: " + "9" * 5000 + "}"))
    errors = [str(error) for error in check_tree(tree)]
    assert len(errors) == 1 and errors[0].startswith(f"{tree}:9:") and "to" in errors[0]


def _instances(loop) -> list[dict]:
    return [child.params["args"] for child in loop.children]


def test_giver_and_receiver_of_every_handover_read_the_same_item_of_the_one_list():
    orders = yaml.safe_load((REPO / "trees" / "shared" / "orders.yaml").read_text())["lists"]["reference"]
    loaded = load_tree(REPO / "trees" / "handover.yaml")
    loops = {spec.name: spec for spec in loaded.root.walk() if spec.type == "for_each"}
    assert set(loops) == {"PSM2 gives", "PSM1 receives", "PSM1 gives", "PSM2 receives"}
    handovers = []
    for giver, receiver in (("PSM2 gives", "PSM1 receives"), ("PSM1 gives", "PSM2 receives")):
        for give, receive in zip(_instances(loops[giver]), _instances(loops[receiver]), strict=True):
            assert (give["n"], give["place"], give["strays"]) == (
                receive["n"],
                receive["place"],
                receive["strays"],
            )
            handovers.append((give["n"], give["pick"], give["place"], give["strays"]))
    assert handovers == [
        (n, item["pick"], item["place"], item.get("strays", [])) for n, item in enumerate(orders, start=1)
    ]


def test_every_tree_moves_each_block_once_out_and_once_back():
    for name in ("unilateral", "bilateral", "handover"):
        loaded = load_tree(REPO / "trees" / f"{name}.yaml")
        moves = [
            (spec.params["pick"], spec.params["place"])
            for spec in loaded.root.walk()
            if spec.type == "begin_transfer"
        ]
        assert sorted(pick for pick, _ in moves[:6]) == [0, 1, 2, 3, 4, 5], name
        assert sorted(pick for pick, _ in moves) == list(range(12)), name
        assert sorted(place for _, place in moves) == list(range(12)), name
