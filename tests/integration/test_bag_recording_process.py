"""A bad bag given to the real `pegbt` process: one line naming the bag and the topic, never a traceback."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest


mcap_ros2_writer = pytest.importorskip("mcap_ros2.writer")
from rosbags.typesys import Stores, get_typestore

STORE = get_typestore(Stores.ROS2_JAZZY)
JOINT_STATE = "sensor_msgs/msg/JointState"
REPO = Path(__file__).resolve().parents[2]


def joint_state(t: float, q) -> dict:
    sec = math.floor(t)
    return {
        "header": {"stamp": {"sec": sec, "nanosec": round((t - sec) * 1e9)}, "frame_id": ""},
        "name": [f"q{i + 1}" for i in range(len(q))],
        "position": [float(v) for v in q],
        "velocity": [],
        "effort": [],
    }


def write_mcap(path: Path, streams: dict[str, list[tuple[float, object]]], kind: str = JOINT_STATE) -> Path:
    """A lone MCAP file written by mcap-ros2-support: `streams` maps a topic to (stamp, message) pairs."""
    with path.open("wb") as out:
        writer = mcap_ros2_writer.Writer(out)
        schema = writer.register_msgdef(kind, STORE.generate_msgdef(kind, ros_version=2)[0])
        for topic, messages in streams.items():
            for stamp, message in messages:
                writer.write_message(topic, schema, message, log_time=round(stamp * 1e9))
        writer.finish()
    return path


def stream_bag(tmp_path: Path) -> tuple[Path, np.ndarray]:
    """Commands at 100 Hz holding each of 60 set-points for 0.5 s; the tracker at 10 Hz, 5 ms off the grid."""
    t_cmd = np.arange(3000) * 0.01
    # within the arm's limits: insertion from 0.12 m, the rest from 0 rad
    scale, base = np.array([1.0, 1.0, 0.1, 1.0, 1.0, 1.0]), np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])
    q_cmd = np.repeat(np.linspace(0.0, 0.6, 60), 50)[:, None] * scale + base
    t_phy = np.arange(300) * 0.1 + 0.005
    q_phy = np.column_stack([np.interp(t_phy, t_cmd, q_cmd[:, j]) for j in range(6)]) + 0.001
    streams = {
        "/PSM1/setpoint_js": [(s, joint_state(s, q)) for s, q in zip(t_cmd, q_cmd)],
        "/tracker/PSM1": [(s, joint_state(s, q)) for s, q in zip(t_phy, q_phy)],
    }
    return write_mcap(tmp_path / "stream.mcap", streams), q_cmd


def test_the_cli_names_the_bag_and_topic(tmp_path):
    bag, _ = stream_bag(tmp_path)
    done = subprocess.run(
        [sys.executable, "-m", "pegbt", "sim2real", "diagnose", str(bag), "--phy", "/PSM1/nope"],
        check=False,
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
    )
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert str(bag) in done.stderr and "no topic /PSM1/nope" in done.stderr
