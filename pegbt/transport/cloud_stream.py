"""`StreamingCamera`: point clouds from a depth camera that streams sensor_msgs/PointCloud2 on its own (a
RealSense on `/camera/camera/depth/color/points`), with the verbs behaviours use on `CameraClient`.

Nobody triggers it: a capture is the first cloud stamped after the request. Invalid points (NaN, as a
RealSense sends for pixels without depth) are dropped; a cloud with colour (an `rgba` or `rgb` field,
`codec.decode_coloured_cloud`) is a `ColouredPoints`, each valid point's colour kept beside it. The camera's
topic is subscribed only while a capture waits: a cloud of a few MB ten times a second, received, copied out
of zenoh and decoded by a callback holding the GIL, would otherwise take time from the tick and the planning
threads for nothing.
"""

from __future__ import annotations

import threading

import numpy as np
from numpy.typing import NDArray

from pegbt.clock import Clock, WallClock
from pegbt.errors import PegbtError
from pegbt.transport import codec
from pegbt.transport.arm import EndpointSilent
from pegbt.transport.camera import ColouredPoints
from pegbt.transport.ros2 import Ros2Wire, Topic, TopicSubscriber

CAPTURE_TIMEOUT = 2.0  # s a streaming camera may take to send a cloud stamped after a capture's request


class StreamedCapture:
    """A requested cloud: `ready` once one stamped after `requested_at` came; then `points` ((N, 3) float32,
    a `ColouredPoints` if the camera sent colours)."""

    sent = True  # nothing to send: the camera streams

    def __init__(self, camera: StreamingCamera, requested_at: float) -> None:
        self.camera = camera
        self.requested_at = requested_at
        self.stamp: float | None = None
        self._points: NDArray[np.float32] | ColouredPoints | None = None
        self._arrived = threading.Event()
        self.lags: list[float] = []  # s from stamp to arrival of each cloud that came stamped before it

    def fulfil(self, stamp: float, points: NDArray[np.float32] | ColouredPoints) -> None:
        self.stamp, self._points = stamp, points
        self._arrived.set()

    @property
    def ready(self) -> bool:
        return self._arrived.is_set()

    def result(self, timeout: float) -> NDArray[np.float32] | ColouredPoints:
        """The cloud, waiting up to `timeout` s; `EndpointSilent` if none came."""
        if not self._arrived.wait(timeout):
            came = (
                f": {len(self.lags)} came, stamped at least {min(self.lags):.3f} s before they arrived (the "
                "camera's computer stamps them: is its clock behind this one's?)"
                if self.lags
                else ""
            )
            raise EndpointSilent(
                f"no point cloud on {self.camera.topic.name} stamped after the request within {timeout:g} s"
                + came,
                field=self.camera.topic.name,
            )
        assert self._points is not None
        self.camera.settle()
        return self._points

    @property
    def points(self) -> NDArray[np.float32] | ColouredPoints:
        return self.result(0.0)


class StreamingCamera:
    """A streaming depth camera on `wire`'s `topic`, listened to while a capture waits."""

    def __init__(
        self, wire: Ros2Wire, topic: Topic, *, clock: Clock | None = None, timeout: float = CAPTURE_TIMEOUT
    ) -> None:
        self.topic = topic
        self.clock: Clock = clock or WallClock()
        self.timeout = timeout
        self._wire = wire
        self._pending: list[StreamedCapture] = []
        self._lock = threading.Lock()
        self._listening = threading.Lock()  # held while the subscriber is declared or undeclared
        self._subscriber: TopicSubscriber | None = None
        self.last_error: str | None = None

    @property
    def listening(self) -> bool:
        """Whether the camera's topic is subscribed (a capture waits, or one was answered and not yet taken)."""
        return self._subscriber is not None

    def settle(self) -> None:
        """Unsubscribe once no capture waits. Called on the thread that takes a cloud, never on zenoh's
        callback thread, which may not undeclare the subscriber it is running for."""
        with self._listening:
            with self._lock:
                if self._pending or self._subscriber is None:
                    return
                subscriber, self._subscriber = self._subscriber, None
            subscriber.close()

    def _on_cloud(self, payload: bytes) -> None:
        with self._lock:
            if not self._pending:
                return
        try:
            stamp, points, rgba = codec.decode_coloured_cloud(payload)
        except PegbtError as error:
            self.last_error = str(error)
            return
        with self._lock:
            answered = [handle for handle in self._pending if handle.requested_at < stamp]
            self._pending = [handle for handle in self._pending if handle.requested_at >= stamp]
            arrived = self.clock.now()
            for handle in self._pending:
                handle.lags.append(arrived - stamp)
        if answered:
            seen = np.isfinite(points).all(axis=1)
            valid = points[seen] if rgba is None else ColouredPoints(points[seen], rgba[seen])
            for handle in answered:
                handle.fulfil(stamp, valid)

    def capture_async(self) -> StreamedCapture:
        """Ask for the next cloud stamped from now on; poll the handle's `ready` in later ticks."""
        handle = StreamedCapture(self, self.clock.now())
        with self._listening:
            with self._lock:
                self._pending.append(handle)
            if self._subscriber is None:
                self._subscriber = self._wire.subscriber(self.topic, self._on_cloud)
        return handle

    def capture(self) -> NDArray[np.float32] | ColouredPoints:
        """The next cloud, blocking up to `timeout` s."""
        return self.capture_async().result(self.timeout)
