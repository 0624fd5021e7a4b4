"""The physical bound of `pegbt bench limit`: below what pegbt's planner achieves, and exact where it can be."""

from __future__ import annotations

import math
from functools import partial

import numpy as np
import pytest
import ruckig

from pegbt.bench.limit_bound import Bound, Start, rest_to_rest, through, trial_bound, via_s
from pegbt.bench.limit_joint import reach_s
from pegbt.frames import apply_rigid
from pegbt.motion.kinematics import tip_position
from pegbt.motion.limits import ArmSettings, arm_settings


def test_rest_to_rest_is_bang_coast_bang_on_the_slowest_joint() -> None:
    settings = arm_settings("PSM1")
    start, goal = np.zeros(6), np.zeros(6)
    goal[2] = 0.1  # insertion: v 0.2 m/s, a 0.2 m/s², so it reaches v at 1 s over 0.1 m: no coast
    assert rest_to_rest(start, goal, settings) == pytest.approx(2 * math.sqrt(0.1 / 0.2), rel=1e-6)


def test_a_via_point_off_the_straight_line_costs_time() -> None:
    settings = arm_settings("PSM1")
    start, via, goal = np.zeros(6), np.zeros(6), np.zeros(6)
    goal[0], via[2] = 0.5, 0.05
    straight = rest_to_rest(start, goal, settings)
    assert through(start, [via], goal, settings) > straight
    # out along one joint and back: it must stop at the via point (passing it moving would overshoot), so
    # twice the rest-to-rest time, not two halves of a profile whose velocity jumps from +0.14 to -0.14 m/s
    # (rounded down by at most a step of the arrival times tried, 1/512 of their range)
    assert through(start, [via], start, settings) == pytest.approx(2 * 2 * math.sqrt(0.05 / 0.2), abs=3e-3)
    assert through(start, [via], start, settings) <= 2 * 2 * math.sqrt(0.05 / 0.2)


def _ruckig_s(
    start: np.ndarray, start_v: np.ndarray, goal: np.ndarray, goal_v: np.ndarray, settings: ArmSettings
) -> float | None:
    """ruckig's time-optimal duration between two states (None where it finds none)."""
    generator, inputs, trajectory = ruckig.Ruckig(6), ruckig.InputParameter(6), ruckig.Trajectory(6)
    inputs.current_position, inputs.current_velocity = start.tolist(), start_v.tolist()
    inputs.target_position, inputs.target_velocity = goal.tolist(), goal_v.tolist()
    inputs.max_velocity = settings.planner_velocity.tolist()
    inputs.max_acceleration = settings.planner_acceleration.tolist()
    inputs.max_jerk = [math.inf] * 6
    if generator.calculate(inputs, trajectory) not in (ruckig.Result.Working, ruckig.Result.Finished):
        return None
    return float(trajectory.duration)


def test_one_joints_reach_is_rucking_time_optimal_duration() -> None:
    rng = np.random.default_rng(3)
    settings = arm_settings("PSM1")
    for _ in range(50):
        distance, velocity = rng.normal() * 0.05, rng.uniform(-0.2, 0.2)
        goal, goal_v = np.zeros(6), np.zeros(6)
        goal[2], goal_v[2] = distance, velocity
        expected = _ruckig_s(np.zeros(6), np.zeros(6), goal, goal_v, settings)
        reached = reach_s(np.array([distance]), np.array([velocity]), np.array([0.2]), np.array([0.2]))
        assert reached[0] == pytest.approx(expected, abs=1e-6), (distance, velocity)


def test_a_via_point_bound_is_below_every_motion_through_it_and_above_the_velocity_jump() -> None:
    """Any velocity at the via point gives a feasible motion (two ruckig segments): the bound is below
    the quickest of those tried, and never below the bound that lets the velocity jump."""
    rng = np.random.default_rng(7)
    settings = arm_settings("PSM1")
    scale = np.array([0.3, 0.3, 0.03, 0.3, 0.3, 0.3])
    for _ in range(8):
        start, via, goal = (rng.normal(size=6) * scale for _ in range(3))
        bound = via_s(start, via, goal, settings)
        jump = 0.5 * rest_to_rest(start, 2 * via - start, settings)
        jump += 0.5 * rest_to_rest(goal, 2 * via - goal, settings)
        assert bound >= jump - 1e-9
        best = math.inf
        for fraction in np.linspace(-1.0, 1.0, 41):
            for direction in (goal - start, rng.normal(size=6)):
                velocity = np.clip(fraction * direction, -1, 1) * settings.planner_velocity
                there = _ruckig_s(start, np.zeros(6), via, velocity, settings)
                back = _ruckig_s(via, velocity, goal, np.zeros(6), settings)
                if there is not None and back is not None:
                    best = min(best, there + back)
        assert bound <= best


