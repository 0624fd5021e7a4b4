"""Transfer planning on the reference pegboard: spline, SQP refinement, checks, baselines, bad input."""

from dataclasses import replace

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from pegbt.behaviours.poses import approach_for
from pegbt.errors import PegbtError
from pegbt.motion import sqp
from pegbt.motion.channel import Channel, Upright
from pegbt.motion.checks import check_trajectory, trajectory_problems
from pegbt.motion.cubic import joint_move, rest_to_rest_path
from pegbt.motion.ik import solve_ik
from pegbt.motion.jacobian import jacobian
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import PSM_SETTINGS, arm_settings
from pegbt.motion.settings import MOTION_SETTINGS, motion_settings
from pegbt.motion.spline import shortest_segment_times
from pegbt.motion.trajectory import HermitePath, Trajectory, concatenate, segment_extremes
from pegbt.motion.transfer import TransferPlanner, cubic_transfer, joint_waypoints
from pegbt.motion.waypoints import placement_waypoints, transfer_waypoints
from pegbt.workcell import UNILATERAL_ORDER, workcell

PSM1 = arm_settings("PSM1")
CELL = workcell()


def _waypoints(pick, place, arm="PSM1", **kwargs):
    tops = CELL.peg_tops_in(arm)
    return transfer_waypoints(tops[pick], tops[place], up=CELL.up_in(arm), **kwargs)


@pytest.fixture(scope="module")
def planner():
    return TransferPlanner(PSM1)


@pytest.fixture(scope="module")
def plan(planner):
    return planner.plan(_waypoints(1, 7, pick_offset=(0.0, 0.004, 0.0), pick_yaw=0.3, place_yaw=-0.2))


def test_transfer_goes_from_the_grasp_to_the_place_pose_within_every_check(plan):
    waypoints = _waypoints(1, 7, pick_offset=(0.0, 0.004, 0.0), pick_yaw=0.3, place_yaw=-0.2)
    trajectory = plan.trajectory
    assert np.allclose(np.diff(trajectory.t), PSM1.control_period)
    assert np.allclose(forward_kinematics(trajectory.q[0]), waypoints.poses[0], atol=1e-9)
    assert np.allclose(forward_kinematics(trajectory.q[-1]), waypoints.poses[3], atol=1e-9)
    assert (
        trajectory_problems(
            trajectory, PSM1, leaving=waypoints.pick, arriving=waypoints.place, upright=waypoints.upright
        )
        == []
    )
    # Independently of the checker: the tip stays within the tolerance of the start peg's axis until
    # the block has cleared it, and the block does clear it; the tool never leans more than 2°.
    poses = forward_kinematics(trajectory.q)
    tips = poses[:, :3, 3]
    heights = waypoints.pick.height(tips)
    cleared = int(np.argmax(heights >= waypoints.pick.clear))
    assert cleared > 0
    assert waypoints.pick.distance(tips[:cleared]).max() <= waypoints.pick.tolerance
    up = waypoints.pick.axis
    assert np.degrees(np.arccos(np.clip(poses[:, :3, 2] @ up, -1.0, 1.0))).max() <= 2.0 + 1e-6
    # The block's hole, 4 mm from the tip, stays round its peg (the tip's tolerance, and as much again
    # for the tool turning about the axis) until the block has cleared it.
    hole = tips[0] - np.array([0.0, 0.004, 0.0])
    in_tool = poses[0, :3, :3].T @ (hole - tips[0])
    holes = tips[:cleared] + np.einsum("kij,j->ki", poses[:cleared, :3, :3], in_tool)
    off = holes - hole
    off -= np.outer(off @ up, up)
    assert np.linalg.norm(off, axis=1).max() <= 2 * waypoints.pick.tolerance + 1e-4


def test_refined_transfer_beats_the_spline_and_the_cubic_baseline(plan):
    cubic = cubic_transfer(
        _waypoints(1, 7, pick_offset=(0.0, 0.004, 0.0), pick_yaw=0.3, place_yaw=-0.2), PSM1
    )
    assert plan.refined
    assert plan.trajectory.duration < plan.spline.duration < cubic.duration


