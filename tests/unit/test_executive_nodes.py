"""Semantics of every node type, built from YAML and ticked through py_trees on a manual clock."""

from __future__ import annotations

import py_trees
import pytest
from executive_helpers import build_text, motion_class, node, tick_statuses
from py_trees.common import Status

from pegbt.clock import ManualClock
from pegbt.executive.guard import BlackboardGuard
from pegbt.executive.recover import Recover
from pegbt.executive.timeout import ClockTimeout

R, S, F, I = Status.RUNNING, Status.SUCCESS, Status.FAILURE, Status.INVALID


def two_children(kind: str, memory: bool, first: str, second: str) -> str:
    return f"""
    tree:
      {kind}:
        memory: {str(memory).lower()}
        children:
          - scripted: {{name: a, outcomes: {first}}}
          - scripted: {{name: b, outcomes: {second}}}
    """


def test_sequence_with_memory_resumes_at_the_running_child(tmp_path):
    built = build_text(
        tmp_path, two_children("sequence", True, "[success, failure]", "[running, running, success]")
    )
    assert tick_statuses(built, 3) == [R, R, S]


def test_sequence_without_memory_restarts_and_halts_the_running_child(tmp_path):
    built = build_text(
        tmp_path, two_children("sequence", False, "[success, failure]", "[running, running, success]")
    )
    assert tick_statuses(built, 2) == [R, F]
    assert node(built, "b").status == I


def test_selector_without_memory_prefers_a_recovered_higher_priority_child(tmp_path):
    built = build_text(tmp_path, two_children("selector", False, "[failure, success]", "[running]"))
    assert tick_statuses(built, 2) == [R, S]
    assert node(built, "b").status == I


def test_selector_with_memory_stays_with_the_running_child(tmp_path):
    built = build_text(
        tmp_path, two_children("selector", True, "[failure, success]", "[running, running, failure]")
    )
    assert tick_statuses(built, 3) == [R, R, F]


def parallel(policy: str, first: str, second: str, extra: str = "") -> str:
    return f"""
    tree:
      parallel:
        policy: {policy}
        {extra}
        children:
          - scripted: {{name: a, outcomes: {first}}}
          - scripted: {{name: b, outcomes: {second}}}
    """


def test_parallel_all_needs_every_child(tmp_path):
    built = build_text(tmp_path, parallel("all", "[success]", "[running, success]"))
    assert tick_statuses(built, 2) == [R, S]


def test_parallel_one_succeeds_with_the_first_success_and_halts_the_rest(tmp_path):
    built = build_text(tmp_path, parallel("one", "[running, success]", "[running]"))
    assert tick_statuses(built, 2) == [R, S]
    assert node(built, "b").status == I


def test_parallel_selected_waits_only_for_the_named_children(tmp_path):
    built = build_text(tmp_path, parallel("selected", "[running, success]", "[running]", "selected: [a]"))
    assert tick_statuses(built, 2) == [R, S]


def test_parallel_fails_when_any_child_fails(tmp_path):
    built = build_text(tmp_path, parallel("all", "[running, failure]", "[running]"))
    assert tick_statuses(built, 2) == [R, F]


def decorated(decorator: str, fields: str, outcomes: str) -> str:
    return f"""
    tree:
      {decorator}:
        {fields}
        child:
          scripted: {{name: child, outcomes: {outcomes}}}
    """


@pytest.mark.parametrize(
    ("decorator", "fields", "outcomes", "expected"),
    [
        ("retry", "attempts: 3", "[failure, failure, success]", [R, R, S]),
        ("retry", "attempts: 2", "[failure, failure, success]", [R, F]),
        ("repeat", "times: 3", "[success]", [R, R, S]),
        ("repeat", "times: 3", "[success, failure]", [R, F]),
        ("inverter", "", "[success, failure, running]", [F, S, R]),
        ("force_success", "", "[failure, success, running]", [S, S, R]),
        ("force_failure", "", "[success, failure, running]", [F, F, R]),
        ("oneshot", "policy: on_success", "[failure, success, failure]", [F, S, S]),
        ("oneshot", "policy: on_completion", "[failure, success]", [F, F]),
    ],
)
def test_decorator_semantics(tmp_path, decorator, fields, outcomes, expected):
    built = build_text(tmp_path, decorated(decorator, fields, outcomes))
    assert tick_statuses(built, len(expected)) == expected


def test_oneshot_does_not_tick_its_child_after_latching(tmp_path):
    built = build_text(tmp_path, decorated("oneshot", "policy: on_success", "[success, failure]"))
    tick_statuses(built, 3)
    assert node(built, "child").current_queue == [Status.FAILURE]  # the second outcome was never consumed


def test_timeout_uses_the_executive_clock_and_halts_its_child(tmp_path):
    clock = ManualClock()
    built = build_text(
        tmp_path, "tree: {timeout: {seconds: 0.25, child: {test_motion: {name: move}}}}", clock
    )
    assert isinstance(built.root, ClockTimeout)
    motion_class().terminated.clear()
    assert tick_statuses(built, 4, clock, step=0.1) == [R, R, R, F]
    assert node(built, "move").status == I
    assert motion_class().terminated == [("move", I)]


def test_timeout_passes_a_child_that_finishes_in_time(tmp_path):
    clock = ManualClock()
    built = build_text(tmp_path, "tree: {timeout: {seconds: 1.0, child: {wait: {seconds: 0.15}}}}", clock)
    assert tick_statuses(built, 3, clock, step=0.1) == [R, R, S]