def test_two_arms_at_once_take_the_busier_arms_time() -> None:
    one = [("PSM1", 1, 7)]
    both = [("PSM1", 1, 7), ("PSM2", 5, 11)]
    alone, together = trial_bound(one), trial_bound(both)
    assert together.arms["PSM1"].total == pytest.approx(alone.arms["PSM1"].total)
    busiest = max(arm.total for arm in together.arms.values())
    assert together.per_transfer_s * 2 == pytest.approx(
        max(end for _, end in together.intervals) - min(start for start, _ in together.intervals)
    )
    assert together.per_transfer_s * 2 <= busiest + 0.2  # the block's fall after the last placement


def test_a_handover_waits_for_both_arms() -> None:
    handover = trial_bound([("PSM2→PSM1", 1, 7)])
    assert handover.arms["PSM1"].motion > 0 and handover.arms["PSM2"].motion > 0
    ((start, end),) = handover.intervals
    assert end - start >= handover.arms["PSM2"].total


def test_two_arms_transfers_overlapping_count_an_arms_time_once() -> None:
    from pegbt.bench.limit import merged

    assert merged([(2.0, 5.0), (0.0, 3.0), (6.0, 7.0)]) == [(0.0, 5.0), (6.0, 7.0)]


def test_the_jaw_enters_and_leaves_a_blocks_hole_along_the_peg_axis() -> None:
    bound = Bound()
    top = -bound.motion.transfer.block_top_below_peg_top
    assert bound.heights.approach == pytest.approx(top)  # the grasp is approached through the block's top
    ends, _, _ = bound.lower("PSM1", 7, lambda joints, via: 0.0)
    assert [end.exit is not None for end in ends] == [height < top for height in bound.heights.lowers]
    low = next(end for end in ends if end.exit is not None)
    aside = low.joints + np.array([0.01, 0.0, 0.0, 0.0, 0.0, 0.0])  # a few millimetres over, as low
    assert bound.reach("PSM1", [low], aside) > 2 * bound.reach("PSM1", [Start(low.joints)], aside)


def test_a_handovers_jaws_enter_and_leave_the_block_through_its_top_along_the_axis() -> None:
    """The receiver's jaw enters the held block's hole, and the giver's leaves it, through the block's top
    over each grasp (the grip `grasp_depth` below it), both tools down; the receiver grasps at the giver's point."""
    bound = Bound()
    cell, depth = bound.cell, bound.motion.transfer.grasp_depth
    exchange = bound.exchange("PSM2", "PSM1", [Start(bound.home("PSM1"))])
    in_board = {arm: cell.arm_to_board(arm) for arm in ("PSM1", "PSM2")}
    giver = apply_rigid(in_board["PSM2"], tip_position(exchange.giver))
    out = apply_rigid(in_board["PSM2"], tip_position(exchange.giver_out))
    receiver = apply_rigid(in_board["PSM1"], tip_position(exchange.receiver))
    up = np.array([0.0, 0.0, -1.0])  # board z points down
    assert out - giver == pytest.approx(depth * up, abs=1e-7)
    assert receiver == pytest.approx(giver, abs=1e-7)
    entry = bound.meeting("PSM1", bound.entry_above_grasp() or 0.0)
    assert apply_rigid(in_board["PSM1"], tip_position(entry)) - receiver == pytest.approx(
        depth * up, abs=1e-7
    )


def opening_off_the_wall_s(bound: Bound) -> float:
    """The jaw's least time from its squeeze (its tips' centre lines on the wall's faces) until its
    `jaw_radius`-round jaws clear the wall, at the jaw's velocity limit: from the geometry, not the bound."""
    block, tool = bound.cell.block, bound.cell.tool
    wall = block.edge_distance - block.hole_radius
    squeeze = 2 * math.asin(wall / 2 / tool.jaw_length)
    clear = 2 * math.asin((wall / 2 + tool.jaw_radius) / tool.jaw_length)
    assert math.degrees(squeeze) == pytest.approx(12.1, abs=0.1)
    assert math.degrees(clear) == pytest.approx(24.3, abs=0.1)
    return (clear - squeeze) / bound.settings["PSM2"].jaw_velocity


def test_the_giver_leaving_the_hole_costs_at_least_its_jaw_opening_and_then_rising_its_grip_depth() -> None:
    """Independently of the bound's via arithmetic: from rest, a joint at its acceleration limit covers a
    distance d in no less than √(2d/a) even passing it at full speed. The giver's jaw must have opened off
    the wall before its arm moves (the receiver holds the block still), and left the hole before the
    receiver may carry the block off; yet that costs no more than the opening and a rest-to-rest rise."""
    bound = Bound()
    exchange = bound.exchange("PSM2", "PSM1", [Start(bound.home("PSM1"))])
    settings = bound.settings["PSM2"]
    one_joint = np.sqrt(2 * np.abs(exchange.giver_out - exchange.giver) / settings.planner_acceleration)
    opening = opening_off_the_wall_s(bound)
    assert exchange.let_go >= opening + float(np.max(one_joint)) - 1e-9
    assert exchange.let_go <= opening + rest_to_rest(exchange.giver, exchange.giver_out, settings) + 1e-9


