"""Handing a block from one arm (the giver) to the other (the receiver), as in the reference setup.

The giver brings the block to the meeting point while the receiver waits, open, above its own grasp on
the same block; the receiver descends and closes; the giver opens and rises before the receiver leaves;
the receiver then places the block on its goal peg, planned like a transfer (the refined SQP path,
lowered onto the peg along its axis, the tool upright) that starts in the air. Both arms' poses are
built in the board frame and planned in each arm's base frame; every phase is checked so that the two
tools (shafts and jaws, as segments) never come closer than the minimum distance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.frames import apply_rigid, invert_rigid, rigid_transform, segment_distances
from pegbt.motion.cubic import joint_move
from pegbt.motion.ik import solve_ik
from pegbt.motion.kinematics import link_frames
from pegbt.motion.limits import ArmSettings
from pegbt.motion.settings import MotionSettings, motion_settings
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.transfer import TransferPlanner
from pegbt.motion.waypoints import placement_waypoints, tool_down_rotation
from pegbt.workcell import ToolGeometry, Workcell

WRIST_FRAME = 4  # link frame at the end of the shaft (wrist pitch axis)


@dataclass(frozen=True)
class HandoverPhase:
    """Moves played together (arm name → trajectory; an arm not named holds still), then jaw commands
    (arm name → jaw angle, rad) once both moves have ended."""

    name: str
    moves: dict[str, Trajectory]
    jaws: dict[str, float]


@dataclass(frozen=True)
class HandoverPlan:
    phases: tuple[HandoverPhase, ...]
    closest_tools: float  # m: the smallest distance between the two tools over the whole plan


def handover_meeting_point(cell: Workcell, motion: MotionSettings | None = None) -> NDArray[np.float64]:
    """The giver's tip position at the handover, board frame: the mean of the work cell's handover peg
    tops (the reference uses pegs 3, 6 and 9), shifted in board y, `meeting_above_transfer` above the
    transfer height (below it if negative)."""
    motion = motion or motion_settings()
    point = cell.pegs.tops[list(cell.handover_pegs)].mean(axis=0)
    point[1] += motion.handover.meeting_offset_board_y
    point[2] -= (
        motion.transfer.transfer_height_above_peg_top + motion.handover.meeting_above_transfer
    )  # board z is down
    return point


def jaw_on_wall(cell: Workcell) -> float:
    """The jaw angle (rad) at which jaws closing astride a block's wall touch it: their tips the wall's
    thickness apart. A jaw sent closing that long before the tool arrives meets the wall as it does."""
    return _jaw_angle(cell, _wall(cell) / 2.0)


def jaw_clear_of_wall(cell: Workcell) -> float:
    """The jaw angle (rad) past which an opening jaw has let go of a block's wall: its jaws, `jaw_radius`
    round, a jaw radius clear of the wall either side at their tips (24°). Below it a jaw opening from its
    squeeze still presses on the wall: an arm moving then drags the block (held by another jaw, through
    that jaw)."""
    return _jaw_angle(cell, _wall(cell) / 2.0 + cell.tool.jaw_radius)


def _wall(cell: Workcell) -> float:
    """The thickness (m) of a block's wall between its edge and its hole."""
    return cell.block.edge_distance - cell.block.hole_radius


def _jaw_angle(cell: Workcell, half_gap: float) -> float:
    """The jaw angle (rad) at which the jaws' tips are `half_gap` off the jaw's centre line either side."""
    return 2.0 * math.asin(min(1.0, half_gap / cell.tool.jaw_length))


def tool_segments(
    q: ArrayLike, board_from_arm: NDArray[np.float64], tool: ToolGeometry | None = None
) -> list[tuple[NDArray, NDArray]]:
    """An arm's tool at joints `q` (..., 6) as segments (start, end; each (..., 3), board frame): the shaft
    (remote centre to wrist pitch axis) and wrist to tip; given `tool`, the latter split at the jaw hinge
    into wrist and jaw, as the simulator's world sees the tool (`pegbt.sim.tools.ToolState.segments`)."""
    frames = link_frames(q)
    tip = frames[-1]
    points = [np.zeros(np.shape(q)[:-1] + (3,)), frames[WRIST_FRAME][..., :3, 3]]
    if tool is not None:
        points.append(tip[..., :3, 3] + tool.jaw_length * tip[..., :3, 2])
    points.append(tip[..., :3, 3])
    points = [apply_rigid(board_from_arm, point) for point in points]
    return list(zip(points[:-1], points[1:]))


