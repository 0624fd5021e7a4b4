"""`ZividCamera`: point clouds from a Zivid camera's ROS 2 driver, which captures only when asked, with the verbs
behaviours use on `CameraClient`.

The driver (zivid/zivid-ros `zivid_camera.cpp`; see `pegbt.sim.zivid`) captures when its `capture` service
(`std_srvs/srv/Trigger`) is called, publishes the frame on the point topics somebody subscribes to, then
responds. So a capture is one call: the cloud that arrives after the request went out is the one it took (a
camera that captures nothing unasked sends no other), matched by arrival, so a camera computer's clock need not
agree with this one's; a response with `success` false, no response, or no cloud soon after a response is an
error naming the service.

A full-resolution frame is 2.3 M points (Zivid 2), 16 bytes each, of which the board is about 130 k. The client
reads `/points/xyzrgba`: x, y, z and each pixel's colour, by which the looks keep the red points
(`pegbt.perception.colour`); `/points/xyz` is as large, its fourth word padding. A capture is a `ZividCloud`:
the image and its colours, views of the message, from which block search takes every pixel near a block
(`pegbt.perception.organised`), and, read as an array (by the board's registration), the valid points of
every `stride`-th row and column, copied out of the message when first asked for. Decoding runs on a
thread of its own, not on zenoh's, which also carry the arms' states.
"""

from __future__ import annotations

import threading
import time
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pegbt.clock import Clock, WallClock
from pegbt.errors import PegbtError
from pegbt.transport import codec
from pegbt.transport.camera import points_array
from pegbt.transport.ros2 import Ros2Wire, Topic
from pegbt.transport.ros2_service import Service, ServiceCall, ServiceFailed

CAPTURE = Service("/capture", codec.TRIGGER)
# rmw_qos_profile_default (the driver's `getQoSLatched(false)`): reliable, volatile, keep last 10
POINTS_XYZRGBA = Topic("/points/xyzrgba", codec.POINT_CLOUD2, depth=10, reliable=True)  # what pegbt reads
POINTS_XYZ = Topic("/points/xyz", codec.POINT_CLOUD2, depth=10, reliable=True)  # the same, padded for rgba
STRIDE = 2  # every 2nd row and column: 0.6 mm between points at the board (see `pegbt bench perception`)
CLOUD_GRACE_S = 2.0  # after the response, for the cloud published before it to arrive (a robot's machine)


class ZividCloud:
    """A Zivid capture: `grid` (H, W, 3) float32, the whole image (NaN where no depth), and `rgba` (H, W), each
    pixel's colour word (`0xAARRGGBB`; None from a cloud without colour), views of the message; `points`
    (N, 3) float32, the valid points of every `stride`-th row and column, thinned when first read (by the
    board's registration, say: block search reads the image), and what the cloud is as an array. Its length is
    the image's (width × height, as the PointCloud2 says), valid or not."""

    def __init__(
        self,
        stamp: float,
        grid: NDArray[np.float32],
        stride: int = STRIDE,
        rgba: NDArray[np.uint32] | None = None,
    ) -> None:
        if rgba is not None and rgba.shape != grid.shape[:2]:
            raise PegbtError(f"{rgba.shape} colours for a {grid.shape[:2]} image", field="rgba")
        self.stamp, self.grid, self.stride, self.rgba = stamp, grid, stride, rgba

    @cached_property
    def points(self) -> NDArray[np.float32]:
        points = np.ascontiguousarray(self.grid[:: self.stride, :: self.stride]).reshape(-1, 3)
        return points[np.isfinite(points).all(axis=1)]

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> NDArray[Any]:
        return points_array(self.points, dtype, copy)

    def __len__(self) -> int:
        return self.grid.shape[0] * self.grid.shape[1]

    def __repr__(self) -> str:
        rows, columns, _ = self.grid.shape
        return f"ZividCloud({rows}×{columns} image, thinned every {self.stride})"


def organised_cloud(payload: bytes, stride: int = STRIDE) -> ZividCloud:
    """An organised PointCloud2 as a `ZividCloud` thinned to every `stride`-th row and column."""
    stamp, grid, rgba = codec.organised_views(payload)
    return ZividCloud(stamp, grid, stride, rgba)