def test_spline_passes_the_middle_waypoints_moving_along_the_peg_axis(planner):
    waypoints = _waypoints(0, 6)
    spline = planner.spline(waypoints)
    up = waypoints.pick.axis
    for index, sign in ((1, 1.0), (2, -1.0)):
        twist = jacobian(spline.positions[index]) @ spline.velocities[index]
        speed = np.linalg.norm(twist[:3])
        assert speed > 0.01
        assert np.allclose(twist[:3] / speed, sign * up, atol=1e-9) and np.allclose(twist[3:], 0, atol=1e-9)


def test_spline_segments_are_as_short_as_the_limits_allow(planner):
    spline = planner.spline(_waypoints(0, 6))
    assert check_trajectory(spline.sample(PSM1.control_period), PSM1) is not None
    faster = spline.retimed(0.97).sample(PSM1.control_period)
    assert any("outside" in problem for problem in trajectory_problems(faster, PSM1))


def test_rest_to_rest_cubic_hits_a_limit_exactly_and_stops_at_each_waypoint():
    q = joint_waypoints(_waypoints(2, 9), PSM1)
    path = rest_to_rest_path(q, PSM1)
    assert np.all(path.velocities == 0)
    trajectory = path.sample(PSM1.control_period)
    assert trajectory_problems(trajectory, PSM1) == []
    peak = np.max(
        np.abs(path.retimed(1.0).evaluate(np.linspace(0, path.duration, 20001))[2])
        / PSM1.planner_acceleration
    )
    assert peak == pytest.approx(1.0, rel=1e-3)


def test_joint_move_is_checked_and_continuous():
    start = np.array([0.1, 0.0, 0.12, 0.0, 0.0, 0.0])
    goal = np.array([-0.3, 0.2, 0.18, 0.5, -0.4, 0.3])
    move = joint_move(start, goal, PSM1)
    assert np.allclose(move.q[0], start) and np.allclose(move.q[-1], goal)
    assert trajectory_problems(move, PSM1) == []
    back = joint_move(goal, start, PSM1)
    both = concatenate([move, back])
    assert len(both) == len(move) + len(back) - 1 and trajectory_problems(both, PSM1) == []


