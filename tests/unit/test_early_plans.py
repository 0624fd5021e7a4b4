"""Plans made ahead of their motion and checked as they are sent (`ArmMotion.plan_early`, `stale`), against
the in-memory robot of `fake_arm`: the carry planned while the approach plays is the one sent; a plan
made from a state the arm has left (a late hold, inputs seen again) is made again, never sent; a motion
aborted by a late hold does not make every later plan start where that motion never arrived."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import py_trees
import pytest
from executive_helpers import write_tree
from fake_arm import FakeArm, fake_robot
from py_trees.common import Status

from pegbt.behaviours import motion as shared_motion
from pegbt.behaviours.actions.handover import way_to_wait
from pegbt.behaviours.meeting import meeting_tip, plan_meeting
from pegbt.behaviours.poses import transfer_for
from pegbt.behaviours.resources.robot import Robot
from pegbt.behaviours.resources.skills import Skills
from pegbt.clock import ManualClock
from pegbt.executive.build import BuiltTree
from pegbt.executive.context import RunContext
from pegbt.executive.loader import load_tree
from pegbt.executive.runner import set_initial_blackboard
from pegbt.executive.work import Job, WorkPool
from pegbt.handover_protocol import Giver, Handover, Receiver
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics
from pegbt.perception.blocks import block_on_peg
from pegbt.sim.camera import DepthCamera
from pegbt.sim.world import World

STEP = 0.05  # s of clock between ticks
PICK, PLACE = 1, 7
APPROACH = "{approach: {arm: PSM1, block: /PSM1/block, grasp: /PSM1/grasp}}"
PICK_AND_CARRY = f"""
  sequence:
    children:
      - begin_transfer: {{arms: PSM1, pick: {PICK}, place: {PLACE}, transfer: /n}}
      - approach: {{arm: PSM1, block: /PSM1/block, grasp: /PSM1/grasp}}
      - grasp: {{arm: PSM1, holding: /PSM1/holding}}
      - transfer: {{arm: PSM1, place: {PLACE}, block: /PSM1/block, grasp: /PSM1/grasp, plan_s: /PSM1/plan_s}}
