"""Optimised approach moves that turn the jaw keep the goal channel and the upright cone (rest-to-rest
cubics, the fallback, break both), and the planner's answer is always checked."""

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.evaluation.campaign import Cell
from pegbt.evaluation.summary import summarise, table
from pegbt.evaluation.trial import TrialRecord
from pegbt.frames import rigid_transform
from pegbt.motion.channel import Channel, Upright
from pegbt.motion.checks import trajectory_problems
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import arm_settings
from pegbt.motion.settings import motion_settings
from pegbt.motion.straighten import upright_configurations
from pegbt.motion.transfer import TransferPlanner, cubic_transfer
from pegbt.motion.waypoints import TransferWaypoints, tool_down_rotation
from pegbt.workcell import workcell

CELL = workcell()
HEIGHTS = motion_settings().transfer
DESCENT_CLEAR = 0.0146  # the approach's channel: from just above the peg tops down onto the grasp

# Approaches of `pegbt eval --condition optimized --workers 1` that fell back to cubics, the first the
# example of unilateral seed 1, the others of bilateral seed 1: (arm, tip positions of the start, risen,
# above-the-grasp and grasp poses (m, arm frame), start yaw, grasp yaw (rad about the pegs' axis)).
# The jaw turns by 74-103° on the way. Planned by a fresh planner (OSQP's duals then start at zero).
APPROACHES = [
    (
        "PSM1",
        [
            [0.16799762263703322, -0.018960862881196815, -0.14185287829418916],
            [0.16840429239930418, -0.01894116699638206, -0.12385748355618531],
            [0.09110364657253388, -0.010308307804182557, -0.12212004995627301],
            [0.09025415862467895, -0.01034945031912894, -0.15971043007565877],
        ],
        0.12276141955002626,
        -1.1775618799733745,
    ),
    (
        "PSM1",
        [
            [0.08971706773452984, -0.01138846463326567, -0.14009213950349947],
            [0.09012373749680082, -0.011368768748450912, -0.12209674476549551],
            [0.1404721739007515, -0.006083209740057871, -0.12324033126215964],
            [0.13962268595289656, -0.0061243522550042525, -0.16083071138154542],
        ],
        -0.8734632381563885,
        0.9076687460457958,
    ),
    (
        "PSM2",
        [
            [-0.1457604516007266, -0.031726972237213685, -0.1362291840400642],
            [-0.14629021006314236, -0.03186715981204851, -0.11823752754558434],
            [-0.08248111580126509, -0.002233164451368483, -0.11612778708793157],
            [-0.08137450923532992, -0.0019403281839357324, -0.15371035843195627],
        ],
        -0.6178286932163419,
        0.7272834775790449,
    ),
]


def _approach(arm, tips, start_yaw, grasp_yaw):
    up = CELL.up_in(arm)
    yaws = (start_yaw, start_yaw, grasp_yaw, grasp_yaw)
    poses = np.stack([rigid_transform(tool_down_rotation(yaw, up), tip) for yaw, tip in zip(yaws, tips)])
    return TransferWaypoints(
        poses,
        None,
        None,
        Channel(tips[3], up, DESCENT_CLEAR, HEIGHTS.channel_tolerance),
        Upright(up, HEIGHTS.upright_tilt),
    )