def test_checker_names_velocity_channel_and_continuity_violations():
    waypoints = _waypoints(3, 8)
    q = joint_waypoints(waypoints, PSM1)
    # Straight from the grasp to the place pose in joint space: drags the block across the peg.
    direct = joint_move(q[0], q[3], PSM1)
    problems = trajectory_problems(direct, PSM1, leaving=waypoints.pick, arriving=waypoints.place)
    assert any("start peg's axis" in p or "never clears the start peg" in p for p in problems)
    too_fast = HermitePath(np.array([0.0, 0.1]), q[[0, 3]], np.zeros((2, 6))).sample(PSM1.control_period)
    problems = trajectory_problems(too_fast, PSM1)
    assert any(p.startswith("q1 (yaw) velocity") for p in problems)
    assert any("acceleration" in p for p in problems)
    jumpy = Trajectory(direct.t, direct.q.copy(), direct.qd, direct.qdd)
    jumpy.q[len(jumpy) // 2 :, 2] += 0.002
    assert any(p.startswith("q3 (insertion) position jumps") for p in trajectory_problems(jumpy, PSM1))
    with pytest.raises(PegbtError, match="transfer for PSM1 fails its checks"):
        check_trajectory(direct, PSM1, leaving=waypoints.pick, what="transfer")


def test_checker_names_a_tool_leaning_beyond_the_upright_limit():
    waypoints = _waypoints(3, 8)
    q = joint_waypoints(waypoints, PSM1)
    leaning = q[1].copy()
    leaning[5] += np.radians(3.0)  # wrist yaw: the jaws lean 3° at the end of the move
    move = joint_move(q[1], leaning, PSM1)
    assert trajectory_problems(move, PSM1, upright=waypoints.upright)[0].startswith("the tool leans 3.0")
    assert trajectory_problems(move, PSM1, upright=Upright(waypoints.upright.axis, np.radians(3.5))) == []
    assert trajectory_problems(move, PSM1) == []  # without the limit nothing else is wrong
    with pytest.raises(PegbtError, match="upright.max_tilt"):
        Upright(waypoints.upright.axis, 2.0)


def test_checker_names_a_tool_turning_the_blocks_hole_off_its_peg():
    """The tip grips the wall 4 mm from the hole's axis: turning the tool about the peg's axis while the
    block is on the peg swings the hole round the tip (a simulated block 2 mm off caught on its peg)."""
    waypoints = _waypoints(3, 8, pick_offset=(0.0, 0.004, 0.0))
    up = waypoints.pick.axis
    grasp = waypoints.poses[0]
    q_grasp = joint_waypoints(waypoints, PSM1)[0]

    def lifted_turning(turn: float) -> Trajectory:
        """Up past the clearing height, turning `turn` about the axis on the way."""
        pose = grasp.copy()
        pose[:3, :3] = Rotation.from_rotvec(turn * up).as_matrix() @ grasp[:3, :3]
        pose[:3, 3] += (waypoints.pick.clear + 0.001) * up
        return joint_move(q_grasp, solve_ik(pose, PSM1), PSM1)

    wide = Channel(waypoints.pick.point, up, waypoints.pick.clear, 0.002, lever=0.004)  # turns ≤ 0.5 rad
    assert wide.max_twist == pytest.approx(0.5)
    problems = trajectory_problems(lifted_turning(0.6), PSM1, leaving=wide)
    assert problems and problems[0].startswith("turns the block's hole 2.")
    assert trajectory_problems(lifted_turning(0.4), PSM1, leaving=wide) == []
    assert trajectory_problems(lifted_turning(0.6), PSM1, leaving=replace(wide, lever=0.0)) == []


def test_unreachable_waypoint_is_refused_naming_it_and_the_limit(planner):
    far = CELL.peg_tops_in("PSM1")[7] + np.array([0.0, 0.0, -0.2])  # 20 cm below the board
    waypoints = transfer_waypoints(CELL.peg_tops_in("PSM1")[1], far)
    with pytest.raises(
        PegbtError,
        match=r"transfer waypoint 2 \(above the goal peg\): not reachable by PSM1: q3 \(insertion\)",
    ):
        planner.plan(waypoints)


def test_nan_peg_position_and_a_malformed_placement_start_are_refused():
    with pytest.raises(PegbtError, match="place_peg_top"):
        transfer_waypoints(CELL.peg_tops_in("PSM1")[1], [0.1, float("nan"), -0.15])
    with pytest.raises(PegbtError, match="start"):
        placement_waypoints(np.eye(3), CELL.peg_tops_in("PSM1")[1])


def test_non_positive_planner_limit_is_refused(tmp_path):
    document = yaml.safe_load(PSM_SETTINGS.read_text())
    document["defaults"]["planner"]["acceleration"][2] = 0.0
    document["arms"]["PSM1"]["planner"] = document["defaults"]["planner"]
    path = tmp_path / "psm.yaml"
    path.write_text(yaml.safe_dump(document))
    with pytest.raises(PegbtError, match=r"arms.PSM1.planner.acceleration"):
        arm_settings("PSM1", path)


def test_motion_settings_name_a_bad_field(tmp_path):
    text = MOTION_SETTINGS.read_text().replace("approach_above_block: 0.0025", "approach_above_block: -1")
    path = tmp_path / "motion.yaml"
    path.write_text(text)
    line = next(i for i, row in enumerate(text.splitlines(), 1) if "approach_above_block: -1" in row)
    with pytest.raises(
        PegbtError,
        match=rf"motion.yaml:{line}:\d+: transfer.approach_above_block: expected a positive number",
    ):
        motion_settings(path)


def test_the_planner_updates_its_osqp_problem_instead_of_setting_up_new_ones(planner, monkeypatch):
    import osqp

    solves_before = planner.refiner.solves

    def no_setup(*args, **kwargs):
        raise AssertionError("a new OSQP problem was set up")

    monkeypatch.setattr(osqp.OSQP, "setup", no_setup)
    assert planner.plan(_waypoints(5, 11)).refined
    assert planner.refiner.solves > solves_before


def test_shortest_segment_times_match_a_dense_scan_and_the_rest_to_rest_formulas():
    rng = np.random.default_rng(3)
    count = 30
    delta = rng.uniform(-0.3, 0.3, (count, 6)) * PSM1.planner_velocity
    v0, v1 = rng.uniform(-0.3, 0.3, (2, count, 6)) * PSM1.planner_velocity
    shortest = shortest_segment_times(delta, v0, v1, PSM1)
    # The first duration on a fine grid at which every limit holds (feasibility is not monotone).
    grid = np.linspace(PSM1.control_period, 3.0, 20001)
    peak_v, peak_a = segment_extremes(delta[:, None], v0[:, None], v1[:, None], grid[None, :, None])
    ok = np.all(
        (peak_v <= PSM1.planner_velocity * (1 + 1e-9)) & (peak_a <= PSM1.planner_acceleration * (1 + 1e-9)),
        axis=-1,
    )
    found = ok.any(axis=1)
    assert found.sum() >= count // 2  # the others overshoot their limits at every duration up to 3 s
    assert np.allclose(shortest[found], grid[np.argmax(ok[found], axis=1)], atol=grid[1] - grid[0])
    assert np.all(shortest[~found] > grid[-1])
    # Rest to rest: 6Δ/T² = a_max when the acceleration binds, 1.5Δ/T = v_max when the velocity does.
    rest = np.zeros((2, 6))
    far = np.array([[0.1, 0, 0, 0, 0, 0], [10.0, 0, 0, 0, 0, 0]])
    times = shortest_segment_times(far, rest, rest, PSM1)
    v, a = PSM1.planner_velocity[0], PSM1.planner_acceleration[0]
    assert times[0] == pytest.approx(np.sqrt(6 * 0.1 / a), rel=1e-9)  # closed form
    assert times[1] == pytest.approx(1.5 * 10.0 / v, rel=3e-4)  # bisected to 0.03 %


def test_the_refinement_tries_the_goal_channel_entered_earlier_and_keeps_the_faster(monkeypatch):
    settings = motion_settings()
    carries = [_waypoints(pick, place) for pick, place in UNILATERAL_ORDER]
    planner = TransferPlanner(PSM1)
    # where each carry lets go is its goal, whatever path the refinement takes to it
    releases = [forward_kinematics(planner.plan(carry).trajectory.q[-1]) for carry in carries[:-1]]

    def approaches() -> np.ndarray:
        """The approaches between the unilateral trial's carries, from where each carry let go."""
        durations = []
        for released, pick in zip(releases, carries[1:]):
            approach = approach_for(CELL, settings, "PSM1", released, pick)
            plan = planner.plan(approach, above_clear=settings.sqp.approach_above_clear)
            assert plan.refined
            durations.append(plan.trajectory.duration)
        return np.array(durations)

    both = approaches()
    with monkeypatch.context() as patch:
        patch.setattr(sqp, "PHASE_SHIFTS", (0,))
        warm_only = approaches()
    assert np.all(both <= warm_only + 1e-9)
    assert both.mean() <= 0.97 * warm_only.mean()


def test_the_refined_carries_of_the_unilateral_trial_beat_those_on_eight_segments():
    """The SQP's spline has as many segments as makes the reference carries quickest: on 8 they take
    about 5 % longer (their channels held at fewer samples, the path bends less freely)."""
    settings = motion_settings()
    carries = [_waypoints(pick, place) for pick, place in UNILATERAL_ORDER]

    def mean_carry(motion) -> float:
        planner = TransferPlanner(PSM1, motion)
        plans = [planner.plan(carry) for carry in carries]
        assert all(plan.refined for plan in plans)
        return float(np.mean([plan.trajectory.duration for plan in plans]))

    eight = replace(settings, sqp=replace(settings.sqp, segments=8))
    assert mean_carry(settings) <= 0.96 * mean_carry(eight)


def test_the_refinement_holds_the_blocks_hole_on_its_peg_where_the_warm_start_turns_the_tool():
    """A warm start turning the tool about the pegs' axis as it lifts (its lifted pose turned 0.2 rad)
    swings the hole, gripped off the tip's line, 0.78 mm round it on the peg: the refined path keeps it
    within the tip's own tolerance (without the SQP's rows for it, none of its 8 linearisations does)."""
    waypoints = _waypoints(3, 8, pick_offset=(0.0, 0.004, 0.0))
    up, lever = waypoints.pick.axis, waypoints.pick.lever
    poses = waypoints.poses.copy()
    poses[1, :3, :3] = Rotation.from_rotvec(0.2 * up).as_matrix() @ poses[1, :3, :3]
    plan = TransferPlanner(PSM1).plan(replace(waypoints, poses=poses))
    assert plan.refined
    frames = forward_kinematics(plan.trajectory.q)
    on_peg = waypoints.pick.height(frames[:, :3, 3]) < waypoints.pick.clear
    jaws = frames[on_peg, :3, 0]
    turn = np.arctan2(np.cross(jaws[0], jaws) @ up, jaws @ jaws[0])
    assert np.abs(turn).max() * lever <= waypoints.pick.tolerance + 1e-6