"""


class GatedPool(WorkPool):
    """Worker threads whose jobs start only once the test opens the gate: what a tick finds is decided
    by the test, not by how fast a thread runs."""

    def __init__(self, clock: ManualClock) -> None:
        super().__init__()
        self.gate = threading.Event()
        self.gate.set()
        self.clock = clock
        self.submitted: list[float] = []  # the clock time of each job's submission

    def submit(self, fn: Callable[..., Any], *args: Any) -> Job[Any]:
        return super().submit(self._gated(fn), *args)

    def submit_ahead(self, fn: Callable[..., Any], *args: Any) -> Job[Any]:
        return super().submit_ahead(self._gated(fn), *args)

    def _gated(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        def gated(*inner: Any) -> Any:
            assert self.gate.wait(10.0), "the test never opened the gate"
            return fn(*inner)

        gated.__qualname__ = getattr(fn, "func", fn).__qualname__
        self.submitted.append(self.clock.now())
        return gated

    def settle(self) -> None:
        """Wait (bounded) until every job submitted has ended."""
        deadline = time.monotonic() + 10.0
        while self.pending():
            assert time.monotonic() < deadline, "a job did not end"
            time.sleep(0.001)


@pytest.fixture(scope="module")
def seen():
    skills = Skills("uncalibrated")
    cloud = DepthCamera(seed=0).capture(World(seed=0))
    board = skills.registration.fit(cloud)
    assert board.ok, board.reason
    return board, skills.locator.locate(cloud, board)


@pytest.fixture
def skills() -> Skills:
    return Skills("uncalibrated")


@pytest.fixture
def clock() -> ManualClock:
    return ManualClock()


@pytest.fixture
def robot(clock, skills) -> Robot:
    return fake_robot(clock, skills.settings, skills.cell)


@pytest.fixture(autouse=True)
def fresh_blackboard():
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def chosen(skills: Skills, seen) -> dict[str, object]:
    block = block_on_peg(seen[1], PICK)
    grasp = skills.selectors["PSM1"].pick(block)
    return {"/board": seen[0], "/blocks": seen[1], "/PSM1/block": block, "/PSM1/grasp": grasp}


def build(tmp_path: Path, robot: Robot, skills: Skills, tree: str, pool: WorkPool, values: dict) -> BuiltTree:
    context = RunContext(clock=robot.trial.clock, resources={"robot": robot, "skills": skills}, work=pool)
    declared = "".join(f"  {key}: null\n" for key in values)
    built = load_tree(write_tree(tmp_path, f"blackboard:\n{declared}tree: {tree}\n")).build(context)
    set_initial_blackboard(built)
    for key, value in values.items():
        py_trees.blackboard.Blackboard.set(key, value)
    built.root.setup_with_descendants()
    return built


def run(built: BuiltTree, clock: ManualClock, pool: WorkPool, seconds: float = 30.0) -> Status:
    """Tick every `STEP` of the clock until the tree ends (at most `seconds`), letting open jobs end first."""
    end = clock.now() + seconds
    while True:
        built.root.tick_once()
        if built.root.status != Status.RUNNING or clock.now() >= end:
            return built.root.status
        if isinstance(pool, GatedPool) and pool.gate.is_set():
            pool.settle()
        clock.advance(STEP)


def psm1(robot: Robot) -> FakeArm:
    arm = robot.arms["PSM1"]
    assert isinstance(arm, FakeArm)
    return arm


def test_the_carry_planned_while_the_approach_plays_is_the_one_sent(tmp_path, robot, skills, seen, clock):
    pool = GatedPool(clock)
    arm = psm1(robot)
    arm.block_in_jaw = True
    built = build(tmp_path, robot, skills, PICK_AND_CARRY, pool, chosen(skills, seen))
    assert run(built, clock, pool) == Status.SUCCESS
    approach, carry = (sent for sent in arm.sent if sent.kind == "trajectory")
    assert np.allclose(carry.target.q[0], approach.target.q[-1])
    # the carry's plan made as the approach was sent: it did not wait for the approach and the grasp
    assert pool.submitted == [0.0, approach.at]
    assert pool.stats.by_kind["prepare_all"][0] == 2


def test_a_carry_planned_early_from_a_block_seen_again_is_planned_anew(tmp_path, robot, skills, seen, clock):
    pool = GatedPool(clock)
    arm = psm1(robot)
    arm.block_in_jaw = True
    values = chosen(skills, seen)
    built = build(tmp_path, robot, skills, PICK_AND_CARRY, pool, values)
    assert run(built, clock, pool, seconds=0.2) == Status.RUNNING  # approaching
    early = skills.arm("PSM1").early
    assert early is not None
    block = values["/PSM1/block"]
    py_trees.blackboard.Blackboard.set(
        "/PSM1/block", type(block)(**vars(block))
    )  # seen again: a new estimate
    assert run(built, clock, pool) == Status.SUCCESS
    assert early.job.discarded
    assert len(pool.submitted) == 3 and pool.submitted[2] > 1.0  # the carry made anew once the grasp held


def test_a_plan_the_arm_has_moved_away_from_is_made_again_from_where_it_is(
    tmp_path, robot, skills, seen, clock
):
    pool = GatedPool(clock)
    arm = psm1(robot)
    built = build(tmp_path, robot, skills, APPROACH, pool, chosen(skills, seen))
    pool.gate.clear()
    assert run(built, clock, pool, seconds=0.0) == Status.RUNNING  # planning from where the arm rests
    moved = arm.rest.copy()
    moved[0] += 0.05  # a late hold left the arm elsewhere while the plan was made
    arm.rest = moved
    pool.gate.set()
    pool.settle()
    assert run(built, clock, pool) == Status.SUCCESS
    (sent,) = arm.trajectories
    assert np.allclose(sent.q[0], moved)


def test_a_motion_aborted_by_a_late_hold_does_not_poison_the_next(tmp_path, robot, skills, seen, clock):
    """The order seen once under load: the hold that stopped a failed carry reached the robot after the next
    approach had started, and aborted it; every plan after that started where that approach would have
    ended, and the robot refused each ("trajectory start")."""
    pool = WorkPool(inline=True)
    arm = psm1(robot)
    values = chosen(skills, seen)
    first = build(tmp_path, robot, skills, APPROACH, pool, values)
    assert run(first, clock, pool, seconds=0.5) == Status.RUNNING
    arm.hold()  # the late hold
    held = arm.rest.copy()
    assert run(first, clock, pool) == Status.FAILURE
    again = build(tmp_path, robot, skills, APPROACH, pool, values)  # pick again
    assert run(again, clock, pool) == Status.SUCCESS, again.root.feedback_message
    assert np.allclose(arm.trajectories[-1].q[0], held)


LOOP = f"""
lists:
  two: [{{pick: {PICK}, place: {PLACE}}}, {{pick: 0, place: 6}}]