def tool_distance(
    q_a: ArrayLike, a_from_board: ArrayLike, q_b: ArrayLike, b_from_board: ArrayLike
) -> NDArray[np.float64]:
    """Smallest distance (...) between two arms' tools (shaft and wrist-to-tip segments) at joints
    `q_a`, `q_b` (..., 6), given each arm's transform from the board frame."""
    pairs = [
        segment_distances(a0, a1, b0, b1)
        for a0, a1 in tool_segments(q_a, invert_rigid(a_from_board))
        for b0, b1 in tool_segments(q_b, invert_rigid(b_from_board))
    ]
    return np.min(np.stack(pairs), axis=0)


def tool_gap(
    q_a: ArrayLike, a_from_board: ArrayLike, q_b: ArrayLike, b_from_board: ArrayLike, tool: ToolGeometry
) -> NDArray[np.float64]:
    """Smallest clearance (...) between two arms' tools as solids: shaft, wrist (pitch axis to jaw hinge)
    and jaw, each a segment with the work cell's radius, at joints `q_a`, `q_b` (..., 6); negative where
    they overlap. `tool_distance` measures axes; this is what touches."""
    parts = [
        tool_segments(q, invert_rigid(np.asarray(T, dtype=float)), tool)
        for q, T in ((q_a, a_from_board), (q_b, b_from_board))
    ]
    radii = (tool.shaft_radius, tool.wrist_radius, tool.jaw_radius)
    gaps = [
        segment_distances(a0, a1, b0, b1) - ra - rb
        for (a0, a1), ra in zip(parts[0], radii)
        for (b0, b1), rb in zip(parts[1], radii)
    ]
    return np.min(np.stack(gaps), axis=0)


def descent_clearance(
    q_wait: ArrayLike,
    q_grasp: ArrayLike,
    receiver_from_board: ArrayLike,
    q_giver: ArrayLike,
    giver_from_board: ArrayLike,
    tool: ToolGeometry,
    steps: int = 6,
) -> float:
    """The receiver's smallest clearance (m, `tool_gap`) from the giver resting at `q_giver` as it descends
    from `q_wait` straight (in joints, as its move does) onto `q_grasp`."""
    along = np.linspace(0.0, 1.0, steps)[:, None]
    q_wait = np.asarray(q_wait, dtype=float)
    path = q_wait + along * (np.asarray(q_grasp, dtype=float) - q_wait)
    giver = np.repeat(np.asarray(q_giver, dtype=float)[None], steps, axis=0)
    return float(tool_gap(path, receiver_from_board, giver, giver_from_board, tool).min())


def _pose_in_arm(position_board: NDArray, yaw: float, arm_from_board: NDArray, up_board: NDArray) -> NDArray:
    return rigid_transform(
        tool_down_rotation(yaw, arm_from_board[:3, :3] @ up_board),
        apply_rigid(arm_from_board, position_board),
    )


