"""What the world needs to know about each arm's instrument at one instant.

The endpoint computes a `ToolState` per arm every step from the PHYSICAL joints (forward kinematics,
then the arm-to-board transform of the work cell), so the world reacts to where the tool really is,
not where the encoders say it is.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from pegbt.frames import Matrix, pose_from_axes
from pegbt.motion.kinematics import shaft_end_and_tip
from pegbt.physics import ArmPhysics
from pegbt.workcell import ToolGeometry

KINEMATICS_MEMO = (
    8192  # tool frames remembered: a transfer's ticks, which the phase simulator's worlds replay
)
Give = tuple[float, float, float, float]  # how far the tip yields along its -x, +x, -y, +y (m)
RIGID: Give = (0.0, 0.0, 0.0, 0.0)
Boxes = tuple[Matrix, Matrix, Matrix, Matrix, Matrix, float, tuple[float, ...]]  # `ToolState.boxes`
TOOL_PARTS = ("shaft", "wrist", "jaw")  # `ToolState.segments`, in order
Touching = tuple[bool, tuple[tuple[str, str], ...]]  # shafts touch; the other parts that do (`TOOL_PARTS`)


@dataclass(frozen=True)
class ToolState:
    """One instrument in the board frame (metres).

    `tip`: 4×4 tool-tip pose (the tool-tip frame of `pegbt.motion.kinematics`: z back up the tool, x the
    jaw-closing direction, y the jaw hinge). `jaw`: jaw opening angle (rad). `shaft`: (2, 3) the shaft's
    two ends, the remote centre of motion and the wrist pitch axis. `give`: how far (m) a push moves the
    tip along its -x, +x, -y and +y before the wrist's cables take up the load (`wrist_give`; rigid by
    default).
    """

    tip: Matrix
    jaw: float
    shaft: Matrix
    give: Give = RIGID
    _boxes: list[tuple[ToolGeometry, Boxes]] = field(
        default_factory=list, init=False, repr=False, compare=False
    )  # `boxes` of the last tool geometry asked
    _pegs: list[tuple[object, tuple[int, ...]]] = field(
        default_factory=list, init=False, repr=False, compare=False
    )  # `touched_pegs` of the last owner asked
    _touching: list[tuple[ToolState, object, Touching]] = field(
        default_factory=list, init=False, repr=False, compare=False
    )  # `touching` of the last other state and owner asked

    @classmethod
    def from_joints(cls, q: Matrix, jaw: float, arm_to_board: Matrix, give: Give = RIGID) -> ToolState:
        """The tool of an arm at joints `q` (its physical joints), by the arm's forward kinematics: the
        shaft runs from the remote centre (the base origin) to the wrist pitch axis.

        One state (read-only arrays) is kept for each exact set of inputs, by their bytes: the phase
        simulator's worlds replay one arm, each asking for the same tool again."""
        joints = np.asarray(q, dtype=float).tobytes()
        key = joints + arm_to_board.tobytes() + struct.pack("5d", jaw, *give)
        known = _STATES.get(key)
        if known is not None:
            return known
        shaft_end, tip = _frames(joints)
        rotation, origin = arm_to_board[:3, :3], arm_to_board[:3, 3]
        tip, shaft = arm_to_board @ tip, np.array([origin, rotation @ shaft_end + origin])
        tip.setflags(write=False)
        shaft.setflags(write=False)
        state = _STATES[key] = cls(tip=tip, jaw=float(jaw), shaft=shaft, give=give)
        if len(_STATES) > KINEMATICS_MEMO:
            del _STATES[next(iter(_STATES))]  # the oldest
        return state

    def jaw_hinge(self, tool: ToolGeometry) -> Matrix:
        """(3,) the wrist yaw axis, where the jaws hinge: `jaw_length` back up the tool from the tip."""
        return self.tip[:3, 3] + tool.jaw_length * self.tip[:3, 2]

    def segments(self, tool: ToolGeometry) -> tuple[Matrix, Matrix, Matrix]:
        """Start points (3, 3), end points (3, 3) and radii (3,) of shaft, wrist and jaw, for collisions."""
        points = np.concatenate((self.shaft, self.jaw_hinge(tool)[None], self.tip[None, :3, 3]))
        return points[:3], points[1:], np.array([tool.shaft_radius, tool.wrist_radius, tool.jaw_radius])

    def boxes(self, tool: ToolGeometry) -> Boxes:
        """`segments` with each one's bounding box (low, high corners, (3, 3) each), the boxes' greatest
        z (the tool's lowest reach, z pointing down) and the box around them all (its low x, y, z, then its
        high ones), for the world's contact checks; computed once for a state (never to be written to)."""
        if self._boxes and (self._boxes[0][0] is tool or self._boxes[0][0] == tool):
            return self._boxes[0][1]
        starts, ends, radii = self.segments(tool)
        reach = radii[:, None]
        high = np.maximum(starts, ends) + reach
        low = np.minimum(starts, ends) - reach
        whole = (*low.min(axis=0).tolist(), *high.max(axis=0).tolist())
        found = (starts, ends, radii, low, high, whole[5], whole)
        self._boxes[:] = [(tool, found)]
        return found

    def touched_pegs(self, owner: object, compute: Callable[[], tuple[int, ...]]) -> tuple[int, ...]:
        """The pegs this state touches, as `compute` finds them for `owner` (the world's work cell, from
        which alone it computes them), kept while the same owner asks again: the phase simulator's worlds,
        with one work cell, ask in turn for one state."""
        if self._pegs and self._pegs[0][0] is owner:
            return self._pegs[0][1]
        touched = compute()
        self._pegs[:] = [(owner, touched)]
        return touched

    def touching(self, other: ToolState, owner: object, compute: Callable[[], Touching]) -> Touching:
        """Whether this state's shaft touches `other`'s, and which other pairs of their segments touch, as
        `compute` finds them for `owner` (the world's work cell), kept while the same other state and owner
        ask again."""
        if self._touching and self._touching[0][0] is other and self._touching[0][1] is owner:
            return self._touching[0][2]
        found = compute()
        self._touching[:] = [(other, owner, found)]
        return found