subtrees:
  one:
    args:
      pick: {{type: int, doc: start peg}}
      place: {{type: int, doc: goal peg}}
      next: {{type: any, default: {{}}, doc: the next item}}
    tree:
      sequence:
        children:
          - begin_transfer: {{arms: PSM1, pick: "${{pick}}", place: "${{place}}", transfer: /n}}
          - select_grasp: {{arm: PSM1, peg: "${{pick}}", block: /PSM1/block, grasp: /PSM1/grasp}}
          - approach: {{arm: PSM1, block: /PSM1/block, grasp: /PSM1/grasp}}
          - grasp: {{arm: PSM1, holding: /PSM1/holding}}
          - transfer: {{arm: PSM1, place: "${{place}}", block: /PSM1/block, grasp: /PSM1/grasp, plan_s: /PSM1/plan_s, then: "${{next}}"}}
          - release: {{arm: PSM1, holding: /PSM1/holding}}
"""


def _run_two_loops(tmp_path, robot, skills, seen, clock, pool) -> None:
    """Two blocks through the loop's approach and carry, the board seen once, to success."""
    context = RunContext(clock=clock, resources={"robot": robot, "skills": skills}, work=pool)
    text = (
        f"blackboard: {{/board: null, /blocks: null}}\n{LOOP}\ntree: {{for_each: {{list: two, use: one}}}}\n"
    )
    built = load_tree(write_tree(tmp_path, text)).build(context)
    set_initial_blackboard(built)
    py_trees.blackboard.Blackboard.set("/board", seen[0])
    py_trees.blackboard.Blackboard.set("/blocks", seen[1])
    built.root.setup_with_descendants()
    assert run(built, clock, pool, seconds=60.0) == Status.SUCCESS, built.root.feedback_message


def test_the_next_blocks_approach_is_planned_while_this_carry_plays(tmp_path, robot, skills, seen, clock):
    pool = GatedPool(clock)
    arm = psm1(robot)
    arm.block_in_jaw = True
    _run_two_loops(tmp_path, robot, skills, seen, clock, pool)
    approach, carry, approach_again, carry_again = (sent for sent in arm.sent if sent.kind == "trajectory")
    assert np.allclose(approach_again.target.q[0], carry.target.q[-1])
    # each plan made as the motion before it was sent: the second approach while the first carry played
    assert pool.submitted == [0.0, approach.at, carry.at, approach_again.at]


def test_an_approach_planned_early_is_sent_with_none_of_its_waypoints_computed_on_the_tick(
    tmp_path, robot, skills, seen, clock, monkeypatch
):
    """The tick that sends an approach (or the carry's tick that plans the next one early) used to compute
    the approach's waypoints and its stops above the pegs (inverse kinematics) before the motion left,
    though the plan made early needed none of it."""
    on_the_tick = []
    stops = shared_motion.above_pegs_first

    def counted(*args: Any, **kwargs: Any) -> Any:
        on_the_tick.append(threading.current_thread() is threading.main_thread())
        return stops(*args, **kwargs)

    monkeypatch.setattr(shared_motion, "above_pegs_first", counted)
    pool = GatedPool(clock)
    psm1(robot).block_in_jaw = True
    _run_two_loops(tmp_path, robot, skills, seen, clock, pool)
    assert on_the_tick == [False, False]  # the first approach's plan and the second's, made early