def test_wait_counts_executive_clock_time_not_ticks(tmp_path):
    clock = ManualClock()
    built = build_text(tmp_path, "tree: {wait: {seconds: 1.0}}", clock)
    assert tick_statuses(built, 5) == [R] * 5
    clock.advance(1.0)
    assert tick_statuses(built, 1) == [S]


def test_guard_halts_its_child_when_the_condition_stops_holding(tmp_path):
    built = build_text(
        tmp_path,
        """
    blackboard: {safe: true}
    tree:
      guard:
        key: safe
        child: {test_motion: {name: move}}
    """,
    )
    assert isinstance(built.root, BlackboardGuard)
    motion_class().terminated.clear()
    assert tick_statuses(built, 2) == [R, R]
    py_trees.blackboard.Blackboard.set("/safe", False)
    assert tick_statuses(built, 1) == [F]
    assert node(built, "move").status == I
    assert motion_class().terminated == [("move", I)]
    assert "no longer holds" in built.root.feedback_message


def test_guard_compares_with_an_operator(tmp_path):
    built = build_text(
        tmp_path,
        """
    blackboard: {force: 0.5}
    tree: {guard: {key: force, op: "<", value: 1.0, child: {scripted: {outcomes: [running]}}}}
    """,
    )
    assert tick_statuses(built, 1) == [R]
    py_trees.blackboard.Blackboard.set("/force", 2.0)
    assert tick_statuses(built, 1) == [F]


def recover(main: str, recovery: str, retries: int) -> str:
    return f"""
    tree:
      recover:
        retries: {retries}
        main: {{scripted: {{name: main, outcomes: {main}}}}}
        recovery: {{scripted: {{name: fix, outcomes: {recovery}}}}}
    """


def test_recover_retries_main_after_its_recovery_succeeds(tmp_path):
    built = build_text(tmp_path, recover("[failure, success]", "[success]", 1))
    assert isinstance(built.root, Recover)
    assert tick_statuses(built, 1) == [S]
    assert built.root.recoveries == 1
    assert node(built, "fix").current_queue == []  # the recovery ran once


def test_recover_waits_for_a_running_recovery_then_retries(tmp_path):
    built = build_text(tmp_path, recover("[failure, running, success]", "[running, success]", 1))
    assert tick_statuses(built, 3) == [R, R, S]


def test_recover_fails_when_the_recovery_fails(tmp_path):
    built = build_text(tmp_path, recover("[failure, success]", "[failure]", 3))
    assert tick_statuses(built, 1) == [F]
    assert node(built, "main").current_queue == [S]  # main was not retried


def test_recover_gives_up_after_its_retries(tmp_path):
    built = build_text(tmp_path, recover("[failure]", "[success]", 2))
    assert tick_statuses(built, 1) == [F]
    assert built.root.recoveries == 2


def test_recover_with_no_retries_fails_like_its_main(tmp_path):
    built = build_text(tmp_path, recover("[failure]", "[success]", 0))
    assert tick_statuses(built, 1) == [F]
    assert node(built, "fix").status == I


def test_set_and_check_blackboard_and_log(tmp_path):
    built = build_text(
        tmp_path,
        """
    tree:
      sequence:
        - set_blackboard: {key: count, value: 3}
        - set_blackboard: {key: copy, value: $count}
        - check_blackboard: {key: copy, op: ">=", value: 3}
        - log: {message: copied, value: $copy}
        - check_blackboard: {key: copy, op: "<", value: 3}
    """,
    )
    assert tick_statuses(built, 1) == [F]
    assert py_trees.blackboard.Blackboard.get("/copy") == 3
    assert node(built, "log").feedback_message == "copied 3"


def test_subtree_instances_get_their_own_namespaces_and_arguments(tmp_path):
    built = build_text(
        tmp_path,
        """
    subtrees:
      mark:
        args: {arm: str, count: {type: int, default: 1}}
        tree:
          sequence:
            name: mark ${arm}
            children:
              - set_blackboard: {key: arm, value: "${arm}"}
              - set_blackboard: {key: label, value: "arm ${arm} x${count}"}
              - check_blackboard: {key: arm, value: "${arm}"}
    tree:
      sequence:
        - subtree: {use: mark, args: {arm: PSM1}}
        - subtree: {use: mark, args: {arm: PSM2, count: 2}}
    """,
    )
    assert tick_statuses(built, 1) == [S]
    assert py_trees.blackboard.Blackboard.get("/mark_PSM1/arm") == "PSM1"
    assert py_trees.blackboard.Blackboard.get("/mark_PSM2_2/label") == "arm PSM2 x2"
    instance = node(built, "mark PSM2 2")
    assert isinstance(instance, py_trees.decorators.PassThrough)
    assert instance.children[0].name == "mark PSM2"


def test_the_built_tree_is_plain_py_trees(tmp_path):
    built = build_text(
        tmp_path,
        "tree: {sequence: [{wait: {seconds: 0}}, {inverter: {child: {scripted: {outcomes: [failure]}}}}]}",
    )
    assert isinstance(built.root, py_trees.composites.Sequence)
    tree = py_trees.trees.BehaviourTree(built.root)
    tree.tick()
    assert tree.root.status == S
    assert "inverter" in py_trees.display.ascii_tree(built.root)