class ZividCapture:
    """A requested capture: `ready` once its cloud came or it failed; then `points` (a `ZividCloud`), or the
    error naming the service."""

    def __init__(self, camera: ZividCamera, call: ServiceCall) -> None:
        self.camera = camera
        self.call = call
        self.stamp: float | None = None
        self._points: ZividCloud | None = None
        self._error: PegbtError | None = None
        self._answered_at: float | None = None
        self._arrived = threading.Event()

    def fulfil(self, cloud: ZividCloud) -> None:
        self.stamp, self._points = cloud.stamp, cloud
        self._arrived.set()

    def refuse(self, error: PegbtError) -> None:
        if not self._arrived.is_set():
            self._error = error
            self._arrived.set()

    @property
    def sent(self) -> bool:
        """Whether the service took the request: it responded, or its cloud came (the driver publishes before
        it responds, so under load the cloud is often here first); until then, no cloud is on its way."""
        self._check_response()
        return self._answered_at is not None or self._points is not None

    @property
    def ready(self) -> bool:
        self._check_response()
        return self._arrived.is_set()

    def _check_response(self) -> None:
        """Note the response, then fail the capture on a refusal or once its cloud is overdue after it. The
        driver publishes before it responds, so the cloud may well have come first."""
        if not self.call.done or (self._answered_at is not None and self._arrived.is_set()):
            return
        service, topic = self.camera.service.name, self.camera.topic.name
        try:
            success, message = codec.decode_trigger_response(self.call.result())
        except PegbtError as error:
            self.refuse(ServiceFailed(f"capture failed: {error.message}", field=service))
            return
        if not success:
            self.refuse(ServiceFailed(f"capture failed: service {service} said: {message}", field=service))
            return
        now = time.monotonic()
        if self._answered_at is None:
            self._answered_at = now
        elif not self._arrived.is_set() and now - self._answered_at > self.camera.grace:
            self.refuse(
                ServiceFailed(
                    f"capture failed: service {service} responded, but no cloud came on {topic} within "
                    f"{self.camera.grace:g} s (the driver publishes only to topics with subscribers: is {topic} "
                    "routed here?)",
                    field=topic,
                )
            )

    def result(self, timeout: float) -> ZividCloud:
        """The cloud, waiting up to `timeout` s; `ServiceFailed` naming the service if none came."""
        deadline = time.monotonic() + timeout
        while not self.ready and time.monotonic() < deadline:
            self._arrived.wait(min(0.05, max(0.0, deadline - time.monotonic())))
        if self._error is not None:
            raise self._error
        if self._points is None:
            if not self.call.done:
                self.call.result(0.0)  # ServiceFailed: no response yet, naming the service
            raise ServiceFailed(
                f"capture failed: no cloud on {self.camera.topic.name} within {timeout:g} s",
                field=self.camera.topic.name,
            )
        return self._points

    @property
    def points(self) -> ZividCloud:
        return self.result(0.0)


class ZividCamera:
    """A Zivid driver's capture `service` and its cloud on `topic` through `wire`, each cloud thinned by
    `stride`; a capture waits up to `timeout` s, its cloud up to `grace` s after the service responded (a run
    that allows its endpoints to stall, `--liveness`, allows the camera as long)."""

    def __init__(
        self,
        wire: Ros2Wire,
        *,
        service: Service = CAPTURE,
        topic: Topic = POINTS_XYZRGBA,
        stride: int = STRIDE,
        clock: Clock | None = None,
        timeout: float = 10.0,
        grace: float = CLOUD_GRACE_S,
    ) -> None:
        if stride < 1:
            raise PegbtError(f"the thinning stride must be at least 1, got {stride}", field="stride")
        self.wire = wire
        self.service, self.topic, self.stride = service, topic, stride
        self.clock: Clock = clock or WallClock()
        self.timeout, self.grace = timeout, grace
        self.last_error: str | None = None
        self._pending: list[ZividCapture] = []
        self._lock = threading.Lock()
        wire.subscriber(topic, self._on_cloud)

    def _on_cloud(self, payload: bytes) -> None:
        """A cloud for every capture requested before it arrived; decoded off zenoh's thread."""
        with self._lock:
            waiting, self._pending = self._pending, []
        if waiting:
            threading.Thread(target=self._decode, args=(payload, waiting), name="zivid-decode").start()

    def _decode(self, payload: bytes, waiting: list[ZividCapture]) -> None:
        try:
            cloud = organised_cloud(payload, self.stride)
        except PegbtError as error:
            self.last_error = str(error)
            for handle in waiting:
                handle.refuse(ServiceFailed(f"capture failed: {error}", field=self.topic.name))
            return
        for handle in waiting:
            handle.fulfil(cloud)

    def capture_async(self) -> ZividCapture:
        """Call the capture service; poll the handle's `ready` in later ticks."""
        with self._lock:
            handle = ZividCapture(
                self, self.wire.call(self.service, codec.encode_trigger_request(), self.timeout)
            )
            self._pending.append(handle)
        return handle

    def capture(self) -> ZividCloud:
        """The next cloud, blocking up to `timeout` s."""
        return self.capture_async().result(self.timeout)