GIVE = f"""
  sequence:
    children:
      - begin_transfer: {{arms: "PSM1→PSM2", pick: {PICK}, place: {PLACE}, transfer: /n}}
      - approach: {{arm: PSM1, block: /PSM1/block, grasp: /PSM1/grasp}}
      - grasp: {{arm: PSM1, holding: /PSM1/holding}}
      - handover_poses: {{arm: PSM1, receiver: PSM2, grasp: /PSM1/grasp, block: /PSM1/block, meeting: /meeting, block_pose: /block_pose, receiver_grasp: /receiver_grasp}}
      - wait: {{seconds: 1.0}}  # for the receiver to be ready
      - carry_to_handover: {{arm: PSM1, grasp: /PSM1/grasp, block: /PSM1/block, meeting: /meeting, plan_s: /PSM1/plan_s}}
"""


def test_the_givers_carry_is_planned_as_its_approach_is_sent(tmp_path, robot, skills, seen, clock):
    """In a handover the meeting tip is fixed, so the giver's carry to it is prepared while the approach and
    the grasp play, from where the approach ends; planning the meeting keeps that plan (the same inputs,
    the tip computed again equal), and it is the one sent."""
    pool = GatedPool(clock)
    arm = psm1(robot)
    arm.block_in_jaw = True
    values = chosen(skills, seen) | {"/meeting": None, "/block_pose": None, "/receiver_grasp": None}
    built = build(tmp_path, robot, skills, GIVE, pool, values)
    assert run(built, clock, pool) == Status.SUCCESS, built.root.feedback_message
    approach, carry = (sent for sent in arm.sent if sent.kind == "trajectory")
    assert np.allclose(carry.target.q[0], approach.target.q[-1])
    assert pool.stats.by_kind["prepare_all"][0] == 2  # the approach, and the carry once: made early
    assert pool.submitted[:2] == [0.0, approach.at]  # the carry's plan began as the approach was sent
    assert pool.stats.by_kind["plan_meeting"][0] == 1  # the meeting too, taken by `handover_poses`
    assert "HandoverPoses.compute" not in pool.stats.by_kind


RISE_THEN_PICK = f"""
  sequence:
    children:
      - rise: {{arm: PSM1, height: 0.01, keep_apart: 0.0, then: {{pick: {PICK}}}, handover_to: PSM2}}
      - select_grasp: {{arm: PSM1, peg: {PICK}, handover_to: PSM2, block: /PSM1/block, grasp: /PSM1/grasp}}
      - approach: {{arm: PSM1, block: /PSM1/block, grasp: /PSM1/grasp}}
"""


def test_a_givers_next_grasp_and_approach_are_chosen_and_planned_while_it_rises(
    tmp_path, robot, skills, seen, clock
):
    """After letting go, a giver chose its next block's grasp (a clearance sweep per candidate) and only
    then planned the approach to it, while it stood still: both are now made while it rises, and they are
    the grasp and the approach `select_grasp` and `approach` would have made."""
    pool = GatedPool(clock)
    arm = psm1(robot)
    values = {"/board": seen[0], "/blocks": seen[1], "/PSM1/block": None, "/PSM1/grasp": None}
    built = build(tmp_path, robot, skills, RISE_THEN_PICK, pool, values)
    assert run(built, clock, pool) == Status.SUCCESS, built.root.feedback_message
    rise, approach = (sent for sent in arm.sent if sent.kind == "trajectory")
    assert np.allclose(approach.target.q[0], rise.target.q[-1])
    assert pool.submitted == [0.0, rise.at]  # the rise, then grasp and approach together as it was sent
    assert "GraspSelector.pick" not in pool.stats.by_kind
    block = block_on_peg(seen[1], PICK)
    expected = skills.selectors["PSM1"].pick(
        block, acceptable=lambda option: plan_meeting(skills, "PSM1", "PSM2", option, block) is not None
    )
    grasp = py_trees.blackboard.Blackboard.get("/PSM1/grasp")
    assert expected is not None and grasp.candidate == expected.candidate


