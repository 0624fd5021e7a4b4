"""ROS 2 bags and MCAP files for the recording and recorder tests, written and read by the mcap and
rosbags libraries, never by pegbt."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from mcap import reader as mcap_reader
from mcap_ros2 import writer as mcap_ros2_writer
from mcap_ros2.decoder import DecoderFactory
from rosbags.typesys import Stores, get_typestore

STORE = get_typestore(Stores.ROS2_JAZZY)


JOINT_STATE = "sensor_msgs/msg/JointState"


def joint_state(t: float, q) -> dict:
    sec = math.floor(t)
    return {
        "header": {"stamp": {"sec": sec, "nanosec": round((t - sec) * 1e9)}, "frame_id": ""},
        "name": [f"q{i + 1}" for i in range(len(q))],
        "position": [float(v) for v in q],
        "velocity": [],
        "effort": [],
    }


def write_mcap(
    path: Path,
    streams: dict[str, list[tuple[float, object]]],
    kind: str = JOINT_STATE,
    chunk_size: int = 2**20,
) -> Path:
    """A lone MCAP file written by mcap-ros2-support: `streams` maps a topic to (stamp, message) pairs; a
    reader holds a chunk of `chunk_size` bytes (the library's default) at a time."""
    with path.open("wb") as out:
        writer = mcap_ros2_writer.Writer(out, chunk_size=chunk_size)
        schema = writer.register_msgdef(kind, STORE.generate_msgdef(kind, ros_version=2)[0])
        for topic, messages in streams.items():
            for stamp, message in messages:
                writer.write_message(topic, schema, message, log_time=round(stamp * 1e9))
        writer.finish()
    return path


def setpoint_streams(t, q_cmd, q_phy, arm="PSM1") -> dict[str, list[tuple[float, object]]]:
    return {
        f"/{arm}/setpoint_js": [(s, joint_state(s, q)) for s, q in zip(t, q_cmd)],
        f"/{arm}/fiducial_js": [(s, joint_state(s, q)) for s, q in zip(t, q_phy)],
    }


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


def read_all(path: Path) -> list[tuple[str, str, int, object]]:
    """(topic, schema name, log time, decoded message) of every message, by mcap's seeking reader."""
    with path.open("rb") as stream:
        reader = mcap_reader.make_reader(stream, decoder_factories=[DecoderFactory()])
        return [
            (channel.topic, schema.name, message.log_time, decoded)
            for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False)
        ]
