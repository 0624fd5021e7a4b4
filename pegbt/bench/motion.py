"""`pegbt bench motion`: inverse kinematics speed and transfer planning speed and quality.

IK: the closed-form solver on one pose and per pose in a batch of 10 000, against a numerical IK
(scipy.optimize.least_squares on the pose error, from the home configuration), all in this process.

Planning: the twelve unilateral transfers of the reference setup, planned by each arm (24 plans; times
and ratios are medians over all of them). Planning time is also given relative to a fixed workload
timed right after each plan in this process, one numerical scipy IK (below), so that the figure holds
on a busy machine and compares across versions of the planner.
Durations are compared with
- `toppra`, the time-optimal timing of *our own path* under the same velocity and acceleration limits:
  the same geometric path, so the same waypoints and the same channel (`..._vs_optimal`);
- `toppra` on the path of the paper's spline (Alg. 2), i.e. the best timing the paper's path allows
  (`..._vs_optimal_spline_path`);
- `ruckig`, time-optimal rest-to-rest from the grasp to the place configuration that ignores the
  channel and the waypoints: a lower bound no channel-keeping motion can reach (`..._vs_ruckig_no_channel`);
- the paper's unoptimised rest-to-rest cubics through the four waypoints (`..._vs_cubic`).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from pegbt.bench import Figures
from pegbt.motion.ik import inverse_kinematics
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import ArmSettings, arm_settings
from pegbt.motion.transfer import TransferPlanner, cubic_transfer
from pegbt.motion.waypoints import transfer_waypoints
from pegbt.workcell import UNILATERAL_ORDER, workcell

HOME = np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])
BATCH = 10_000
SCIPY_POSES = 30


def _median_seconds(function: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def _scipy_ik(target: np.ndarray, settings: ArmSettings) -> np.ndarray:
    """Numerical IK as the paper's baseline: least squares on position and rotation error."""
    from scipy.optimize import least_squares
    from scipy.spatial.transform import Rotation

    target_rotation = Rotation.from_matrix(target[:3, :3])

    def residual(q: np.ndarray) -> np.ndarray:
        pose = forward_kinematics(q)
        rotation_error = (target_rotation.inv() * Rotation.from_matrix(pose[:3, :3])).as_rotvec()
        return np.concatenate([pose[:3, 3] - target[:3, 3], 0.01 * rotation_error])

    result = least_squares(
        residual, HOME, bounds=(settings.lower, settings.upper), xtol=1e-12, ftol=1e-12, gtol=1e-12
    )
    return result.x


def _ik_figures(settings: ArmSettings) -> Figures:
    rng = np.random.default_rng(0)
    poses = forward_kinematics(rng.uniform(settings.lower, settings.upper, (BATCH, 6)))
    singles = poses[:200]
    single = _median_seconds(lambda: [inverse_kinematics(p, settings) for p in singles], 15) / len(singles)
    batched = _median_seconds(lambda: inverse_kinematics(poses, settings), 15) / BATCH
    scipy_times, scipy_errors = [], []
    for pose in poses[:SCIPY_POSES]:
        start = time.perf_counter()
        q = _scipy_ik(pose, settings)
        scipy_times.append(time.perf_counter() - start)
        scipy_errors.append(np.linalg.norm(forward_kinematics(q)[:3, 3] - pose[:3, 3]))
    scipy = float(np.median(scipy_times))
    return {
        "ik_us_single": single * 1e6,
        "ik_us_batched": batched * 1e6,
        "ik_us_scipy": scipy * 1e6,
        "ik_speedup_vs_scipy": scipy / single,
        "ik_scipy_converged_fraction": float(np.mean(np.asarray(scipy_errors) < 1e-6)),
    }


def _toppra_duration(q: np.ndarray, times: np.ndarray, settings: ArmSettings) -> float:
    """Time-optimal duration along the geometric path through `q` (sampled at `times`)."""
    import toppra
    import toppra.algorithm
    import toppra.constraint

    toppra.setup_logging("WARNING")
    path = toppra.SplineInterpolator(times, q)
    limits = [
        toppra.constraint.JointVelocityConstraint(
            np.stack([-settings.planner_velocity, settings.planner_velocity], axis=1)
        ),
        toppra.constraint.JointAccelerationConstraint(
            np.stack([-settings.planner_acceleration, settings.planner_acceleration], axis=1)
        ),
    ]
    grid = np.linspace(times[0], times[-1], 1001)
    algorithm = toppra.algorithm.TOPPRA(limits, path, gridpoints=grid, parametrizer="ParametrizeConstAccel")
    trajectory = algorithm.compute_trajectory(0.0, 0.0)
    assert trajectory is not None  # the planner's own path, within its limits, is always parametrisable
    start, end = trajectory.path_interval
    return float(end - start)


