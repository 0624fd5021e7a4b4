"""The simulator's Zivid as a node of a ROS 2 graph on rmw_zenoh, used by zenoh-ros2-sdk (ROBOTIS's rmw_zenoh
client, not pegbt's code): its service client computes the Trigger service's type hash itself, calls `/capture`
and gets the response; its subscriber gets one organised full-resolution cloud, none before the call; and
pegbt's own client captures through the same graph. A zenoh session in router mode on 127.0.0.1 stands in
for rmw_zenohd."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import zenoh

from pegbt.sim.process import SimProcess, free_port
from pegbt.transport.rmw_zenoh import type_hash
from pegbt.transport.session import open_session, ros2_graph_settings
from pegbt.transport.wires import make_wire
from pegbt.transport.zivid_camera import ZividCamera

pytestmark = pytest.mark.system

PARTNER = Path(__file__).resolve().parents[1] / "ros2_partner.py"
MESSAGES = {  # what the partner's subscriber decodes a PointCloud2 with (ros2/common_interfaces)
    "builtin_interfaces/msg/Time.msg": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header.msg": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "sensor_msgs/msg/PointField.msg": (
        "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\n"
        "uint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n"
    ),
    "sensor_msgs/msg/PointCloud2.msg": (
        "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\n"
        "bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n"
    ),
}


@pytest.fixture
def router() -> Iterator[int]:
    port = free_port()
    config = zenoh.Config()
    config.insert_json5("mode", '"router"')
    config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    config.insert_json5("scouting/multicast/enabled", "false")
    with zenoh.open(config):
        yield port


@pytest.fixture
def messages_dir(tmp_path: Path) -> Path:
    for name, text in MESSAGES.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    return tmp_path


def test_a_ros2_node_calls_capture_and_gets_one_organised_cloud(
    router: int, messages_dir: Path, tmp_path: Path
) -> None:
    graph = f"tcp/127.0.0.1:{router}"
    with SimProcess(["--camera", "zivid", "--seed", "0"], interface="dvrk", router=graph):
        env = dict(
            os.environ, ZENOH_CONFIG_OVERRIDE='listen/endpoints=["tcp/127.0.0.1:0"]', ROS_DOMAIN_ID="0"
        )
        partner = subprocess.run(
            [
                sys.executable,
                str(PARTNER),
                str(messages_dir),
                str(router),
                "capture",
                "/capture",
                "/points/xyz",
                "20",
            ],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )
        assert partner.returncode == 0, partner.stderr
        report = json.loads(partner.stdout.splitlines()[-1])
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
    assert np.isfinite(points).all() and 0.2 < len(points) / cloud["valid"] < 0.3
