"""The optimised transfer passes over the pegs low, so the block's clearance over the pegs between its two
channels is planned for and checked on every set-point."""

import re
from dataclasses import replace

import numpy as np
import pytest

from pegbt.behaviours.poses import HANDOVER_RISE, approach_for, to_arm, tool_pose
from pegbt.motion.checks import CLEARANCE_SLACK, trajectory_problems
from pegbt.motion.cubic import rest_to_rest_path
from pegbt.motion.handover import handover_meeting_point
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import arm_settings
from pegbt.motion.settings import motion_settings
from pegbt.motion.transfer import TransferPlanner, joint_waypoints, lowered
from pegbt.motion.waypoints import Channel, TransferWaypoints, transfer_waypoints
from pegbt.workcell import workcell

PSM1 = arm_settings("PSM1")
CELL = workcell()
TRANSFER = motion_settings().transfer


def _waypoints(pick: int, place: int):
    tops = CELL.peg_tops_in("PSM1")
    return transfer_waypoints(tops[pick], tops[place], up=CELL.up_in("PSM1"))


def _above_peg_tops(tips: np.ndarray) -> np.ndarray:
    """Tip heights above the peg tops (the board is flat: every peg top is at the same height)."""
    top = CELL.peg_tops_in("PSM1")[0]
    return (tips - top) @ CELL.up_in("PSM1")


def _problems_of(path, waypoints):
    """What the checks find in `path` sampled at the control period, leaving and arriving as `waypoints` do."""
    return trajectory_problems(
        path.sample(PSM1.control_period),
        PSM1,
        leaving=waypoints.pick,
        arriving=waypoints.place,
        upright=waypoints.upright,
    )


def _through_middle(waypoints: TransferWaypoints, height: float) -> list[str]:
    """The clearance problems of rest-to-rest cubics through `waypoints` with a stop halfway between the
    lifted pose and the one over the goal, `height` above the peg tops."""
    q = joint_waypoints(waypoints, PSM1)
    middle = waypoints.poses[1].copy()
    middle[:3, 3] = (waypoints.poses[1][:3, 3] + waypoints.poses[2][:3, 3]) / 2
    middle[:3, 3] += (height - _above_peg_tops(middle[:3, 3])) * CELL.up_in("PSM1")
    joints = [q[0], q[1], solve_ik(middle, PSM1), q[2], q[3]]
    path = rest_to_rest_path(joints, PSM1, ["grasp", "lifted", "middle", "above", "goal"])
    problems = _problems_of(path, waypoints)
    return [problem for problem in problems if "clearing height" in problem]


@pytest.fixture(scope="module")
def planner():
    return TransferPlanner(PSM1)


@pytest.mark.parametrize(("pick", "place"), [(1, 7), (0, 6), (5, 11), (2, 9)])
def test_the_refined_transfer_carries_the_block_clear_of_the_peg_tops(planner, pick, place):
    waypoints = _waypoints(pick, place)
    plan = planner.plan(waypoints)
    assert plan.refined
    tips = forward_kinematics(plan.trajectory.q)[:, :3, 3]
    bottom = _above_peg_tops(tips) - TRANSFER.block_below_tip  # the hanging block's bottom
    off_pick = np.linalg.norm(np.cross(tips - waypoints.pick.point, waypoints.pick.axis), axis=1)
    off_place = np.linalg.norm(np.cross(tips - waypoints.place.point, waypoints.place.axis), axis=1)
    # away from both pegs' axes (more than the channel's tolerance), the block is above every peg top
    between = (off_pick > 2 * waypoints.pick.tolerance) & (off_place > 2 * waypoints.place.tolerance)
    assert between.sum() > 10
    assert bottom[between].min() >= TRANSFER.channel_margin - CLEARANCE_SLACK


def test_a_carry_sagging_between_the_pegs_is_refused_and_one_over_them_passes():
    waypoints = lowered(_waypoints(1, 7), 0.002)
    clear = TRANSFER.channel_clear_above_peg_top
    assert _through_middle(waypoints, clear + 0.002) == []
    (problem,) = _through_middle(waypoints, clear - 0.003)
    sag = float(re.search(r"sags ([0-9.]+) mm below the clearing height", problem).group(1))
    assert sag >= 3.0