OFFERED = Handover(1, receiver=Receiver.READY).said(Giver.OFFERED)  # the giver on its way to the meeting
RECEIVE = """
  sequence:
    children:
      - go_to_handover: {arm: PSM1, grasp: /receiver_grasp}
      - descend_to_grasp: {arm: PSM1, grasp: /receiver_grasp, block_pose: /block_pose, n: 1}
"""


def test_the_receivers_descent_is_planned_while_it_goes_to_wait_above_the_grasp(
    tmp_path, robot, skills, seen, clock
):
    """The receiver's descent onto its grasp was planned only once it waited above it, with the giver
    arrived: it is now planned as the receiver sets off, and that plan is the one sent."""
    pool = GatedPool(clock)
    arm = psm1(robot)
    block = block_on_peg(seen[1], PICK)
    giver_grasp = skills.selectors["PSM2"].pick(block)
    meeting = plan_meeting(skills, "PSM2", "PSM1", giver_grasp, block)
    assert meeting is not None
    values = {
        "/board": seen[0],
        "/receiver_grasp": meeting.receiver_grasp,
        "/block_pose": meeting.block_pose,
        "/handover/state_1": OFFERED,
    }
    built = build(tmp_path, robot, skills, RECEIVE, pool, values)
    assert run(built, clock, pool) == Status.SUCCESS, built.root.feedback_message
    wait, descent = (sent for sent in arm.sent if sent.kind == "trajectory")
    assert np.allclose(descent.target.q[0], wait.target.q[-1])
    assert pool.submitted == [0.0, wait.at]  # the descent's plan began as the receiver set off
    assert pool.stats.by_kind["prepare_all"][0] == 2


def test_a_motion_the_other_arm_blocks_is_tried_again_with_its_plan_not_planned_anew(
    tmp_path, robot, skills, seen, clock, monkeypatch
):
    """While the other arm is in the way, a blocked motion was planned and pre-compensated again every
    retry (0.1 s) although this arm had not moved; the plan is now kept and checked again as it is sent."""
    pool = WorkPool(inline=True)
    monkeypatch.setattr(skills, "clearances", lambda *args: np.zeros(3))  # the other arm's tool is in the way
    tree = "{rise: {arm: PSM1, height: 0.01, keep_apart: 0.05}}"
    built = build(tmp_path, robot, skills, tree, pool, {"/board": seen[0]})
    assert run(built, clock, pool, seconds=1.0) == Status.RUNNING
    assert "would bring the tools within" in built.root.feedback_message
    assert pool.stats.by_kind["prepare_all"][0] == 1  # ten tries, one plan
    assert not psm1(robot).trajectories


def test_a_givers_rise_is_planned_while_it_carries_the_block_to_the_meeting_point(
    tmp_path, robot, skills, seen, clock
):
    """The receiver carries the block away only once the giver has let go and risen: the rise was planned
    when it began, with the receiver waiting; it is now planned as the carry is sent, and that plan is the
    one sent."""
    pool = GatedPool(clock)
    arm = psm1(robot)
    arm.block_in_jaw = True
    tree = (
        GIVE.replace("plan_s: /PSM1/plan_s}", "plan_s: /PSM1/plan_s, rise: 0.01}")
        + (
            "      - release: {arm: PSM1, holding: /PSM1/holding}\n"
            "      - rise: {arm: PSM1, height: 0.01, keep_apart: 0.0, handover_to: PSM2}\n"
        )
    )  # as `trees/shared/handover.yaml`'s giver rises: the carry plans the rise that leaf sends (`rise_extent`)
    values = chosen(skills, seen) | {"/meeting": None, "/block_pose": None, "/receiver_grasp": None}
    built = build(tmp_path, robot, skills, tree, pool, values)
    assert run(built, clock, pool) == Status.SUCCESS, built.root.feedback_message
    approach, carry, risen = (sent for sent in arm.sent if sent.kind == "trajectory")
    assert np.allclose(risen.target.q[0], carry.target.q[-1])
    assert pool.stats.by_kind["prepare_all"][0] == 3  # approach, carry, rise: each once
    assert (
        pool.submitted[-1] == carry.at < risen.at
    )  # the rise's plan, the last job, began as the carry was sent


