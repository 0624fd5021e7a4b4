"""The ROS 2 side of the rmw_zenoh tests: the message definitions `ros2_partner.py` hashes its types from,
a zenoh router standing in for rmw_zenohd, and the partner node run as a child process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import zenoh

from pegbt.sim.process import free_port

PARTNER = Path(__file__).with_name("ros2_partner.py")
# The ROS 2 definitions the partner computes its own type hashes from (comments do not enter RIHS01).
MESSAGES = {
    "builtin_interfaces/msg/Time.msg": "int32 sec\nuint32 nanosec\n",
    "std_msgs/msg/Header.msg": "builtin_interfaces/Time stamp\nstring frame_id\n",
    "sensor_msgs/msg/JointState.msg": (
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"
    ),
    "crtk_msgs/msg/OperatingState.msg": "std_msgs/Header header\nstring state\nbool is_homed\nbool is_busy\n",
    "crtk_msgs/msg/StringStamped.msg": "std_msgs/Header header\nstring string\n",
    "sensor_msgs/msg/PointField.msg": (
        "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\n"
        "uint8 FLOAT32=7\nuint8 FLOAT64=8\nstring name\nuint32 offset\nuint8 datatype\nuint32 count\n"
    ),
    "sensor_msgs/msg/PointCloud2.msg": (
        "std_msgs/Header header\nuint32 height\nuint32 width\nsensor_msgs/PointField[] fields\n"
        "bool is_bigendian\nuint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense\n"
    ),
}


def write_messages(folder: Path) -> Path:
    """`MESSAGES` written under `folder`, as the partner reads them."""
    for name, text in MESSAGES.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text)
    return folder


@contextmanager
def zenoh_router() -> Iterator[int]:
    """A zenoh router on 127.0.0.1, as rmw_zenohd would run (gossip on, multicast off); yields its port."""
    port = free_port()
    config = zenoh.Config()
    config.insert_json5("mode", '"router"')
    config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    config.insert_json5("scouting/multicast/enabled", "false")
    with zenoh.open(config):
        yield port


def partner(messages_dir: Path, router: int, *args: str) -> subprocess.Popen[str]:
    """`ros2_partner.py` in a child process on the router at port `router`."""
    env = dict(os.environ, ZENOH_CONFIG_OVERRIDE='listen/endpoints=["tcp/127.0.0.1:0"]', ROS_DOMAIN_ID="0")
    return subprocess.Popen(
        [sys.executable, str(PARTNER), str(messages_dir), str(router), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def lines(process: subprocess.Popen[str], timeout: float = 30.0) -> list[dict]:
    """The JSON lines a partner printed, once it ended successfully."""
    out, err = process.communicate(timeout=timeout)
    assert process.returncode == 0, err
    return [json.loads(line) for line in out.splitlines() if line.startswith("{")]


def await_ready(process: subprocess.Popen[str]) -> None:
    """Waits for a partner's `{"ready": true}` line."""
    assert process.stdout is not None
    line = process.stdout.readline()
    assert json.loads(line) == {"ready": True}, process.stderr.read() if process.stderr else line
