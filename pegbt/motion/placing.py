"""The reference paper's placing heights, and a carry stopped at rest over its goal peg.

BerkeleyAutomation/FLSpegtransferHO, `motion/dvrkPegTransferMotion*.py` (`transfer_block_traj`): the carry
ends at rest at `height_ready` over the goal peg, where the camera looks at the held block (`place_servoing`,
`FLSPegTransfer_*.py`); only then does the arm go down to `height_drop` and open. Both are z values in each
arm's own base frame, whatever the peg tops' height there (`posw2 = [pos_place[0], pos_place[1],
self.height_ready]`, `dvrkPegTransferMotionDualArm.py` lines 155 and 293–307; `HandOver.py` 246, 265, 335 and
388–390), and the tool there lies along the base's z (`euler_to_quaternion([rot, 0, 0])`). The board leans
in the arms' frames, so one z is a different height over each arm's pegs (docs/guides/sim-to-real.md).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.frames import rigid_transform, yaw_rotation
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.waypoints import TransferWaypoints

STOP_Z = -0.120  # m, `height_ready` of all three motion scripts: where the carry stops and the look is taken
# m, `height_drop` by script: where the tip stops before the jaw opens
DROP_Z = {"unilateral": -0.130, "bilateral": -0.135, "handover": -0.138}
# an axis rising less than this per unit of its length is too near horizontal to reach a z along (a 1 cm change
# of z would move the point over 1 m)
MIN_AXIS_RISE = 0.01


def paper_variant(variant: str) -> str:
    """`variant` if the paper's protocol has heights for it (`DROP_Z`), else a `PegbtError`."""
    if variant not in DROP_Z:
        raise PegbtError(
            f"the paper's protocol has heights for {', '.join(DROP_Z)} only, not {variant!r}", field="variant"
        )
    return variant


def along_to_z(point: ArrayLike, z: float, along: ArrayLike) -> NDArray[np.float64]:
    """`point` (arm frame) moved along `along` until its z in the arm's frame is `z`; a `PegbtError` if
    `along` barely rises (`MIN_AXIS_RISE`), where the move would be huge or infinite."""
    point, along = np.asarray(point, dtype=float), np.asarray(along, dtype=float)
    length = float(np.linalg.norm(along))
    if not abs(along[2]) >= MIN_AXIS_RISE * length > 0:
        raise PegbtError(
            f"the axis {along.tolist()} rises {along[2]:.3g} per {length:.3g} of its length (at least "
            f"{MIN_AXIS_RISE:g} needed): it cannot reach z = {z:.4g} m from z = {point[2]:.4g} m",
            field="axis",
        )
    return point + (z - point[2]) / along[2] * along


def paper_heights(waypoints: TransferWaypoints, variant: str, up: ArrayLike) -> TransferWaypoints:
    """`waypoints` with the lift (a transfer's, not a placement's), the stop over the goal peg and the
    lowering at the paper's z (`STOP_Z`, `STOP_Z`, `variant`'s `DROP_Z`), each pose moved along `up`, the pegs'
    axis, so the tip keeps to the same peg axes; the goal's channel follows the lowered tip."""
    targets = {2: STOP_Z, 3: DROP_Z[paper_variant(variant)]} | (
        {1: STOP_Z} if waypoints.pick is not None else {}
    )
    poses = waypoints.poses.copy()
    for row, z in targets.items():
        poses[row, :3, 3] = along_to_z(poses[row, :3, 3], z, up)
    return _lowered_to(replace(waypoints, poses=poses), waypoints)


def straight_down(waypoints: TransferWaypoints, place: ArrayLike, yaw: float) -> TransferWaypoints:
    """`waypoints` over the goal peg and lowered as the paper commands them (`servoing_block`): the tip
    over `place` (arm frame: the peg top and the tip's offset from the block's axis) at the poses' own z,
    the tool along the base's z at `yaw`; the goal's channel follows the lowered tip."""
    poses = waypoints.poses.copy()
    x, y = np.asarray(place, dtype=float)[:2]
    for row in (2, 3):
        poses[row] = rigid_transform(yaw_rotation(yaw), [x, y, poses[row, 2, 3]])
    return _lowered_to(replace(waypoints, poses=poses), waypoints)


def _lowered_to(moved: TransferWaypoints, before: TransferWaypoints) -> TransferWaypoints:
    """`moved` with its goal channel through its lowered tip: as `before`'s, its clearing height counted
    from there."""
    channel = before.place
    dropped = moved.poses[3, :3, 3]
    rise = float((dropped - channel.point) @ channel.axis)
    return replace(moved, place=replace(channel, point=dropped, clear=channel.clear - rise))


def segment_times(planned: Trajectory) -> tuple[float, float]:
    """Planned times (s from the start) at which a carry's lift ends and its lowering starts: where the
    joint speed first dips (the cubics stop at each waypoint; a spline slows through them)."""
    speed = np.linalg.norm(planned.qd, axis=1)
    stops = [i for i in range(1, len(speed) - 1) if speed[i] <= speed[i - 1] and speed[i] <= speed[i + 1]]
    stops = (stops + [len(speed) - 1, len(speed) - 1])[:2]
    return float(planned.t[stops[0]] - planned.t[0]), float(planned.t[stops[1]] - planned.t[0])


def stopped_above(planned: Trajectory) -> Trajectory:
    """`planned` (a carry through lifted, above the goal peg and lowered onto it) up to its stop above the
    goal peg: the paper's carry, which ends there at rest."""
    _, lowering = segment_times(planned)
    stop = int(np.searchsorted(planned.t - planned.t[0], lowering + 1e-9))
    return Trajectory(planned.t[:stop], planned.q[:stop], planned.qd[:stop], planned.qdd[:stop])
