"""The handover's short moves (the giver's rise, the receiver's way to the meeting and its descent) are on
its critical path: each is the time-optimal rest-to-rest move on its joint line (ruckig's duration, to a
control period), not a rest-to-rest cubic, and passes the checks every streamed trajectory passes."""

from __future__ import annotations

import numpy as np
import pytest

from pegbt.behaviours.motion import rise
from pegbt.behaviours.poses import tool_pose
from pegbt.behaviours.resources.arm_motion import ArmMotion
from pegbt.bench.limit_bound import rest_to_rest
from pegbt.motion.checks import check_trajectory
from pegbt.motion.handover import handover_meeting_point
from pegbt.motion.ik import solve_ik
from pegbt.motion.limits import arm_settings
from pegbt.motion.quickest import quickest_move, quickest_through
from pegbt.motion.settings import MOTION_SETTINGS, motion_settings
from pegbt.workcell import workcell


@pytest.fixture(scope="module")
def start() -> np.ndarray:
    settings = arm_settings("PSM1")
    return solve_ik(tool_pose(settings.home_tip, 0.0, workcell().up_in("PSM1")), settings)


def test_a_quickest_move_is_time_optimal_on_its_joint_line(start: np.ndarray) -> None:
    settings = arm_settings("PSM1")
    goal = start + np.array([0.03, -0.02, -0.008, 0.1, 0.05, -0.02])
    move = check_trajectory(quickest_move(start, goal, settings), settings, what="quickest move")
    optimum = rest_to_rest(start, goal, settings)
    assert optimum - 1e-9 <= move.duration < optimum + settings.control_period
    assert np.allclose(move.q[-1], goal) and np.allclose(move.qd[[0, -1]], 0.0)
    along = (move.q - start) @ (goal - start) / np.dot(goal - start, goal - start)
    assert np.allclose(move.q, start + along[:, None] * (goal - start), atol=1e-9)  # the straight line


@pytest.mark.parametrize("travel", [1e-15, 1e-17])
def test_a_move_of_a_rounding_error_is_a_period_at_the_goal(start: np.ndarray, travel: float) -> None:
    """A start read back from the robot a femtoradian off the goal: ruckig's limits on the fraction of the
    line overflow there (it raised, and the trial with it)."""
    settings = arm_settings("PSM1")
    goal = start.copy()
    goal[0] += travel
    move = quickest_move(start, goal, settings)
    assert move.duration == pytest.approx(settings.control_period)
    assert np.array_equal(move.q[-1], goal)


def test_moves_through_stops_rest_at_each(start: np.ndarray) -> None:
    settings = arm_settings("PSM1")
    via, goal = start + 0.01, start - 0.01
    moves = quickest_through([start, via, goal], settings)
    check_trajectory(moves, settings, what="quickest moves")
    stop = int(np.argmin(np.linalg.norm(moves.q - via, axis=1)))
    assert np.allclose(moves.q[stop], via) and np.allclose(moves.qd[stop], 0.0)


def test_the_givers_rise_takes_no_longer_than_the_time_optimal_move(start: np.ndarray) -> None:
    cell, settings = workcell(), arm_settings("PSM1")
    risen = rise(cell, ArmMotion(settings), "PSM1", start, 0.007)
    check_trajectory(risen, settings, what="rise")
    assert risen.duration < rest_to_rest(start, risen.q[-1], settings) + settings.control_period


def test_a_meeting_point_below_the_transfer_height_is_good_data(tmp_path) -> None:
    """The meeting may lie below the transfer height (`meeting_above_transfer` < 0): the held block only
    needs to clear the peg tops under it, and every millimetre up to it is insertion the giver's carry and
    approach and the receiver's carry spend."""
    text = MOTION_SETTINGS.read_text()
    line = next(row for row in text.splitlines() if row.strip().startswith("meeting_above_transfer:"))
    path = tmp_path / "motion.yaml"
    path.write_text(text.replace(line, "  meeting_above_transfer: -0.006"))
    assert motion_settings(path).handover.meeting_above_transfer == pytest.approx(-0.006)


def test_the_block_held_at_the_meeting_point_clears_the_pegs_under_it() -> None:
    cell, motion = workcell(), motion_settings()
    point = handover_meeting_point(cell, motion)
    bottom = (cell.pegs.tops[:, 2] - point[2]).min() - motion.transfer.block_below_tip  # board z is down
    assert bottom >= motion.transfer.channel_margin + motion.transfer.approach_above_block