def plan_handover(
    giver: ArmSettings,
    receiver: TransferPlanner,
    giver_q: ArrayLike,
    receiver_q: ArrayLike,
    meeting_point: ArrayLike,
    giver_from_board: ArrayLike,
    receiver_from_board: ArrayLike,
    receiver_offset: ArrayLike,
    place_peg_top: ArrayLike,
    *,
    place_offset: ArrayLike = (0.0, 0.0, 0.0),
    giver_yaw: float = 0.0,
    receiver_yaw: float = 0.0,
    up_board: ArrayLike = (0.0, 0.0, -1.0),
    motion: MotionSettings | None = None,
) -> HandoverPlan:
    """The handover from the giver (holding the block, at joints `giver_q`) to the receiver (the
    receiving arm's transfer planner; at `receiver_q`, jaw open), which then places the block on the
    peg whose top centre is `place_peg_top` with its tip `place_offset` from the peg's axis (board
    frame, m), keeping its yaw. The giver's tip goes to `meeting_point` (board frame, m); the receiver
    grasps at `receiver_offset` (board frame, m) from the giver's grasp point. Yaws are each tool's
    rotation about the pegs' axis in its own arm frame. A `PegbtError` names an unreachable pose, a
    placement that fails its checks, or the phase in which the tools come too close."""
    motion = motion or motion_settings()
    settings, taker = motion.handover, receiver.settings
    up = np.asarray(up_board, dtype=float) / np.linalg.norm(up_board)
    meet = np.asarray(meeting_point, dtype=float)
    grasp = meet + np.asarray(receiver_offset, dtype=float)
    T_giver, T_receiver = (
        np.asarray(giver_from_board, dtype=float),
        np.asarray(receiver_from_board, dtype=float),
    )

    def ik(arm: ArmSettings, position: NDArray, yaw: float, T: NDArray, what: str) -> NDArray:
        return solve_ik(_pose_in_arm(position, yaw, T, up), arm, what=f"handover {what}")

    q_meet = ik(giver, meet, giver_yaw, T_giver, "meeting pose (giver)")
    q_wait = ik(
        taker, grasp + settings.receiver_wait_above * up, receiver_yaw, T_receiver, "waiting pose (receiver)"
    )
    q_grasp = ik(taker, grasp, receiver_yaw, T_receiver, "grasp (receiver)")
    q_clear = ik(giver, meet + settings.giver_retreat * up, giver_yaw, T_giver, "retreat (giver)")
    placement = receiver.plan(
        placement_waypoints(
            _pose_in_arm(grasp, receiver_yaw, T_receiver, up),
            apply_rigid(T_receiver, place_peg_top),
            place_offset=T_receiver[:3, :3] @ np.asarray(place_offset, dtype=float),
            place_yaw=receiver_yaw,
            up=T_receiver[:3, :3] @ up,
            heights=motion.transfer,
        )
    )
    jaw_open, jaw_closed = motion.transfer.jaw_open, motion.transfer.jaw_closed
    phases = (
        HandoverPhase(
            "meet",
            {
                giver.name: joint_move(giver_q, q_meet, giver),
                taker.name: joint_move(receiver_q, q_wait, taker),
            },
            {taker.name: jaw_open},
        ),
        HandoverPhase(
            "receiver descends", {taker.name: joint_move(q_wait, q_grasp, taker)}, {taker.name: jaw_closed}
        ),
        HandoverPhase("giver releases", {}, {giver.name: jaw_open}),
        HandoverPhase("giver rises", {giver.name: joint_move(q_meet, q_clear, giver)}, {}),
        HandoverPhase("receiver places", {taker.name: placement.trajectory}, {taker.name: jaw_open}),
    )
    return HandoverPlan(
        phases,
        _closest_tools(
            phases,
            {giver.name: giver_q, taker.name: receiver_q},
            T_giver,
            T_receiver,
            settings.min_tool_distance,
        ),
    )


def _closest_tools(
    phases: tuple[HandoverPhase, ...],
    start: dict[str, ArrayLike],
    T_giver: NDArray,
    T_receiver: NDArray,
    minimum: float,
) -> float:
    """The smallest distance between the two tools over all phases (giver first in `start`); a
    `PegbtError` names the first phase in which it falls below `minimum`."""
    positions = {arm: np.asarray(q, dtype=float) for arm, q in start.items()}
    giver, receiver = positions
    closest = np.inf
    for phase in phases:
        steps = max((len(t) for t in phase.moves.values()), default=1)
        paths = {}
        for arm, held in positions.items():
            move = phase.moves.get(arm)
            q = np.repeat(held[None], steps, axis=0) if move is None else move.q
            paths[arm] = np.concatenate([q, np.repeat(q[-1:], steps - len(q), axis=0)])
            positions[arm] = paths[arm][-1]
        distance = float(tool_distance(paths[giver], T_giver, paths[receiver], T_receiver).min())
        if distance < minimum:
            raise PegbtError(
                f"the tools come within {distance * 1000:.1f} mm of each other during '{phase.name}' (minimum {minimum * 1000:.1f} mm)",
                field="handover",
            )
        closest = min(closest, distance)
    return closest