def test_lowering_keeps_the_ends_and_never_raises():
    waypoints = _waypoints(1, 7)
    low = lowered(waypoints, 0.004)
    assert np.array_equal(low.poses[[0, 3]], waypoints.poses[[0, 3]])
    heights = _above_peg_tops(low.poses[1:3, :3, 3])
    assert np.allclose(heights, TRANSFER.channel_clear_above_peg_top + 0.004)
    assert np.array_equal(lowered(waypoints, 1.0).poses, waypoints.poses)


def test_an_approach_from_clear_of_the_pegs_sets_off_sideways_and_one_from_low_rises_first(planner):
    carry = planner.plan(_waypoints(1, 7)).trajectory
    pick = _waypoints(0, 6)
    released = approach_for(CELL, motion_settings(), "PSM1", forward_kinematics(carry.q[-1]), pick)
    warm = lowered(released, motion_settings().sqp.approach_above_clear)
    assert np.array_equal(warm.poses[1], warm.poses[0])
    approach = planner.plan(released, above_clear=motion_settings().sqp.approach_above_clear)
    assert approach.refined
    tips = forward_kinematics(approach.trajectory.q)[:, :3, 3]
    assert _above_peg_tops(tips[: len(tips) // 2]).min() >= _above_peg_tops(tips[0]) - CLEARANCE_SLACK
    # from among the blocks (a grasp that closed on nothing), the warm start still rises over the pegs
    low = approach_for(CELL, motion_settings(), "PSM1", _waypoints(1, 7).poses[0], pick)
    assert _above_peg_tops(lowered(low, 0.007).poses[1, :3, 3]) > _above_peg_tops(low.poses[0, :3, 3]) + 0.02


def _to_meeting(pick: int) -> TransferWaypoints:
    """A giver's carry from peg `pick` up onto the handover's meeting point (a goal in the air, which the
    block comes up onto along its axis: a channel pointing down, no floor), as `to_handover` plans it."""
    up = CELL.up_in("PSM1")
    meeting = tool_pose(to_arm(CELL, "PSM1", handover_meeting_point(CELL)), 0.0, up)
    below = meeting.copy()
    below[:3, 3] -= HANDOVER_RISE * up
    lift = _waypoints(pick, pick)
    in_the_air = Channel(meeting[:3, 3], -up, HANDOVER_RISE, TRANSFER.channel_tolerance, floor=False)
    poses = np.stack([lift.poses[0], lift.poses[1], below, meeting])
    return TransferWaypoints(poses, lift.approach, lift.pick, in_the_air, lift.upright)


@pytest.mark.parametrize("pick", [7, 6])
def test_a_carry_to_the_meeting_point_is_lifted_only_clear_of_its_peg_and_stays_above_it(planner, pick):
    waypoints = _to_meeting(pick)
    low = lowered(waypoints, 0.004)
    assert np.array_equal(low.poses[[0, 2, 3]], waypoints.poses[[0, 2, 3]])
    clear = TRANSFER.channel_clear_above_peg_top
    assert _above_peg_tops(low.poses[1, :3, 3]) == pytest.approx(clear + 0.004)
    plan = planner.plan(waypoints)
    assert plan.refined
    tips = forward_kinematics(plan.trajectory.q)[:, :3, 3]
    heights = _above_peg_tops(tips)
    cleared = int(np.argmax(heights >= clear))
    assert cleared > 0 and heights[cleared:].min() >= clear - CLEARANCE_SLACK


@pytest.mark.parametrize("pick", [7, 6])
def test_a_carry_up_onto_the_meeting_point_ends_on_its_axis_never_above_it(planner, pick):
    """The block comes up its final axis onto the meeting point (its last millimetre within the channel's
    tolerance of the axis, and never above the point), so the receiver's jaw may come down onto it; the
    checks refuse a carry that comes in sideways to the point instead."""
    waypoints = _to_meeting(pick)
    plan = planner.plan(waypoints)
    assert plan.refined
    up, meeting = CELL.up_in("PSM1"), waypoints.poses[-1][:3, 3]
    offset = forward_kinematics(plan.trajectory.q)[:, :3, 3] - meeting
    risen = offset @ up
    arrival = int(np.flatnonzero(risen <= -HANDOVER_RISE + 1e-6)[-1])
    off_axis = np.linalg.norm(offset - np.outer(risen, up), axis=1)
    assert off_axis[arrival:].max() <= TRANSFER.channel_tolerance + 1e-6
    assert risen[arrival:].max() <= 1e-6
    sideways = waypoints.poses.copy()
    sideways[2, :3, 3] = meeting + 0.003 * CELL.board_to_arm("PSM1")[:3, 0]
    path = rest_to_rest_path(joint_waypoints(replace(waypoints, poses=sideways), PSM1), PSM1)
    problems = _problems_of(path, waypoints)
    assert any("goal peg's axis" in problem for problem in problems)


def test_a_carry_to_the_air_sagging_below_its_pegs_clearing_height_on_the_way_is_refused():
    waypoints = _to_meeting(7)
    clear = TRANSFER.channel_clear_above_peg_top
    assert _through_middle(waypoints, clear + 0.002) == []
    (problem,) = _through_middle(waypoints, clear - 0.003)
    assert "below the start peg's clearing height" in problem


def test_a_jaws_way_out_of_a_held_block_is_no_floor_for_the_transit_after_it(planner):
    """A giver leaves the block it handed over up the block's axis; after that the block stays behind, so
    only the transit's own clearance over the pegs applies (a peg's channel, whose block hangs below the
    tip, would hold the tip above its clearing height all the way)."""
    up = CELL.up_in("PSM1")
    meeting = tool_pose(to_arm(CELL, "PSM1", handover_meeting_point(CELL)), 0.0, up)
    way = approach_for(CELL, motion_settings(), "PSM1", meeting, _waypoints(7, 7), out_of=0.007)
    assert way.pick is not None and not way.pick.floor
    warm = lowered(way, motion_settings().sqp.warm_above_clear)
    assert np.allclose(warm.poses[1][:3, 3], meeting[:3, 3] + 0.007 * up)  # it rises out of the hole first
    plan = planner.plan(way, above_clear=motion_settings().sqp.warm_above_clear)
    assert plan.refined
    args = {"arriving": way.place, "upright": way.upright}
    assert trajectory_problems(plan.trajectory, PSM1, leaving=way.pick, **args) == []
    as_a_peg = replace(way.pick, floor=True)
    problems = trajectory_problems(plan.trajectory, PSM1, leaving=as_a_peg, **args)
    assert any("below the clearing height" in problem for problem in problems)


def test_a_givers_way_out_widens_as_the_jaws_tips_clear_the_blocks_top(planner):
    """Off the block's axis by more than the jaw's spare round the wall, the tip is over the wall: the
    planned way out is there only once the jaw's round tips are above the block's top by the spare and as
    much again as it is off beyond it; and it uses the funnel (the cylinder of the same tolerance fails it)."""
    up = CELL.up_in("PSM1")
    meeting = tool_pose(to_arm(CELL, "PSM1", handover_meeting_point(CELL)), 0.0, up)
    way = approach_for(CELL, motion_settings(), "PSM1", meeting, _waypoints(7, 7), out_of=0.007)
    plan = planner.plan(way, above_clear=motion_settings().sqp.warm_above_clear)
    args = {"leaving": way.pick, "arriving": way.place, "upright": way.upright}
    assert plan.refined and trajectory_problems(plan.trajectory, PSM1, **args) == []
    tips = forward_kinematics(plan.trajectory.q)[:, :3, 3]
    offset = tips - meeting[:3, 3]
    risen = offset @ up
    inside = np.arange(len(risen)) < np.argmax(risen >= 0.007)  # until the jaw is out
    off_axis = np.linalg.norm(offset - np.outer(risen, up), axis=1)[inside]
    over_top = risen[inside] - CELL.block.grasp_depth - CELL.tool.jaw_radius  # the jaw tips' lowest point
    beyond_spare = off_axis - TRANSFER.channel_tolerance
    assert beyond_spare.max() > 0.0005  # it turns before it is out: the funnel is used
    over = beyond_spare > 0
    assert np.all(over_top[over] >= TRANSFER.channel_tolerance + beyond_spare[over] - 1e-6)
    cylinder = replace(way.pick, widening=0.0)
    problems = trajectory_problems(plan.trajectory, PSM1, **(args | {"leaving": cylinder}))
    assert any("start peg's axis" in problem for problem in problems)
