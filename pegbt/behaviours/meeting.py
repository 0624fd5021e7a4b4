"""Where a handover's two arms meet: pegbt's meeting point and the receiver's grasp there.

The giver holds the block out with its tip at the meeting point (the mean of pegs 3, 6 and 9, shifted and
raised as `skills/motion.yaml` says, tool yaw 0); the receiver takes it by a grasp on another wall than the
giver's jaw whose descent keeps clear of the giver's tool. The paper's meeting (`paper_meeting`) is the
other one a run can take.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pegbt.behaviours.poses import to_arm, tool_pose
from pegbt.behaviours.resources.skills import Skills
from pegbt.errors import PegbtError
from pegbt.frames import invert_rigid
from pegbt.motion.handover import descent_clearance, handover_meeting_point
from pegbt.motion.ik import solve_ik
from pegbt.perception.blocks import BlockEstimate
from pegbt.perception.grasp import Grasp
from pegbt.workcell import Workcell


@dataclass(frozen=True)
class Meeting:
    """A planned handover: where the giver's tip meets (its arm frame), the block's pose there (board frame)
    and the receiver's grasp of it."""

    tip: NDArray[np.float64]
    block_pose: NDArray[np.float64]
    receiver_grasp: Grasp


# a meeting planner: (skills, giver, receiver, the giver's grasp, the block) to the meeting, None if none
Meet = Callable[[Skills, str, str, Grasp, BlockEstimate], Meeting | None]


def plan_meeting(
    skills: Skills, giver: str, receiver: str, grasp: Grasp, block: BlockEstimate
) -> Meeting | None:
    """The handover of `block` held by `giver` at `grasp`, or None if the receiver cannot take it: the
    receiver's grasp is on another wall than the giver's jaw, keeps its tool `grasp_clearance` clear of the
    giver's all the way down onto it, and is the nearest such to the receiver. Whether there is one depends
    on the giver's grasp: a block held on some walls hangs so that every grasp of the receiver strikes the
    giver's tool (never one held as the paper picks it off its peg; often one picked off the board)."""
    cell = skills.cell
    tip = meeting_tip(skills, giver)
    q_giver = solve_ik(tip, skills.arm(giver).settings, what="the giver at the meeting point")
    block_pose = (
        cell.arm_to_board(giver) @ tip @ invert_rigid(cell.arm_to_board(giver) @ grasp.pose) @ block.pose
    )
    giver_edge = cell.block.grasp_candidates.edge[grasp.candidate]
    options = [
        option
        for option in skills.selectors[receiver].feasible(block_pose)
        if cell.block.grasp_candidates.edge[option.candidate] != giver_edge
    ]
    taken = next(
        (
            option
            for option in sorted(options, key=lambda option: distance_to(cell, receiver, option))
            if clear_descent(skills, receiver, option, giver, q_giver)
        ),
        None,
    )
    return None if taken is None else Meeting(tip, block_pose, taken)


def meeting_tip(skills: Skills, giver: str) -> NDArray[np.float64]:
    """The giver's tip pose at pegbt's meeting point (its arm frame): fixed by the cell and the motion
    settings, so the carry to it can be planned before the meeting itself is."""
    cell = skills.cell
    return tool_pose(to_arm(cell, giver, handover_meeting_point(cell, skills.motion)), 0.0, cell.up_in(giver))


def distance_to(cell: Workcell, arm: str, option: Grasp) -> float:
    """How far `option` lies from `arm`'s remote centre on the board: a receiver takes the nearest."""
    return float(np.linalg.norm(option.board_position[:2] - cell.remote_centre(arm)[:2]))


def clear_descent(
    skills: Skills, receiver: str, option: Grasp, giver: str, q_giver: NDArray[np.float64]
) -> bool:
    """Whether the receiver, descending from waiting above `option` onto it, keeps `grasp_clearance` from the giver."""
    cell, settings = skills.cell, skills.motion.handover
    wait = option.pose.copy()
    wait[:3, 3] += settings.receiver_wait_above * cell.up_in(receiver)
    try:
        q_wait, q_grasp = (solve_ik(pose, skills.arm(receiver).settings) for pose in (wait, option.pose))
    except PegbtError:
        return False
    clearance = descent_clearance(
        q_wait, q_grasp, cell.board_to_arm(receiver), q_giver, cell.board_to_arm(giver), cell.tool
    )
    return clearance >= settings.grasp_clearance
