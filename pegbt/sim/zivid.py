"""A Zivid 2 camera as `ros2 run zivid_camera zivid_camera` serves it: a cloud only when asked.

From zivid/zivid-ros (`README.md`, `zivid_camera/src/zivid_camera.cpp`):
- the `capture` service (`std_srvs/srv/Trigger`) captures a frame and publishes it before it responds
  (`captureServiceHandler` → `invokeCaptureAndPublishFrame` → `publishFrame`); a failure is a response with
  `success` false and the exception's text as `message` (`utility.hpp`,
  `runFunctionAndCatchExceptionsForTriggerResponse`);
- the frame is an organised, full-resolution `sensor_msgs/PointCloud2` in the camera's optical frame
  (`frame_id` parameter, default `zivid_optical_frame`), metres, NaN where a pixel has no depth, never dense,
  16 bytes a point: `points/xyzrgba` with x, y, z and a UINT32 rgba (`makePointCloud2Msg`; here each pixel
  the colour of what its ray met, `pegbt.sim.camera`), `points/xyz` with x, y, z and 4 bytes of padding
  (`publishPointCloudXYZ`, `Zivid::PointXYZW`); its stamp is taken after the capture (`makeHeader`);
- a topic nobody subscribes to gets nothing (`shouldPublishPointsXYZ`, `get_subscription_count() > 0`); with
  no subscriber at all, the capture still succeeds and nothing is sent (`publishFrame`'s warning);
- the node's names are relative, so run as `ros2 run zivid_camera zivid_camera` they are `/capture`,
  `/points/xyzrgba` and `/points/xyz`.

A Zivid 2 images 1944 × 1200 pixels (Zivid 2 datasheet); here it sits at the work cell's camera pose with its
pinhole figures, every pixel ray-cast (`DepthCamera(full_frame=True)`), so a pixel that sees nothing is NaN.
A capture freezes the world when its request is taken, its rays are cast within a budget of each control
period (as the streaming camera's), and the cloud is developed, encoded and published, then the request
answered, on a thread of its own: 2.3 M points take longer than a control period to pack.
"""

from __future__ import annotations

import collections
import dataclasses
import threading
import time

from pegbt.sim.interfaces import CameraExposure, SimWorld, StreamingCamera
from pegbt.transport import codec
from pegbt.transport.ros2 import Ros2Wire
from pegbt.transport.ros2_service import ServiceRequest
from pegbt.transport.zivid_camera import CAPTURE, POINTS_XYZ, POINTS_XYZRGBA
from pegbt.workcell import CameraModel

ZIVID2_WIDTH, ZIVID2_HEIGHT = 1944, 1200  # Zivid 2: 2.3 MP
ZIVID_FRAME = "zivid_optical_frame"
RAYS_PER_CAST = 8192  # a part of a frame: about a millisecond of ray casting on this machine


def zivid2_model(camera: CameraModel) -> CameraModel:
    """A Zivid 2 where the work cell's camera is, with its focal lengths, centred on its own image."""
    return dataclasses.replace(
        camera, width=ZIVID2_WIDTH, height=ZIVID2_HEIGHT, cx=ZIVID2_WIDTH / 2, cy=ZIVID2_HEIGHT / 2
    )


class ZividDriver:
    """The driver's `capture` service and point cloud topics on `wire`, rendering `camera` (full frame) in
    `world`. `step` is called every control period by the simulator's loop."""

    def __init__(
        self, wire: Ros2Wire, camera: StreamingCamera, world: SimWorld, control_period: float, budget: float
    ) -> None:
        self._camera = camera
        self._world = world
        self._budget = budget * control_period  # s of wall time per control period for ray casting
        self._requests: collections.deque[ServiceRequest] = collections.deque()
        self._request: ServiceRequest | None = None
        self._exposure: CameraExposure | None = None
        self._packing: threading.Thread | None = None
        self._finished = threading.Event()
        self._xyzrgba = wire.publisher(POINTS_XYZRGBA)
        self._xyz = wire.publisher(POINTS_XYZ)
        self._server = wire.serve(CAPTURE, self._requests.append)

    def step(self, elapsed: float) -> bool:
        """Take the next request, or cast the current one's rays within the budget; True once a capture has
        been published and answered since the last call (its noise burst, if any, is in the world's log)."""
        finished = self._finished.is_set()
        if finished:
            self._finished.clear()
            self._packing = None
        if self._packing is not None:
            return False
        if self._exposure is None:
            if not self._requests:
                return finished
            self._request = self._requests.popleft()
            self._exposure = self._camera.expose(self._world, elapsed)
        exposure = self._exposure
        deadline = time.perf_counter() + self._budget
        while not exposure.done and time.perf_counter() < deadline:
            exposure.cast(RAYS_PER_CAST)
        if exposure.done:
            request, self._request, self._exposure = self._request, None, None
            assert request is not None  # taken with its exposure
            self._packing = threading.Thread(
                target=self._publish, args=(exposure, request), name="zivid-capture", daemon=True
            )
            self._packing.start()
        return finished

    def _publish(self, exposure: CameraExposure, request: ServiceRequest) -> None:
        """Develop the frame, publish it on the topics somebody subscribes to, then answer the request."""
        try:
            targets = [p for p in (self._xyzrgba, self._xyz) if p.matched]
            if targets:
                rows, columns = self._camera.image_shape
                points = exposure.points().reshape(rows, columns, 3)
                stamp = time.time()  # the driver stamps a frame once captured
                if self._xyzrgba in targets:
                    rgba = exposure.colours().reshape(rows, columns)
                    self._xyzrgba.put(codec.encode_organised_cloud(stamp, points, ZIVID_FRAME, rgba))
                if self._xyz in targets:
                    self._xyz.put(codec.encode_organised_cloud(stamp, points, ZIVID_FRAME))
            request.reply(codec.encode_trigger_response(True))
        finally:
            self._finished.set()

    def close(self) -> None:
        if self._packing is not None:
            self._packing.join()
        for request in (*([self._request] if self._request else []), *self._requests):
            request.reply(codec.encode_trigger_response(False, "the camera node is shutting down"))
        self._server.close()
        self._xyzrgba.close()
        self._xyz.close()
