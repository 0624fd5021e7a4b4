"""Cartesian waypoints of one transfer, in the arm's base frame, from the pick and place peg positions.

Four poses (the paper's transfer): grasp the block on the start peg, lift it clear above that peg,
move above the goal peg, lower it onto the goal peg. Plus the approach pose just above the grasp, and
the two channels the block must follow while it is on a peg. A placement (after a handover) starts
with the block in the air instead: no start peg, no channel to leave. Heights come from
`skills/motion.yaml`; peg positions come from the caller (the workcell), so this module knows no
board geometry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.frames import rigid_transform, yaw_rotation
from pegbt.motion.channel import Channel, Upright
from pegbt.motion.settings import TransferSettings, motion_settings

WAYPOINT_NAMES = ("grasp", "lifted above the start peg", "above the goal peg", "lowered onto the goal peg")


@dataclass(frozen=True)
class TransferWaypoints:
    """`poses` (4, 4, 4) in the order of `WAYPOINT_NAMES`; `approach` (4, 4) just above the grasp; the
    channels of the pick and place pegs; how upright the tool stays while it carries the block. A
    placement has no `approach` and no `pick` channel, and its first two poses are both the start."""

    poses: NDArray[np.float64]
    approach: NDArray[np.float64] | None
    pick: Channel | None
    place: Channel
    upright: Upright


def tool_down_rotation(yaw: float, up: ArrayLike = (0.0, 0.0, 1.0)) -> NDArray[np.float64]:
    """Tip orientation with the tool along −`up` (straight down into the board) and `yaw` about `up`.

    With `up` = z this is a plain rotation about z (the PSM's R = I points the tool down)."""
    axis = np.asarray(up, dtype=float)
    axis = axis / np.linalg.norm(axis)
    # The smallest rotation taking z onto `up` (Rodrigues), for boards that are not level.
    z = np.array([0.0, 0.0, 1.0])
    v, cos_angle = np.cross(z, axis), float(z @ axis)
    skew = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    tilt = np.eye(3) + skew + skew @ skew / (1.0 + cos_angle)
    return tilt @ yaw_rotation(yaw)


def _vector(value: ArrayLike, what: str) -> NDArray[np.float64]:
    vector = np.asarray(value, dtype=float)
    if vector.shape != (3,) or not np.all(np.isfinite(vector)):
        raise PegbtError(f"expected 3 finite numbers (m, arm frame), got {value!r}", field=what)
    return vector


def _unit_up(up: ArrayLike) -> NDArray[np.float64]:
    up = _vector(up, "up")
    if np.linalg.norm(up) == 0:
        raise PegbtError("the up direction is zero", field="up")
    return up / np.linalg.norm(up)


def _lateral(offset: ArrayLike, up: NDArray[np.float64], what: str) -> NDArray[np.float64]:
    """`offset` without its component along `up`."""
    offset = _vector(offset, what)
    return offset - (offset @ up) * up


def _placing(
    place_peg_top: ArrayLike,
    place_offset: ArrayLike,
    place_yaw: float,
    up: NDArray[np.float64],
    heights: TransferSettings,
) -> tuple[NDArray[np.float64], NDArray[np.float64], Channel]:
    """The poses above the goal peg and lowered onto it, and the goal peg's channel."""
    offset = _lateral(place_offset, up, "place_offset")
    place = _vector(place_peg_top, "place_peg_top") + offset
    dropped = place + heights.drop_height_above_peg_top * up
    rotation = tool_down_rotation(place_yaw, up)
    channel = Channel(
        dropped,
        up,
        heights.channel_clear_above_peg_top - heights.drop_height_above_peg_top,
        heights.channel_tolerance,
        lever=float(np.linalg.norm(offset)),
    )
    return (
        rigid_transform(rotation, place + heights.transfer_height_above_peg_top * up),
        rigid_transform(rotation, dropped),
        channel,
    )


def transfer_waypoints(
    pick_peg_top: ArrayLike,
    place_peg_top: ArrayLike,
    *,
    pick_offset: ArrayLike = (0.0, 0.0, 0.0),
    place_offset: ArrayLike = (0.0, 0.0, 0.0),
    pick_yaw: float = 0.0,
    place_yaw: float = 0.0,
    up: ArrayLike = (0.0, 0.0, 1.0),
    heights: TransferSettings | None = None,
) -> TransferWaypoints:
    """Waypoints moving a block from the peg whose top centre is `pick_peg_top` to `place_peg_top`
    (arm frame, m). The tip grasps at `pick_offset` from the pick peg's axis and places with
    `place_offset` from the place peg's axis (the grasp's offset from the block centre), with gripper
    yaws `pick_yaw` and `place_yaw` (rad) about `up`, the pegs' axis direction."""
    heights = heights or motion_settings().transfer
    up = _unit_up(up)
    offset = _lateral(pick_offset, up, "pick_offset")
    pick = _vector(pick_peg_top, "pick_peg_top") + offset
    above, dropped, place = _placing(place_peg_top, place_offset, place_yaw, up, heights)
    block_top = -heights.block_top_below_peg_top
    grasp = pick + (block_top - heights.grasp_depth) * up
    pick_rotation = tool_down_rotation(pick_yaw, up)
    poses = np.stack(
        [
            rigid_transform(pick_rotation, grasp),
            rigid_transform(pick_rotation, pick + heights.transfer_height_above_peg_top * up),
            above,
            dropped,
        ]
    )
    clear = heights.channel_clear_above_peg_top
    return TransferWaypoints(
        poses=poses,
        approach=rigid_transform(pick_rotation, pick + (block_top + heights.approach_above_block) * up),
        pick=Channel(
            grasp,
            up,
            clear - (block_top - heights.grasp_depth),
            heights.channel_tolerance,
            lever=float(np.linalg.norm(offset)),
        ),
        place=place,
        upright=Upright(up, heights.upright_tilt),
    )


def placement_waypoints(
    start: ArrayLike,
    place_peg_top: ArrayLike,
    *,
    place_offset: ArrayLike = (0.0, 0.0, 0.0),
    place_yaw: float = 0.0,
    up: ArrayLike = (0.0, 0.0, 1.0),
    heights: TransferSettings | None = None,
) -> TransferWaypoints:
    """Waypoints placing a block held in the air with the tip at pose `start` (4, 4; arm frame, e.g.
    the receiver's grasp after a handover) onto the peg whose top centre is `place_peg_top`, lowered
    along its axis as in a transfer. The block is already clear: the lifted pose is the start itself."""
    heights = heights or motion_settings().transfer
    start = np.asarray(start, dtype=float)
    if start.shape != (4, 4) or not np.all(np.isfinite(start)):
        raise PegbtError(f"expected a finite 4x4 pose, got shape {start.shape}", field="start")
    up = _unit_up(up)
    above, dropped, place = _placing(place_peg_top, place_offset, place_yaw, up, heights)
    return TransferWaypoints(
        poses=np.stack([start, start, above, dropped]),
        approach=None,
        pick=None,
        place=place,
        upright=Upright(up, heights.upright_tilt),
    )
