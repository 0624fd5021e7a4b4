"""What the endpoint needs of a world and a camera: small protocols, so the pegboard world and the depth
camera (written elsewhere) plug in without the endpoint knowing their insides.

Each control tick the endpoint hands the world one `ToolState` per arm, computed from the *physical*
joints (after the cable physics), and publishes whatever ground-truth events the world returns. A
world or camera that also has `inject_fault` receives the scheduled faults aimed at it (a slip, a
missed grasp, a burst of depth noise) at their time.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.motion.kinematics import link_frames

WRIST_FRAME = 3  # link frame at the wrist-pitch axis: the end of the shaft


@dataclass(frozen=True)
class ToolState:
    """One arm's tool, in the board frame: tip pose (4×4), jaw angle (rad), shaft from RCM to wrist (2×3)."""

    tip: NDArray[np.float64]
    jaw: float
    shaft: NDArray[np.float64]


class SimWorld(Protocol):
    """The pegboard and blocks."""

    def board_from_base(self, arm: str) -> NDArray[np.float64]:
        """4×4 transform from the arm's base (RCM) frame to the board frame."""
        ...

    def update(self, time: float, tools: Mapping[str, ToolState]) -> Sequence[Mapping[str, Any]]:
        """Advance to `time` with the tools where they are; return ground-truth events (JSON-able dicts)."""
        ...


class DepthCamera(Protocol):
    """A depth camera looking at the world."""

    def capture(self, time: float) -> NDArray[np.float32]:
        """(N, 3) points in metres, camera frame, as seen at `time`."""
        ...


@runtime_checkable
class FaultTarget(Protocol):
    """A plug-in that accepts scheduled faults."""

    def inject_fault(self, kind: str, params: Mapping[str, Any], time: float) -> None: ...


def tool_state(physical_joints: ArrayLike, jaw: float, board_from_base: ArrayLike) -> ToolState:
    """The tool of an arm at `physical_joints`, expressed in the board frame."""
    frames = link_frames(physical_joints)
    to_board = np.asarray(board_from_base, dtype=float)
    tip = to_board @ frames[-1]
    wrist = to_board @ frames[WRIST_FRAME][:, 3]
    rcm = to_board[:, 3]
    return ToolState(tip=tip, jaw=float(jaw), shaft=np.stack([rcm[:3], wrist[:3]]))
