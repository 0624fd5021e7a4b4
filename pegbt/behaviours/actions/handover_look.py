"""The reference paper's look at the block the giver holds out, and the receiver's grasp of what it sees.

BerkeleyAutomation/FLSpegtransferHO, `FLSPegTransfer_handover.py` and
`motion/dvrkPegTransferMotionHandOver.py`: once the giver holds the block out at rest, the camera looks at it
(`find_block_servo_handover` registers the block model to the cloud) and the receiver's grasp is worked out
from what it sees (`find_grasping_pose_handover`); the receiver moves to `ABOVE_GRASP_POINT` over that grasp
point, down onto it and closes, its tool along its base's z at the grasp's yaw (`pick_block`, lines
157–167). The trees run it under the paper's protocol (`/policy/look_at_handover`,
trees/shared/handover.yaml); the phase simulator's paper handover
(`pegbt.sim2real.outcomes.paperhandover`) works out the receiver's grasp by the same `receiver_grasp`.

Which of the receiver's grasps is taken stays pegbt's (another wall than the giver's, clear of the giver's
tool, nearest to the receiver): the paper's rule (the window of ±70°, then the point farthest to the
receiver's side) has the same intent.
"""

from __future__ import annotations

from functools import partial

import numpy as np
from numpy.typing import ArrayLike, NDArray
from py_trees.common import Status

from pegbt.behaviours.actions.handover import clear_descent, distance_to, giver_of
from pegbt.behaviours.actions.placing import board_points
from pegbt.behaviours.base import ComputeLeaf, MotionLeaf
from pegbt.behaviours.poses import to_arm
from pegbt.behaviours.resources.skills import Skills
from pegbt.frames import apply_rigid, rigid_transform, yaw_rotation
from pegbt.motion.ik import solve_ik
from pegbt.perception.board import BoardEstimate
from pegbt.perception.cloud import open3d_threads
from pegbt.perception.grasp import Grasp, grasp_options
from pegbt.perception.organised import OrganisedCloud
from pegbt.perception.servo import HANDED_MIN_POINTS, around_block, held_block
from pegbt.workcell import Workcell

ABOVE_GRASP_POINT = 0.003  # m: `pick_block` stops this far over the seen grasp point (`offset_grasp`)

Seen = tuple[
    Grasp | None, NDArray[np.float64] | None, str
]  # the receiver's grasp, the seen pose, what was seen


def receiver_grasp(
    skills: Skills,
    receiver: str,
    giver: str,
    giver_candidate: int,
    block_pose: NDArray[np.float64],
    q_giver: NDArray[np.float64],
) -> Grasp | None:
    """The receiver's grasp of a block at `block_pose` (board frame, tilted as it hangs) held by `giver`
    (its joints `q_giver`) by candidate `giver_candidate`: at the candidate's point, the tool upright at
    its yaw, as `pick_block` goes (`euler_to_quaternion([rot, 0, 0])`); on another wall than the giver's,
    reachable, its descent from `receiver_wait_above` keeping `grasp_clearance` of the giver's tool; the
    nearest to the receiver. None if there is none."""
    cell = skills.cell
    edges = cell.block.grasp_candidates.edge
    selector = skills.selectors[receiver]
    options = [
        _upright(cell, option, block_pose)
        for option in grasp_options(block_pose, receiver, cell)
        if abs(option.yaw) <= selector.yaw_window and edges[option.candidate] != edges[giver_candidate]
    ]
    if not options:
        return None
    reachable = np.asarray(selector.reachable(np.array([option.pose for option in options])), dtype=bool)
    return next(
        (
            option
            for option in sorted(
                (option for option, ok in zip(options, reachable) if ok),
                key=lambda option: distance_to(cell, receiver, option),
            )
            if clear_descent(skills, receiver, option, giver, q_giver)
        ),
        None,
    )


