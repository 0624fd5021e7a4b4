"""`CameraClient`: point clouds from a depth camera on `camera/depth/points` (sensor_msgs/PointCloud2).

`capture_async()` asks for a cloud (a trigger message the simulator answers; a streaming real camera
ignores it) and returns a handle that later ticks poll; `capture()` blocks for it. The cloud that
answers is the one tagged with the trigger's id, or for an untagged camera the first one stamped at
or after the request. Nothing here blocks a tick: if no camera listens yet (a fresh session takes a
moment to see it), the trigger goes out on a later poll of the handle.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pegbt.clock import Clock, WallClock
from pegbt.errors import PegbtError
from pegbt.transport import codec
from pegbt.transport.arm import EndpointSilent
from pegbt.transport.keys import CameraKeys
from pegbt.transport.link import Link
from pegbt.transport.sequencing import Received

Cloud = tuple[float, NDArray[np.float32], NDArray[np.uint32] | None]


def points_array(points: NDArray[np.float32], dtype: Any = None, copy: bool | None = None) -> NDArray[Any]:
    """`points` as numpy's `__array__` protocol asks for them: a cloud object read as its (N, 3) points."""
    if dtype is not None and dtype != points.dtype:
        return points.astype(dtype)
    return points.copy() if copy else points


class ColouredPoints:
    """A cloud whose points have a colour: `points` (N, 3) float32, metres, camera frame, and `rgba` (N,),
    one word a point (`0xAARRGGBB`); read as an array, its points."""

    def __init__(self, points: NDArray[np.float32], rgba: NDArray[np.uint32]) -> None:
        if rgba.shape != (len(points),):
            raise PegbtError(f"{len(rgba)} colours for {len(points)} points", field="rgba")
        self.points, self.rgba = points, rgba

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray[Any]:
        return points_array(self.points, dtype, copy)

    def __len__(self) -> int:
        return len(self.points)

    def __repr__(self) -> str:
        return f"ColouredPoints({len(self.points)} points)"


class CaptureHandle:
    """A requested point cloud: `ready` in a later tick, then `points` ((N, 3) float32, metres, camera frame;
    a `ColouredPoints` if the camera sent colours).

    `sent` says whether the trigger has gone out; until a camera listens it has not, and each poll of
    `ready` tries again."""

    def __init__(self, camera: CameraClient, requested_at: float) -> None:
        self.camera = camera
        self.request_id: str | None = None
        self.requested_at = requested_at
        self.stamp: float | None = None
        self._points: NDArray[np.float32] | ColouredPoints | None = None
        self._arrived = threading.Event()

    def fulfil(self, stamp: float, points: NDArray[np.float32] | ColouredPoints) -> None:
        self.stamp, self._points = stamp, points
        self._arrived.set()

    @property
    def sent(self) -> bool:
        return self.request_id is not None

    @property
    def ready(self) -> bool:
        """Whether the cloud has come (sending the trigger first if a camera now listens)."""
        if not self.sent:
            self.camera.send_trigger(self)
        return self._arrived.is_set()

    def result(self, timeout: float) -> NDArray[np.float32] | ColouredPoints:
        """The cloud, waiting up to `timeout` seconds (a blocking call); `EndpointSilent` if none came."""
        deadline = time.monotonic() + timeout
        while not self.camera.send_trigger(self) and time.monotonic() < deadline:
            time.sleep(0.005)  # a blocking caller waits for a camera to listen; a tick polls `ready` instead
        if not self.sent:
            raise EndpointSilent(
                f"no camera listens on {self.camera.keys.trigger}; capture not sent",
                field=self.camera.keys.trigger,
            )
        if not self._arrived.wait(max(0.0, deadline - time.monotonic())):
            raise EndpointSilent(
                f"no point cloud answered capture {self.request_id} within {timeout} s", field="camera"
            )
        assert self._points is not None
        return self._points

    @property
    def points(self) -> NDArray[np.float32] | ColouredPoints:
        return self.result(0.0)


class CameraClient:
    """A depth camera on the link."""

    def __init__(
        self, link: Link, name: str = "camera", *, clock: Clock | None = None, timeout: float = 2.0
    ) -> None:
        self.keys = CameraKeys(name, link.namespace)
        self.clock: Clock = clock or WallClock()
        self.timeout = timeout
        self._pending: dict[str, CaptureHandle] = {}
        self._lock = threading.Lock()
        self._trigger = link.outlet(self.keys.trigger)
        self._points = link.inlet(self.keys.points, codec.decode_coloured_cloud, self._on_cloud)

    def _on_cloud(self, received: Received[Cloud]) -> None:
        stamp, xyz, rgba = received.value
        points = xyz if rgba is None else ColouredPoints(xyz, rgba)
        with self._lock:
            if received.tag is not None and received.tag.cause:
                answered = (
                    [self._pending.pop(received.tag.cause)] if received.tag.cause in self._pending else []
                )
            else:
                due = [request for request, h in self._pending.items() if h.requested_at <= stamp]
                answered = [self._pending.pop(request) for request in due]
        for handle in answered:
            handle.fulfil(stamp, points)

    def capture_async(self) -> CaptureHandle:
        """Request a cloud now; poll the handle's `ready` in later ticks. Never waits."""
        handle = CaptureHandle(self, self.clock.now())
        self.send_trigger(handle)
        return handle

    def send_trigger(self, handle: CaptureHandle) -> bool:
        """Send `handle`'s trigger if a camera listens (and it was not sent yet); whether it has gone out."""
        with self._lock:
            if handle.sent or not self._trigger.matched:
                return handle.sent
            tag = self._trigger.put(codec.encode_empty())
            handle.request_id = tag.command_id(self.keys.trigger)
            self._pending[handle.request_id] = handle
        return True

    def capture(self) -> NDArray[np.float32] | ColouredPoints:
        """A fresh cloud, blocking until it arrives (at most `timeout` seconds)."""
        return self.capture_async().result(self.timeout)