HAND_OVER_AGAIN = f"""
  sequence:
    children:
      - begin_transfer: {{arms: "PSM1→PSM2", pick: {PICK}, place: {PLACE}, transfer: /n}}
      - go_to_handover: {{arm: PSM2, grasp: /last_grasp}}
      - descend_to_grasp: {{arm: PSM2, grasp: /last_grasp, block_pose: /last_block_pose, n: 1}}
      - approach: {{arm: PSM1, block: /PSM1/block, grasp: /PSM1/grasp, keep_apart: 0.0}}
      - carry_from_handover: {{arm: PSM2, place: 8, grasp: /last_grasp, block_pose: /last_block_pose, plan_s: /PSM2/plan_s}}
      - grasp: {{arm: PSM1, holding: /PSM1/holding}}
      - handover_poses: {{arm: PSM1, receiver: PSM2, grasp: /PSM1/grasp, block: /PSM1/block, meeting: /meeting, block_pose: /block_pose, receiver_grasp: /receiver_grasp}}
      - go_to_handover: {{arm: PSM2, grasp: /receiver_grasp}}
"""


def test_the_receivers_way_to_the_next_meeting_is_planned_while_it_carries_the_last_block(
    tmp_path, robot, skills, seen, clock
):
    """The receiver went to wait above its grasp only once the giver held the block and the meeting was
    planned, and planned that way then (its way and descent are the handover's critical path). The meeting
    is now computed as the giver's approach is sent, the way planned from it while the receiver carries its
    last block, and that is the plan sent, to where planning it then would have gone."""
    pool = GatedPool(clock)
    giver, receiver = psm1(robot), robot.arms["PSM2"]
    assert isinstance(receiver, FakeArm)
    giver.block_in_jaw = receiver.block_in_jaw = True
    last = block_on_peg(seen[1], 3)
    last_meeting = plan_meeting(skills, "PSM1", "PSM2", skills.selectors["PSM1"].pick(last), last)
    assert last_meeting is not None
    values = chosen(skills, seen) | {
        "/meeting": None,
        "/block_pose": None,
        "/receiver_grasp": None,
        "/last_grasp": last_meeting.receiver_grasp,
        "/last_block_pose": last_meeting.block_pose,
        "/handover/state_1": OFFERED,
    }
    built = build(tmp_path, robot, skills, HAND_OVER_AGAIN, pool, values)
    assert run(built, clock, pool) == Status.SUCCESS, built.root.feedback_message
    *_, carry, way = (sent for sent in receiver.sent if sent.kind == "trajectory")
    assert (
        way.at > carry.at and carry.at in pool.submitted
    )  # planned as the carry was sent, not as it set off
    assert "HandoverPoses.compute" not in pool.stats.by_kind  # the meeting computed early was taken
    assert pool.stats.by_kind["plan_meeting"][0] == 1
    grasp = py_trees.blackboard.Blackboard.get("/receiver_grasp")
    expected = way_to_wait(skills, skills.arm("PSM2"), "PSM2", carry.target.q[-1], grasp)
    assert np.allclose(way.target.q, expected.q)


FIRST_HANDOVER = f"""
  sequence:
    children:
      - begin_transfer: {{arms: "PSM1→PSM2", pick: {PICK}, place: {PLACE}, transfer: /n}}
      - approach: {{arm: PSM1, block: /PSM1/block, grasp: /PSM1/grasp, keep_apart: 0.0}}
      - grasp: {{arm: PSM1, holding: /PSM1/holding}}
      - handover_poses: {{arm: PSM1, receiver: PSM2, grasp: /PSM1/grasp, block: /PSM1/block, meeting: /meeting, block_pose: /block_pose, receiver_grasp: /receiver_grasp}}
      - go_to_handover: {{arm: PSM2, grasp: /receiver_grasp, keep_apart: 0.0}}
"""


