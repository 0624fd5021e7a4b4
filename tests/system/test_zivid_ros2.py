"""The simulator's Zivid as a node of a ROS 2 graph on rmw_zenoh, used by zenoh-ros2-sdk (ROBOTIS's rmw_zenoh
client, not pegbt's code): its service client computes the Trigger service's type hash itself, calls `/capture`
and gets the response; its subscriber gets one organised full-resolution cloud, none before the call; and
pegbt's own client captures through the same graph. A zenoh session in router mode on 127.0.0.1 stands in
for rmw_zenohd."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from rmw_zenoh_helpers import await_ready, lines, partner

from pegbt.sim.process import SimProcess
from pegbt.transport.rmw_zenoh import type_hash
from pegbt.transport.ros2_service import ServiceFailed
from pegbt.transport.session import open_session, ros2_graph_settings
from pegbt.transport.wires import make_wire
from pegbt.transport.zivid_camera import ZividCamera


def test_a_ros2_node_calls_capture_and_gets_one_organised_cloud(router: int, messages_dir: Path) -> None:
    graph = f"tcp/127.0.0.1:{router}"
    with SimProcess(["--camera", "zivid", "--seed", "0"], interface="dvrk", router=graph):
        report = lines(
            partner(messages_dir, router, "capture", "/capture", "/points/xyzrgba", "20"), timeout=120
        )[-1]
        session = open_session(ros2_graph_settings([graph]))
        try:
            camera = ZividCamera(make_wire("rmw_zenoh", session, "", "pegbt"), timeout=20.0)
            time.sleep(1.0)
            points = camera.capture()
        finally:
            session.close()
    assert report["hash"] == type_hash("std_srvs/srv/Trigger")  # the SDK's own RIHS01 of the service
    assert report["response"] == {"success": True, "message": ""}
    assert report["unasked"] == 0
    (cloud,) = report["clouds"]
    assert (cloud["height"], cloud["width"], cloud["point_step"]) == (1200, 1944, 16)
    assert cloud["frame_id"] == "zivid_optical_frame"
    assert 50_000 < cloud["valid"] < 1200 * 1944 / 2
    thinned = np.asarray(points)  # the capture as an array: every 2nd row and column, valid points only
    assert np.isfinite(thinned).all() and 0.2 < len(thinned) / cloud["valid"] < 0.3


def test_pegbts_client_calls_a_ros2_nodes_trigger_service(router: int, messages_dir: Path) -> None:
    """zenoh-ros2-sdk's service server (it drops a request without rmw_zenoh's attachment) refuses the
    capture; pegbt's client says what it said, naming the service."""
    server = partner(messages_dir, router, "serve", "/capture", "camera not connected", "15")
    await_ready(server)
    session = open_session(ros2_graph_settings([f"tcp/127.0.0.1:{router}"]))
    try:
        camera = ZividCamera(make_wire("rmw_zenoh", session, "", "pegbt"), timeout=10.0)
        time.sleep(1.0)
        with pytest.raises(ServiceFailed) as raised:
            camera.capture()
    finally:
        session.close()
    assert raised.value.field == "/capture"
    assert "service /capture said: camera not connected" in raised.value.message
    assert lines(server, timeout=30)[-1] == {"served": 1}
