"""A depth camera that streams, as a RealSense does: a frame every period, with no trigger.

Each frame is exposed (the world frozen as it is) when due and rendered over the control periods that
follow, a few thousand rays at a time within a budget of wall time per period, so that ray casting never
delays the arms; a finished frame is an organised cloud (the camera's region of the image, row by row,
NaN for the pixels that see nothing), each point with the colour of what its ray met (an rgba field, as
`pegbt.transport.codec.encode_point_cloud` lays it out), stamped with its exposure time. If rendering falls behind, frames
are skipped, never queued: the stream's rate drops, its latency does not grow. A frame nobody listens for
is not exposed: rendering is the simulator's cost, not the camera's, and a subscriber sees the same
stream (its first frame is exposed when it joins, as a running camera's next one would be).
"""

from __future__ import annotations

import time

from pegbt.sim.interfaces import CameraExposure, SimWorld, StreamingCamera
from pegbt.transport import codec

RAYS_PER_CAST = 8192  # a part of a frame: about a millisecond of ray casting on this machine


class CameraStream:
    """Frames of `camera` looking at `world`, one every `period` s of simulated time, rendered within
    `budget` (a fraction) of each control period."""

    def __init__(
        self,
        camera: StreamingCamera,
        world: SimWorld,
        period: float,
        control_period: float,
        budget: float,
        frame_id: str,
    ) -> None:
        self._camera = camera
        self._world = world
        self._period = period
        self._slack = control_period / 2  # a frame is due at the control period nearest its time
        self._budget = budget * control_period  # s of wall time per control period for ray casting
        self._frame_id = frame_id
        self._exposure: CameraExposure | None = None
        self._stamp = 0.0
        self._next = 0.0

    def step(self, elapsed: float, stamp: float, *, listened: bool = True) -> bytes | None:
        """Expose a frame if one is due at `elapsed` (simulated s; `stamp` its epoch time) and someone
        `listened`, render within the budget; the encoded PointCloud2 of a frame finished now, else None."""
        if self._exposure is None and listened and elapsed >= self._next - self._slack:
            self._exposure = self._camera.expose(self._world, elapsed)
            self._stamp = stamp
            self._next = max(self._next, elapsed) + self._period
        exposure = self._exposure
        if exposure is None:
            return None
        deadline = time.perf_counter() + self._budget
        while not exposure.done and time.perf_counter() < deadline:
            exposure.cast(RAYS_PER_CAST)
        if not exposure.done:
            return None
        self._exposure = None
        rows, columns = self._camera.image_shape
        points = exposure.points().reshape(rows, columns, 3)
        rgba = exposure.colours().reshape(rows, columns)
        return codec.encode_point_cloud(self._stamp, points, self._frame_id, rgba=rgba)
