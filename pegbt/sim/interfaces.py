"""What the endpoint needs of a world and a camera: `pegbt.sim.world.World` and
`pegbt.sim.camera.DepthCamera` satisfy these protocols, and the endpoint knows nothing else of them,
so an endpoint without a world (`pegbt sim --no-world`) never imports them (nor Open3D), and a test may
hand it a world of its own.

Each control tick the endpoint hands the world one `ToolState` per arm, computed from the *physical*
joints (after the cable physics), publishes the events the world appended to its log, and holds each
jaw where the world says a gripped block stops it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Protocol, TypedDict

import numpy as np
from numpy.typing import NDArray

from pegbt.sim.events import Event, EventLog
from pegbt.sim.tools import ToolState
from pegbt.workcell import Workcell


class WorldSnapshot(TypedDict):
    """JSON-ready ground truth: simulated time and each block's `to_dict()`."""

    time: float
    blocks: list[dict[str, object]]


class SimWorld(Protocol):
    """The pegboard and blocks, in the work cell's board frame; times are simulated seconds from 0."""

    cell: Workcell
    events: EventLog

    def update(self, time: float, tools: Mapping[str, ToolState]) -> Sequence[Event]:
        """Advance to `time` with the tools where they are; the new events are also appended to `events`."""
        ...

    def arm_to_board(self, arm: str) -> NDArray[np.float64]:
        """(4, 4) where `arm`'s base truly stands in the board frame (its tools are placed by it)."""
        ...

    def jaw_stop(self, arm: str) -> float | None:
        """The angle below which a gripped block stops `arm`'s jaw; None when it grips nothing."""
        ...

    def snapshot(self) -> WorldSnapshot:
        """JSON-ready ground truth: time and every block (state, peg, holders, pose)."""
        ...


class SimCamera(Protocol):
    """A depth camera looking at the world."""

    def capture(self, world: SimWorld, time: float | None = None) -> NDArray[np.float32]:
        """(N, 3) points in metres, camera frame, as the world is at `time`."""
        ...

    def capture_coloured(
        self, world: SimWorld, time: float | None = None
    ) -> tuple[NDArray[np.float32], NDArray[np.uint32]]:
        """`capture`'s points and each one's colour, a rgba word (`0xAARRGGBB`)."""
        ...


class CameraExposure(Protocol):
    """One capture under way (`pegbt.sim.camera.Exposure`): cast its rays a part at a time, then develop it."""

    @property
    def done(self) -> bool:
        """Whether every ray has been cast."""
        ...

    def cast(self, count: int) -> None:
        """Cast the next `count` rays."""
        ...

    def points(self) -> NDArray[np.float32]:
        """Every pixel's point (n, 3), row by row over the camera's `image_shape`; NaN where nothing is hit."""
        ...

    def colours(self) -> NDArray[np.uint32]:
        """Every pixel's rgba word, as `points` orders them; 0 where nothing is hit."""
        ...


class StreamingCamera(Protocol):
    """A depth camera that renders a frame in parts, so that streaming never stalls a control loop."""

    image_shape: tuple[int, int]

    def expose(self, world: SimWorld, time: float | None = None) -> CameraExposure:
        """A capture of the world as it is now, at simulated `time`."""
        ...