@pytest.mark.parametrize("arm, tips, start_yaw, grasp_yaw", APPROACHES)
def test_an_approach_turning_the_jaw_is_refined_within_the_channel_and_the_upright_cone(
    arm, tips, start_yaw, grasp_yaw
):
    waypoints = _approach(arm, tips, start_yaw, grasp_yaw)
    settings = arm_settings(arm)
    plan = TransferPlanner(settings).plan(waypoints)
    assert plan.method == "sqp" and plan.reason == ""
    trajectory = plan.trajectory
    assert (
        trajectory_problems(trajectory, settings, arriving=waypoints.place, upright=waypoints.upright) == []
    )
    # Independently of the checker: the tool leans at most 2° all along, and below the clearing height
    # the tip is within 0.5 mm of the grasp's axis.
    poses = forward_kinematics(trajectory.q)
    assert np.degrees(waypoints.upright.tilt(poses[:, :3, 2])).max() <= 2.0 + 1e-6
    tips_now = poses[:, :3, 3]
    entered = int(np.flatnonzero(waypoints.place.height(tips_now) >= DESCENT_CLEAR)[-1]) + 1
    assert waypoints.place.distance(tips_now[entered:]).max() <= 0.0005
    assert np.allclose(poses[-1], waypoints.poses[3], atol=1e-9)
    # Faster than the paper's unoptimised cubics, which here leave the cone (and the channel).
    cubic = cubic_transfer(waypoints, settings)
    assert trajectory.duration < 0.8 * cubic.duration
    assert trajectory_problems(cubic, settings, arriving=waypoints.place, upright=waypoints.upright) != []


def test_configurations_turned_upright_keep_their_tip_and_heading():
    settings = arm_settings("PSM1")
    up = CELL.up_in("PSM1")
    rng = np.random.default_rng(3)
    q = rng.uniform([-0.6, -0.5, 0.12, -1.5, -0.4, -0.4], [0.6, 0.5, 0.2, 1.5, 0.4, 0.4], size=(50, 6))
    turned = upright_configurations(q, settings, Upright(up, HEIGHTS.upright_tilt))
    before, after = forward_kinematics(q), forward_kinematics(turned)
    moved = np.any(turned != q, axis=1)
    assert moved.sum() >= 40  # the rest: upright out of the joint limits, kept as they were
    assert np.allclose(after[moved, :3, 2], up, atol=1e-9)
    assert np.allclose(after[:, :3, 3], before[:, :3, 3], atol=1e-9)
    heading = before[moved, :3, 0] - np.outer(before[moved, :3, 0] @ up, up)
    assert np.allclose(
        np.einsum("ki,ki->k", heading / np.linalg.norm(heading, axis=1, keepdims=True), after[moved, :3, 0]),
        1.0,
    )
    assert np.all(np.abs(turned - q)[:, [0, 1, 3, 4, 5]] <= np.pi)


def test_when_no_plan_keeps_the_checks_the_error_gives_every_reason():
    arm, tips, start_yaw, grasp_yaw = APPROACHES[0]
    waypoints = _approach(arm, tips, start_yaw, grasp_yaw)
    impossible = Channel(waypoints.place.point, waypoints.place.axis, DESCENT_CLEAR, 1e-9)
    with pytest.raises(PegbtError) as error:
        TransferPlanner(arm_settings(arm)).plan(
            TransferWaypoints(waypoints.poses, None, None, impossible, waypoints.upright)
        )
    message = str(error.value)
    assert "no transfer for PSM1 passes its checks" in message
    assert all(f"{method}: " in message for method in ("sqp", "spline", "cubic"))


def test_the_eval_summary_counts_fallbacks_per_trial():
    records = [
        TrialRecord("unilateral", "optimized", seed, "success", fallbacks=count)
        for seed, count in ((1, 1), (2, 0))
    ]
    figures = summarise(Cell("unilateral", "optimized", 2, 1), records)
    assert figures["fallbacks_per_trial"] == 0.5
    assert "fallen back to cubics / trial" in table(figures)


def test_a_plan_depends_on_its_waypoints_alone_not_on_the_plans_before_it():
    arm, tips, start_yaw, grasp_yaw = APPROACHES[0]
    waypoints = _approach(arm, tips, start_yaw, grasp_yaw)
    fresh = TransferPlanner(arm_settings(arm)).plan(waypoints).trajectory
    used = TransferPlanner(arm_settings(arm))
    for other in APPROACHES[1:2]:
        used.plan(_approach(*other))
    again = used.plan(waypoints).trajectory
    # the same plan, whatever the planner solved before
    assert len(again) == len(fresh) and np.allclose(again.q, fresh.q, rtol=0, atol=1e-9)