def _ruckig_duration(start: np.ndarray, goal: np.ndarray, settings: ArmSettings) -> float:
    import ruckig

    generator = ruckig.Ruckig(6)
    inputs, trajectory = ruckig.InputParameter(6), ruckig.Trajectory(6)
    inputs.current_position, inputs.target_position = start.tolist(), goal.tolist()
    inputs.max_velocity = settings.planner_velocity.tolist()
    inputs.max_acceleration = settings.planner_acceleration.tolist()
    inputs.max_jerk = [float("inf")] * 6
    generator.calculate(inputs, trajectory)
    return float(trajectory.duration)


def _transfer_figures(settings: ArmSettings) -> dict[str, list]:
    """Per-transfer figures of one arm's twelve unilateral transfers."""
    setup_start = time.perf_counter()
    planner = TransferPlanner(settings)
    setup = time.perf_counter() - setup_start
    cell = workcell()
    tops, up = cell.peg_tops_in(settings.name), cell.up_in(settings.name)
    transfers = [transfer_waypoints(tops[a], tops[b], up=up) for a, b in UNILATERAL_ORDER]
    planner.plan(transfers[0])  # warm-up: imports and first factorisation
    keys = (
        "plan",
        "baseline",
        "ours",
        "splines",
        "optimal",
        "optimal_spline",
        "no_channel",
        "cubic",
        "refined",
    )
    figures: dict[str, list] = {key: [] for key in keys}
    figures["setup"], solves_before = [setup], planner.refiner.solves
    for waypoints in transfers:
        start = time.perf_counter()
        plan = planner.plan(waypoints)
        figures["plan"].append(time.perf_counter() - start)
        start = time.perf_counter()
        _scipy_ik(waypoints.poses[0], settings)
        figures["baseline"].append(time.perf_counter() - start)
        figures["refined"].append(plan.refined)
        trajectory = plan.trajectory
        figures["ours"].append(trajectory.duration)
        figures["splines"].append(plan.spline.duration)
        figures["optimal"].append(_toppra_duration(trajectory.q, trajectory.t, settings))
        spline = plan.spline.sample(settings.control_period)
        figures["optimal_spline"].append(_toppra_duration(spline.q, spline.t, settings))
        figures["no_channel"].append(_ruckig_duration(plan.joints[0], plan.joints[3], settings))
        figures["cubic"].append(cubic_transfer(waypoints, settings).duration)
    figures["solves"] = [planner.refiner.solves - solves_before]
    return figures


def _planning_figures(arms: list[ArmSettings]) -> Figures:
    per_arm = [_transfer_figures(settings) for settings in arms]
    figures = {key: np.concatenate([np.asarray(arm[key]) for arm in per_arm]) for key in per_arm[0]}
    ours = figures["ours"]

    def ratios(baseline: str) -> np.ndarray:
        return ours / figures[baseline]

    plan_ms = figures["plan"] * 1000
    return {
        "plan_ms_median": float(np.median(plan_ms)),
        "plan_ms_p90": float(np.percentile(plan_ms, 90)),
        "plan_ms_max": float(np.max(plan_ms)),
        "plan_over_scipy_ik_median": float(np.median(figures["plan"] / figures["baseline"])),
        "plan_setup_ms": float(np.median(figures["setup"])) * 1000,
        "qp_solves_per_plan": float(np.sum(figures["solves"])) / len(ours),
        "transfers_refined": f"{int(np.sum(figures['refined']))}/{len(ours)}",
        "transfer_s_median": float(np.median(ours)),
        "spline_s_median": float(np.median(figures["splines"])),
        "cubic_s_median": float(np.median(figures["cubic"])),
        "traj_time_ratio_vs_optimal": float(np.median(ratios("optimal"))),
        "traj_time_ratio_vs_optimal_max": float(np.max(ratios("optimal"))),
        "traj_time_ratio_vs_optimal_per_transfer": " ".join(f"{r:.3f}" for r in ratios("optimal")),
        "traj_time_ratio_vs_optimal_spline_path": float(np.median(ratios("optimal_spline"))),
        "traj_time_ratio_vs_ruckig_no_channel": float(np.median(ratios("no_channel"))),
        "traj_time_ratio_vs_cubic": float(np.median(ratios("cubic"))),
        "traj_time_ratio_vs_cubic_per_transfer": " ".join(f"{r:.3f}" for r in ratios("cubic")),
    }


def run() -> Figures:
    return {
        **_ik_figures(arm_settings("PSM1")),
        **_planning_figures([arm_settings("PSM1"), arm_settings("PSM2")]),
    }