def test_a_receiver_with_nothing_to_carry_plans_its_way_to_the_meeting_as_the_givers_approach_is_sent(
    tmp_path, robot, skills, seen, clock
):
    """The first handover after a look has no carry before the receiver's way to the meeting: that way
    was planned only as it began, on the handover's critical path. It is now planned from where the
    receiver rests as the giver's approach is sent (with the meeting), and is the plan sent."""
    pool = GatedPool(clock)
    giver, receiver = psm1(robot), robot.arms["PSM2"]
    assert isinstance(receiver, FakeArm)
    giver.block_in_jaw = True
    values = chosen(skills, seen) | {"/meeting": None, "/block_pose": None, "/receiver_grasp": None}
    built = build(tmp_path, robot, skills, FIRST_HANDOVER, pool, values)
    resting = receiver.rest.copy()
    assert run(built, clock, pool) == Status.SUCCESS, built.root.feedback_message
    approach = next(sent for sent in giver.sent if sent.kind == "trajectory")
    (way,) = (sent for sent in receiver.sent if sent.kind == "trajectory")
    assert set(pool.submitted) == {0.0, approach.at, way.at}  # the last: the descent's plan
    grasp = py_trees.blackboard.Blackboard.get("/receiver_grasp")
    expected = way_to_wait(skills, skills.arm("PSM2"), "PSM2", resting, grasp)
    assert np.allclose(way.target.q, expected.q)


CARRY_THEN_GO = f"""
  sequence:
    children:
      - begin_transfer: {{arms: "PSM1→PSM2", pick: {PICK}, place: {PLACE}, transfer: /n}}
      - carry_to_handover: {{arm: PSM1, grasp: /PSM1/grasp, block: /PSM1/block, meeting: /meeting, plan_s: /PSM1/plan_s, rise: 0.007, then: {{pick: {PICK}}}}}
      - release: {{arm: PSM1, holding: /PSM1/holding}}
      - rise: {{arm: PSM1, height: 0.007, keep_apart: 0.0, then: {{pick: {PICK}}}, handover_to: PSM2}}
"""


def test_a_givers_way_out_into_its_next_approach_is_planned_as_its_carry_is_sent(tmp_path, seen, clock):
    """With a planner, the giver's rise after the handover goes on into its next approach; planning that
    (the next grasp's clearance sweeps and the approach) when the rise began put it on the handover's
    critical path in real time. It is planned as the carry to the meeting point is sent, and the rise
    sends that plan."""
    skills = Skills("optimized")
    skills.arm("PSM1").compensator = None  # the fake arm goes where it is sent: no cable error to correct
    robot = fake_robot(clock, skills.settings, skills.cell)
    arm = psm1(robot)
    values = chosen(skills, seen)
    block, grasp = values["/PSM1/block"], values["/PSM1/grasp"]
    start = transfer_for(skills.cell, skills.motion, "PSM1", seen[0], block, grasp).poses[0]
    arm.rest = solve_ik(start, skills.settings["PSM1"])  # where its approach and grasp left it
    arm.block_in_jaw = True
    values |= {"/meeting": meeting_tip(skills, "PSM1"), "/PSM1/holding": True}
    pool = GatedPool(clock)
    built = build(tmp_path, robot, skills, CARRY_THEN_GO, pool, values)
    status = run(built, clock, pool)
    assert status == Status.SUCCESS, "; ".join(
        f"{n.name}: {n.feedback_message}" for n in built.root.iterate()
    )
    carry, way = (sent for sent in arm.sent if sent.kind == "trajectory")
    assert np.allclose(way.target.q[0], carry.target.q[-1])
    assert pool.submitted == [
        0.0,
        carry.at,
    ]  # the carry, then the way out as it was sent: nothing at the rise
    expected = skills.selectors["PSM1"].pick(
        block, acceptable=lambda option: plan_meeting(skills, "PSM1", "PSM2", option, block) is not None
    )
    assert np.allclose(forward_kinematics(way.target.q[-1]), expected.pose, atol=1e-4)
