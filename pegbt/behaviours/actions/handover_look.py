"""The reference paper's look at the block the giver holds out, and the receiver's grasp of what it sees.

BerkeleyAutomation/FLSpegtransferHO, `FLSPegTransfer_handover.py` and
`motion/dvrkPegTransferMotionHandOver.py`: once the giver holds the block out at rest, the camera looks at it
(`find_block_servo_handover` registers the block model to the cloud) and the receiver's grasp is worked out
from what it sees (`find_grasping_pose_handover`); the receiver moves to `ABOVE_GRASP_POINT` over that grasp
point, down onto it and closes, its tool along its base's z at the grasp's yaw (`pick_block`, lines
157–167). The trees run it under the paper's protocol (`/policy/look_at_handover`,
trees/shared/handover.yaml), where the arms also meet as the paper's did
(`pegbt.behaviours.paper_meeting`, whose `receiver_grasp` the phase simulator's paper handover uses too).
"""

from __future__ import annotations

from functools import partial

import numpy as np
from numpy.typing import ArrayLike, NDArray
from py_trees.common import Status

from pegbt.behaviours.actions.handover import giver_of
from pegbt.behaviours.actions.placing import board_points
from pegbt.behaviours.base import ComputeLeaf, MotionLeaf
from pegbt.behaviours.paper_meeting import receiver_grasp
from pegbt.motion.ik import solve_ik
from pegbt.perception.board import BoardEstimate
from pegbt.perception.cloud import open3d_threads
from pegbt.perception.grasp import Grasp
from pegbt.perception.organised import OrganisedCloud
from pegbt.perception.servo import HANDED_MIN_POINTS, around_block, held_block
from pegbt.workcell import Workcell

ABOVE_GRASP_POINT = 0.003  # m: `pick_block` stops this far over the seen grasp point (`offset_grasp`)

Seen = tuple[
    Grasp | None, NDArray[np.float64] | None, str
]  # the receiver's grasp, the seen pose, what was seen


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
