"""A Zivid capture's bookkeeping in the order a loaded machine delivers it: the driver publishes the cloud, then
responds, so the cloud is often decoded before the service's response arrives."""

from __future__ import annotations

from types import SimpleNamespace

from pegbt.transport import codec
from pegbt.transport.ros2_service import ServiceCall
from pegbt.transport.zivid_camera import CAPTURE, POINTS_XYZRGBA, ZividCapture


def test_a_capture_whose_cloud_came_before_the_response_is_sent_and_ready() -> None:
    camera = SimpleNamespace(service=CAPTURE, topic=POINTS_XYZRGBA)
    call = ServiceCall(CAPTURE, timeout=10.0)
    capture = ZividCapture(camera, call)
    assert not capture.sent and not capture.ready
    cloud = SimpleNamespace(stamp=12.5)
    capture.fulfil(cloud)
    assert capture.ready and capture.sent  # the cloud is proof the driver took the request
    call.respond(codec.encode_trigger_response(True))
    assert capture.sent and capture.result(0.0) is cloud and capture.stamp == 12.5
