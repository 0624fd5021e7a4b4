"""Choosing where an arm grips a block (paper §IV-B): six candidates, a yaw window, reachability, one rule.

Each block offers six grasps, two per flat edge on the wall between hole and edge (`Workcell.block`).
An arm keeps those whose gripper yaw lies within ±70° and that its inverse kinematics can reach (the
caller's `reachable` predicate), then takes the one farthest from the block's peg, so the jaw never
works behind the peg. A block resting centred on its peg leaves all six at the same distance (within
`PEG_DISTANCE_TIE`); then the one nearest to the arm wins, the same intent: the jaw works on the arm's
side of the peg and the tool never reaches over it. A handover receiver takes the candidate nearest to
itself.

Gripper yaw is the angle of the jaw-closing axis (tool x) about the arm's base z. The jaws are
symmetric, so a grasp and the same grasp turned by 180° are one: each candidate is expressed at the
yaw in (-90°, 90°], the smaller turn from the tool's neutral orientation.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.frames import apply_rigid, pose_from_axes, yaw_of
from pegbt.perception.blocks import BlockEstimate
from pegbt.workcell import Workcell, workcell

Reachable = Callable[[NDArray[np.float64]], ArrayLike]  # (n, 4, 4) tip poses in the arm frame -> (n,) bool
YAW_WINDOW = math.radians(70.0)
PEG_DISTANCE_TIE = 0.0005  # candidates this close to the farthest one from the peg count as equally far


@dataclass(frozen=True)
class Grasp:
    """One grasp candidate for one arm.

    `pose`: 4×4 tool-tip pose in the arm's base frame (z back up the tool, x the jaw-closing axis);
    `yaw`: its gripper yaw (rad, in (-90°, 90°]); `candidate`: index into the block's six candidates;
    `board_position`: the jaw tip in the board frame.
    """

    arm: str
    candidate: int
    pose: NDArray[np.float64]
    yaw: float
    board_position: NDArray[np.float64]

    @property
    def position(self) -> NDArray[np.float64]:
        """Jaw-tip position in the arm's base frame."""
        return self.pose[:3, 3]


def grasp_options(block_pose: ArrayLike, arm: str, cell: Workcell | None = None) -> list[Grasp]:
    """The six grasps of a block at `block_pose` (4×4, board frame) for `arm`, tool straight along the block's axis."""
    cell = cell or workcell()
    arm_from_board = cell.board_to_arm(arm)
    block_pose = np.asarray(block_pose, dtype=np.float64)
    candidates = cell.block.grasp_candidates
    up = -block_pose[:3, 2]  # block z points down into the board; the tool's z points back up it
    options = []
    for index, (local, jaw_yaw) in enumerate(zip(candidates.positions, candidates.jaw_yaw)):
        closing = block_pose[:3, :3] @ [math.cos(jaw_yaw), math.sin(jaw_yaw), 0.0]
        tip_in_board = pose_from_axes(closing, up, apply_rigid(block_pose, local))
        pose = arm_from_board @ tip_in_board
        yaw = yaw_of(pose)
        if not -math.pi / 2 < yaw <= math.pi / 2:  # the same grasp with the jaws swapped
            pose[:3, :2] = -pose[:3, :2]
            yaw = yaw_of(pose)
        options.append(Grasp(arm, index, pose, yaw, tip_in_board[:3, 3].copy()))
    return options


class GraspSelector:
    """One arm's grasp choices: its IK predicate and yaw window, set once, applied to every block.

    `reachable((n, 4, 4) tip poses in the arm frame) -> (n,) bool` is called once per choice with the
    options inside the yaw window.
    """

    def __init__(
        self, arm: str, reachable: Reachable, cell: Workcell | None = None, yaw_window: float = YAW_WINDOW
    ) -> None:
        self.cell = cell or workcell()
        self.arm = arm
        self.reachable = reachable
        self.yaw_window = yaw_window
        self._centre = self.cell.remote_centre(arm)[:2]

    def feasible(self, block_pose: ArrayLike) -> list[Grasp]:
        """The options of a block at `block_pose` within the yaw window that the arm can reach."""
        in_window = [
            option
            for option in grasp_options(block_pose, self.arm, self.cell)
            if abs(option.yaw) <= self.yaw_window
        ]
        if not in_window:
            return []
        accepted = np.asarray(self.reachable(np.array([option.pose for option in in_window])))
        if accepted.shape != (len(in_window),) or accepted.dtype != bool:
            raise PegbtError(
                f"expected one bool per pose ({len(in_window)}), got {accepted.dtype} of shape {accepted.shape}",
                field="reachable",
            )
        return [option for option, ok in zip(in_window, accepted) if ok]

    def pick(
        self,
        block: BlockEstimate,
        avoid: Collection[int] = (),
        acceptable: Callable[[Grasp], bool] | None = None,
    ) -> Grasp | None:
        """The paper's grasp of a located block: feasible, and farthest (in x, y) from the block's peg,
        ties going to the candidate nearest to the arm (its remote centre, in x, y). Candidates in `avoid`
        (one that just missed) are taken only if no other is feasible; candidates `acceptable` rejects (what
        the grasp is for cannot be done from it) never.

        For a block lying on the board, "its peg" is the nearest one. None if no candidate is feasible.
        """
        if not block.ok:
            raise PegbtError(f"the block's pose is not trustworthy ({block.reason})", field="block")
        pegs = self.cell.pegs.positions
        peg = (
            block.peg
            if block.peg is not None
            else int(np.argmin(np.linalg.norm(pegs - block.position[:2], axis=1)))
        )
        feasible = [
            option for option in self.feasible(block.pose) if acceptable is None or acceptable(option)
        ]
        options = [option for option in feasible if option.candidate not in avoid] or feasible
        if not options:
            return None
        from_peg = np.array([np.linalg.norm(option.board_position[:2] - pegs[peg]) for option in options])
        return self._nearest(
            [option for option, d in zip(options, from_peg) if d >= from_peg.max() - PEG_DISTANCE_TIE]
        )

    def receive(self, block_pose: ArrayLike) -> Grasp | None:
        """A handover receiver's grasp of the block held at `block_pose` (4×4, board frame): feasible,
        and nearest to the receiver. None if no candidate is feasible."""
        return self._nearest(self.feasible(block_pose))

    def _nearest(self, options: list[Grasp]) -> Grasp | None:
        """The option nearest (in x, y) to the arm's remote centre, or None if there are none."""
        return min(
            options, key=lambda option: np.linalg.norm(option.board_position[:2] - self._centre), default=None
        )


def select_grasp(
    block: BlockEstimate, arm: str, reachable: Reachable, cell: Workcell | None = None
) -> Grasp | None:
    """`GraspSelector(arm, reachable, cell).pick(block)`: the paper's grasp, with the default yaw window."""
    return GraspSelector(arm, reachable, cell).pick(block)