def _upright(cell: Workcell, option: Grasp, block_pose: NDArray[np.float64]) -> Grasp:
    """`option` as `pick_block` takes it: `grasp_depth` down the base's z from the candidate's point on the
    (tilted) top face (`offset_grasp` is along the robot's z), the tool along the base's z at the option's
    yaw (`euler_to_quaternion([rot, 0, 0])`)."""
    local = cell.block.grasp_candidates.positions[option.candidate] - [0.0, 0.0, cell.block.grasp_depth]
    tip = to_arm(cell, option.arm, apply_rigid(block_pose, local)) - [0.0, 0.0, cell.block.grasp_depth]
    pose = rigid_transform(yaw_rotation(option.yaw), tip)
    return Grasp(
        option.arm, option.candidate, pose, option.yaw, apply_rigid(cell.arm_to_board(option.arm), tip)
    )


def over_grasp(cell: Workcell, grasp: Grasp) -> NDArray[np.float64]:
    """Where `pick_block` first takes the receiver: `ABOVE_GRASP_POINT` over the grasp point, which lies
    `grasp_depth` over the tip at the grasp, along the base's z."""
    pose = grasp.pose.copy()
    pose[2, 3] += ABOVE_GRASP_POINT + cell.block.grasp_depth
    return pose


class FindHandedBlock(ComputeLeaf):
    """`find_block_servo_handover` and `find_grasping_pose_handover` on `/cloud`: the points around where
    the block was planned held out (`block_pose`, `around_block`), less those on both arms' tools where
    their plans put them, registered to the block model (`held_block`, with the paper's 100 points at
    least); the receiver `arm`'s grasp of the seen block (`receiver_grasp`) and the seen pose replace
    `grasp` and `block_pose`. Fails, saying what it saw, if it finds no block there or no grasp of it."""

    def inputs(self) -> tuple[object, ...]:
        arm = self.param("arm")
        giver = giver_of(self, arm)
        joints = {name: self.motion(name).start_from(self.client(name)) for name in (arm, giver)}
        planned = np.asarray(self.get("block_pose"), dtype=float)
        candidate = self.get("giver_grasp").candidate
        return self.read("/cloud"), self.read("/board"), arm, giver, joints, planned, candidate

    def compute(
        self,
        cloud: ArrayLike | OrganisedCloud,
        board: BoardEstimate,
        arm: str,
        giver: str,
        joints: dict[str, NDArray[np.float64]],
        planned: NDArray[np.float64],
        candidate: int,
    ) -> Seen:
        cell = self.skills.cell
        points = board_points(cloud, board, cell, joints)
        seen = points[around_block(points, planned, cell.block)]
        with open3d_threads(1 if self.context.work.inline else None):
            pose, count, why = held_block(self.skills.locator, seen, planned[:2, 3], HANDED_MIN_POINTS)
        if pose is None:
            return None, None, f"{count} points where the block is held out, {why}: no block seen"
        off = 1000 * np.linalg.norm(pose[:3, 3] - planned[:3, 3])
        taken = receiver_grasp(self.skills, arm, giver, candidate, pose, joints[giver])
        seen_as = f"{count} points: the block {off:.1f} mm off where it was planned held out"
        return taken, pose, seen_as if taken is not None else f"{seen_as}, and {arm} has no grasp of it"

    def finish(self, result: Seen) -> Status:
        taken, pose, seen = result
        if taken is None or pose is None:
            return self.fail(seen)
        self.put("grasp", taken)
        self.put("block_pose", pose)
        self.feedback_message = f"{seen}; grasp at candidate {taken.candidate}"
        return Status.SUCCESS


class OverSeenGrasp(MotionLeaf):
    """The receiver goes, rest to rest, to `ABOVE_GRASP_POINT` over its grasp point of the block seen held
    out (`over_grasp`), jaw open, as `pick_block` does before it descends."""

    def begin(self) -> None:
        arm, grasp = self.param("arm"), self.get("grasp")
        motion = self.motion(arm)
        start = motion.start_from(self.client(arm))
        target = solve_ik(over_grasp(self.skills.cell, grasp), motion.settings, what=f"{arm} over the grasp")
        self.move(arm, partial(motion.through, start, [target], ["over the grasp"]), f"{arm} over the grasp")
        self.move_jaw(arm, self.skills.motion.transfer.jaw_open, f"{arm} jaw opening")
