"""Planning one transfer: waypoints → IK → the paper's spline (Alg. 2) → SQP refinement → checked trajectory.

Also the paper's unoptimised baseline for the same waypoints: rest-to-rest cubics, stopping at each.
The spline (and so the SQP's path) passes over the pegs lower than the cubics' transfer height: at the
block's clearing height plus `sqp.warm_above_clear` (`lowered`), since the SQP and the checks keep the
block clear of the pegs all along; the transfer height is the paper's, kept by the cubics.
The planner's answer always passes the checks and is never slower than that baseline: the SQP's path
if it passes them and is no slower, else the spline (never slower: its magnitudes' grid starts at rest)
or else the cubics, whichever first passes the checks; if none does, an error gives every reason.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.motion.checks import trajectory_problems
from pegbt.motion.cubic import rest_to_rest_path
from pegbt.motion.ik import solve_ik
from pegbt.motion.limits import ArmSettings
from pegbt.motion.settings import MotionSettings, motion_settings
from pegbt.motion.spline import joint_direction, plan_spline
from pegbt.motion.sqp import SqpRefiner
from pegbt.motion.trajectory import HermitePath, Trajectory
from pegbt.motion.waypoints import WAYPOINT_NAMES, Channel, TransferWaypoints


@dataclass(frozen=True)
class TransferPlan:
    """A planned transfer: the streamable `trajectory`, the continuous `path` it was sampled from, the
    spline that warm-started the SQP, the joint waypoints (4, 6), which method gave it (`sqp`, `spline` or
    `cubic`, tried in that order) and why the ones before it did not (empty for the SQP's)."""

    trajectory: Trajectory
    path: HermitePath
    spline: HermitePath
    joints: NDArray[np.float64]
    method: str
    reason: str = ""

    @property
    def refined(self) -> bool:
        """Whether the SQP refined the spline."""
        return self.method == "sqp"


def joint_waypoints(waypoints: TransferWaypoints, settings: ArmSettings) -> NDArray[np.float64]:
    """IK of the four transfer poses (4, 6); a `PegbtError` names the first unreachable one and why."""
    return np.stack(
        [
            solve_ik(pose, settings, what=f"transfer waypoint {i} ({name})")
            for i, (pose, name) in enumerate(zip(waypoints.poses, WAYPOINT_NAMES))
        ]
    )


def cubic_transfer(waypoints: TransferWaypoints, settings: ArmSettings) -> Trajectory:
    """The paper's unoptimised transfer: a rest-to-rest cubic per segment, sampled at the control period."""
    path = rest_to_rest_path(joint_waypoints(waypoints, settings), settings, list(WAYPOINT_NAMES))
    return path.sample(settings.control_period)


def lowered(waypoints: TransferWaypoints, above_clear: float) -> TransferWaypoints:
    """`waypoints` with the poses over the pegs (lifted, above the goal) brought down to `above_clear`
    over the clearing height of the transit (the higher of the two pegs'), never raised, and the lifted
    pose never below the start (a motion from high up does not dip first); with nothing held (an
    approach, or a jaw's way out of a block the other arm holds: not a `floor`) from a start already above
    the clearing height, the lifted pose is the start (or the top of the way out of the hole): a rise there
    only makes the warm start stop and turn, and the SQP's path is the slower for it (0.11 s an
    approach over the unilateral trial). The start and the goal stay where they are. A transit without
    a clearing height above its goal (a goal that is no floor: the carry up onto the handover point) has
    only its lifted pose lowered, over its start peg's clearing height (`_lift_lowered`)."""
    place, poses = waypoints.place, waypoints.poses.copy()
    if place.in_the_air:
        if waypoints.pick is None:
            return waypoints
        return replace(waypoints, poses=_lift_lowered(poses, waypoints.pick, above_clear))
    floor, held = place.clear, waypoints.pick if waypoints.pick is not None and waypoints.pick.floor else None
    if held is not None:
        floor = max(floor, held.clear + float((held.point - place.point) @ place.axis))
    start = float((poses[0][:3, 3] - place.point) @ place.axis)
    lifted = max(floor + above_clear, start)
    if held is None and start >= floor:
        lifted = start  # nothing held and already clear: no rise, the motion sets off sideways
    way_out = waypoints.pick
    if way_out is not None and not way_out.floor:  # out of a held block's hole first
        lifted = max(lifted, way_out.clear + float((way_out.point - place.point) @ place.axis))
    for index, lowest in ((1, lifted), (2, floor + above_clear)):
        excess = float((poses[index][:3, 3] - place.point) @ place.axis) - lowest
        if excess > 0.0:
            poses[index][:3, 3] -= excess * place.axis
    return replace(waypoints, poses=poses)


def _lift_lowered(poses: NDArray[np.float64], pick: Channel, above_clear: float) -> NDArray[np.float64]:
    """`poses` of a carry to a goal in the air (the handover's meeting point) with the lifted pose brought
    down to `above_clear` over the start peg's clearing height, never raised: lifted to the transfer height
    over its peg, the SQP's path rose the block there and came down to the meeting point again."""
    excess = float((poses[1][:3, 3] - pick.point) @ pick.axis) - (pick.clear + above_clear)
    if excess > 0.0:
        poses[1][:3, 3] -= excess * pick.axis
    return poses


class TransferPlanner:
    """Plans transfers for one arm; owns that arm's OSQP problem so consecutive plans reuse it."""

    def __init__(self, settings: ArmSettings, motion: MotionSettings | None = None) -> None:
        self.settings = settings
        sqp = (motion or motion_settings()).sqp
        self.refiner = SqpRefiner(settings, sqp)
        self.warm_above_clear = sqp.warm_above_clear

    def spline(self, waypoints: TransferWaypoints, joints: NDArray[np.float64] | None = None) -> HermitePath:
        """The paper's Alg. 2 spline through the waypoints (the SQP's warm start): up from the lifted pose,
        down onto the goal, or up its channel onto a goal that is no floor (the block rises onto it)."""
        q = joint_waypoints(waypoints, self.settings) if joints is None else joints
        up = waypoints.upright.axis
        arrival = up if waypoints.place.floor else waypoints.place.axis
        return plan_spline(q, joint_direction(q[1], up), joint_direction(q[2], -arrival), self.settings)

    def plan(self, waypoints: TransferWaypoints, *, above_clear: float | None = None) -> TransferPlan:
        """The checked transfer, never slower than the rest-to-rest cubics: the SQP's, else the spline's,
        else the cubics' (see the module's docstring); a `PegbtError` (and no trajectory) if the
        waypoints are out of reach or none passes the checks (limits, channels, upright tool, C1,
        clearance), naming why each failed. The spline passes over the pegs `above_clear` over the
        clearing height (`lowered`; default `sqp.warm_above_clear`)."""
        joints = joint_waypoints(waypoints, self.settings)
        warm = lowered(waypoints, self.warm_above_clear if above_clear is None else above_clear)
        spline = self.spline(warm, joints if warm is waypoints else None)
        cubic = rest_to_rest_path(joints, self.settings, list(WAYPOINT_NAMES))
        reasons: list[str] = []
        try:
            path, trajectory = self.refiner.refine(spline, waypoints.pick, waypoints.place, waypoints.upright)
        except PegbtError as error:
            reasons.append(f"sqp: {error.message}")
        else:
            if trajectory.duration <= cubic.sample(self.settings.control_period).duration:
                return TransferPlan(trajectory, path, spline, joints, "sqp")
            reasons.append(f"sqp: its {trajectory.duration:.2f} s are slower than the cubics")
        for method, path in (("spline", spline), ("cubic", cubic)):
            trajectory = path.sample(self.settings.control_period)
            problems = trajectory_problems(
                trajectory,
                self.settings,
                leaving=waypoints.pick,
                arriving=waypoints.place,
                upright=waypoints.upright,
            )
            if not problems:
                return TransferPlan(trajectory, path, spline, joints, method, "; ".join(reasons))
            reasons.append(f"{method}: " + "; ".join(problems))
        raise PegbtError(
            f"no transfer for {self.settings.name} passes its checks: " + " | ".join(reasons),
            field="transfer",
        )