_STATES: dict[bytes, ToolState] = {}  # `from_joints`' states, oldest first


@lru_cache(maxsize=KINEMATICS_MEMO)
def _frames(joints: bytes) -> tuple[Matrix, Matrix]:
    """`shaft_end_and_tip` of the joints given as their bytes, remembered (never to be written to): the
    phase simulator's worlds replay one arm's physical joints, each world asking for its tool again."""
    return shaft_end_and_tip(np.frombuffer(joints))


def wrist_give(physics: ArmPhysics, wrist_yaw: float, tool: ToolGeometry) -> Give:
    """How far (m) a push can move the tip along the tool's -x, +x, -y and +y within the wrist's cable
    play as it stands now, at wrist yaw (q6) `wrist_yaw`.

    Wrist yaw turns the jaws about the hinge (y): +q6 swings the tip along +x on the jaw's length. Wrist
    pitch (q5): +q5 swings it along -y on the wrist's length plus the jaw's, shortened as the jaw turns."""
    yaw_down, yaw_up = physics.play_room(5)  # q6
    pitch_down, pitch_up = physics.play_room(4)  # q5
    lever = abs(tool.wrist_length + tool.jaw_length * math.cos(wrist_yaw))
    return tool.jaw_length * yaw_down, tool.jaw_length * yaw_up, lever * pitch_up, lever * pitch_down


def tool_pointing_down(
    position: Matrix, yaw: float, jaw: float, remote_centre: Matrix, tool: ToolGeometry
) -> ToolState:
    """A tool whose jaw points straight down into the board at `position`, jaws closing along `yaw`.

    For scripted scenes and benchmarks: the shaft runs from the arm's remote centre to a wrist placed
    `wrist_length` from the jaw hinge towards it, as an unbent wrist would put it.
    """
    position = np.asarray(position, dtype=float)
    z = np.array([0.0, 0.0, -1.0])  # back up the tool: "up" is -z on the board
    tip = pose_from_axes([np.cos(yaw), np.sin(yaw), 0.0], z, position)
    hinge = position + tool.jaw_length * z
    towards_centre = (remote_centre - hinge) / np.linalg.norm(remote_centre - hinge)
    wrist = hinge + tool.wrist_length * towards_centre
    return ToolState(tip=tip, jaw=float(jaw), shaft=np.array([remote_centre, wrist], dtype=float))