def test_the_giver_moves_on_only_once_the_receiver_has_closed_and_its_own_jaw_has_opened_off_the_wall() -> (
    None
):
    """The giver's next pick starts no sooner than both arms are at the meeting point (the giver after its
    approach, its close and its carry; the receiver from its start), the receiver has closed and then the
    giver's jaw has opened off the wall, one after the other: a jaw opening while the arm rises drags the
    block the receiver grips (`pegbt/sim/world.py`'s two-jaw drag)."""
    bound = Bound()
    giver, receiver, pick = "PSM2", "PSM1", 1
    trial = trial_bound([(f"{giver}→{receiver}", pick, 7), (f"{giver}→{receiver}", 0, 6)], bound)
    (first_start, _), (second_start, _) = trial.intervals
    grasp, reach = bound.approach(giver, [Start(bound.home(giver))], pick)
    exchange = bound.exchange(giver, receiver, [Start(bound.home(receiver))])
    carry = max(bound.lift_to(giver, grasp, pick, exchange.giver), bound.held_on_axis(giver, receiver, pick))
    met = max(reach + bound.jaw_close_s + carry, exchange.to_receive)
    taken = met + bound.jaw_close_s  # the receiver's close
    assert second_start - first_start >= taken + opening_off_the_wall_s(bound) - 1e-9


def test_the_receiver_enters_the_hole_through_the_blocks_top() -> None:
    """From beside its grasp, at its height, the receiver's way passes over the block's top first: more
    than twice as long as straight across (up and down again)."""
    bound = Bound()
    grasp = bound.exchange("PSM2", "PSM1", [Start(bound.home("PSM1"))]).receiver
    beside = [Start(grasp + np.array([0.01, 0.0, 0.0, 0.0, 0.0, 0.0]))]  # a millimetre or two over
    assert bound.exchange("PSM2", "PSM1", beside).to_receive > 2 * bound.reach("PSM1", beside, grasp)


def test_a_giver_is_not_free_before_its_jaw_has_opened_and_left_the_hole() -> None:
    """Two handovers by one giver: its second pick starts only once the receiver has closed on the first
    block and its own jaw has opened off the wall, leaving from where its jaw is out of that block's hole
    (dearer than leaving from the meeting point itself), and the receiver carries the first block off only
    once that jaw is out."""
    bound = Bound()
    trial = trial_bound([("PSM2→PSM1", 1, 7), ("PSM2→PSM1", 0, 6)], bound)
    (_, first_end), (second_start, _) = trial.intervals
    exchange = bound.exchange("PSM2", "PSM1", [Start(bound.home("PSM1"))])
    _, from_the_hole = bound.approach("PSM2", [Start(exchange.giver, exchange.giver_out)], 0)
    _, from_the_meeting = bound.approach("PSM2", [Start(exchange.giver)], 0)
    assert from_the_hole > from_the_meeting
    lowered = min(
        rest_to_rest(exchange.receiver, bound.joints("PSM1", 7, height), bound.settings["PSM1"])
        + bound.fall_s(height)
        for height in bound.heights.lowers
    )
    # the first block lands no sooner than the giver's jaw is out and the receiver has lowered it onto peg 7
    assert first_end - second_start >= exchange.let_go - exchange.opening + lowered - 1e-9


def test_a_block_let_go_with_its_hole_round_the_goal_peg_came_down_the_pegs_axis() -> None:
    """Below the height where the block's bottom meets the goal peg's top, the carry passes that point on
    the peg's axis first: where going straight to a lower point would be quicker (the arm's insertion
    reaches lower sooner), the bound pays for the way down the axis, and no less than the carry that lets
    go at that point itself."""
    bound = Bound()
    hanging = bound.motion.transfer.block_below_tip
    arm, pick, place = "PSM1", 0, 6
    grasp = bound.joints(arm, pick, bound.grasp_height())
    resting = bound.joints(arm, place, bound.heights.lowers[0])
    straight = bound.lift_to(arm, grasp, pick, resting)
    down_the_axis = bound.lift_to(arm, grasp, pick, resting, (bound.joints(arm, place, hanging),))
    let_go_there = bound.lift_to(arm, grasp, pick, bound.joints(arm, place, hanging)) + bound.fall_s(hanging)
    assert straight < let_go_there  # straight to the resting height: quicker than letting go over the peg
    _, carry, fall = bound.lower(arm, place, partial(bound.lift_to, arm, grasp, pick))
    assert straight < carry + fall <= let_go_there  # the old bound let go at the resting height, straight
    assert down_the_axis > straight
