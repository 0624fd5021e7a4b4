"""`pegbt sim --interface dvrk`'s streaming camera read by pegbt's client (`StreamingCamera`) over zenoh on
loopback: each point of a capture comes with the colour of what its ray met, as the simulator's camera sees the
same world (blocks and pegs red, board light grey, a tool in view dark grey)."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np

from pegbt.sim.camera import BOARD_GREY, RED, TOOL_GREY, DepthCamera
from pegbt.sim.dvrk_endpoint import DvrkEndpoint, DvrkEndpointConfig
from pegbt.sim.process import free_port
from pegbt.sim.world import World
from pegbt.transport.camera import ColouredPoints
from pegbt.transport.cloud_stream import StreamingCamera
from pegbt.transport.dvrk_topics import point_cloud_topic
from pegbt.transport.ros2 import BridgeWire
from pegbt.transport.session import client_settings, endpoint_settings, open_session

TOOL_IN_VIEW = (0.6, 0.0, 0.18, 0.0, 0.0, 0.0)  # PSM1 yawed over the board's edge, its tip near the board


def test_a_streamed_capture_has_the_colour_of_what_each_ray_met(tmp_path: Path) -> None:
    address = f"tcp/127.0.0.1:{free_port()}"
    sim_session = open_session(endpoint_settings([address]))
    config = DvrkEndpointConfig(log_path=tmp_path / "sim.jsonl", initial_joints={"PSM1": TOOL_IN_VIEW})
    endpoint = DvrkEndpoint(BridgeWire(sim_session), config, world=World(0), camera=DepthCamera(seed=0))
    thread = threading.Thread(target=endpoint.run, name="dvrk-sim", daemon=True)
    thread.start()
    session = open_session(client_settings([address]))
    try:
        camera = StreamingCamera(BridgeWire(session), point_cloud_topic(config.camera_topic), timeout=20.0)
        time.sleep(0.5)
        cloud = camera.capture()
    finally:
        session.close()
        endpoint.stop()
        thread.join(timeout=10)
        endpoint.close()
        sim_session.close()
    assert isinstance(cloud, ColouredPoints)
    assert endpoint.world is not None  # the arms stood still: the world is as the frame saw it
    points, rgba = DepthCamera(seed=1).capture_coloured(endpoint.world)
    assert len(cloud) == len(points) and np.isfinite(cloud.points).all()
    np.testing.assert_array_equal(cloud.rgba, rgba)  # the same pixels, each the colour of what it saw
    assert np.abs(cloud.points - points).max() < 0.003  # and where: the depth noise apart
    counts = {colour: np.count_nonzero(cloud.rgba == colour) for colour in (RED, BOARD_GREY, TOOL_GREY)}
    assert counts[RED] > 15_000 and counts[BOARD_GREY] > 50_000 and counts[TOOL_GREY] > 1_000
    assert sum(counts.values()) == len(cloud)
