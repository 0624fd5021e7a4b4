"""Bags of a real dVRK recording (`../shared/data/dvrk`), written here by the `mcap-ros2-support` writer (a
lone MCAP file) and by `rosbags`' rosbag2 writer (sqlite3 and MCAP storage), never by pegbt, read through
`load_recording` and diagnosed as the same set-points in the folder layout are."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pegbt.physics.recording import dvrk_data_dir, load_recording

mcap_ros2_writer = pytest.importorskip("mcap_ros2.writer")
from rosbags.rosbag2 import StoragePlugin, Writer
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


def setpoint_streams(t, q_cmd, q_phy, arm="PSM1") -> dict[str, list[tuple[float, object]]]:
    return {
        f"/{arm}/setpoint_js": [(s, joint_state(s, q)) for s, q in zip(t, q_cmd)],
        f"/{arm}/fiducial_js": [(s, joint_state(s, q)) for s, q in zip(t, q_phy)],
    }


@pytest.fixture(scope="module")
def folder():
    path = dvrk_data_dir() / "random_smooth_grey1_PSM1"
    if not (path / "q_cmd.npy").exists():
        pytest.skip(f"real dVRK recordings not found at {path}")
    return load_recording(path).slice(0, 400)


def test_a_bag_of_the_folders_setpoints_diagnoses_as_the_folder(tmp_path, folder):
    from pegbt.sim2real.diagnose import diagnose
    from pegbt.sim2real.report import report_dict

    bag = write_mcap(tmp_path / "grey1.mcap", setpoint_streams(folder.t, folder.q_cmd, folder.q_phy))
    recording = load_recording(bag)
    assert recording.arm == "PSM1" and recording.n == folder.n
    np.testing.assert_array_equal(recording.q_cmd, folder.q_cmd)
    np.testing.assert_array_equal(recording.q_phy, folder.q_phy)
    np.testing.assert_allclose(recording.t, folder.t, rtol=0, atol=1e-6)
    assert recording.sampling == folder.sampling
    ours, theirs = (report_dict(diagnose(r, "ideal", n_bootstrap=0)) for r in (recording, folder))
    for report in (ours, theirs):
        report.pop("recording")
    assert [(e["effect"], e["joint"]) for e in ours["effects"]] == [
        (e["effect"], e["joint"]) for e in theirs["effects"]
    ]
    assert ours["effects"] and same(ours, theirs)


def same(a, b) -> bool:
    """Equal reports, numbers to 1e-6 (a bag's stamps are whole nanoseconds, the folder's float seconds)."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(map(same, a, b))
    if isinstance(a, float) and isinstance(b, (int, float)):
        return math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-6)
    return a == b


@pytest.mark.parametrize("storage", [StoragePlugin.SQLITE3, StoragePlugin.MCAP])
def test_a_rosbag2_folder_reads_as_the_folder(tmp_path, folder, storage):
    path = tmp_path / "bag"
    with Writer(path, version=9, storage_plugin=storage) as writer:
        for topic, source in (("/PSM2/setpoint_js", folder.q_cmd), ("/PSM2/fiducial_js", folder.q_phy)):
            connection = writer.add_connection(topic, JOINT_STATE, typestore=STORE)
            for stamp, q in zip(folder.t, source):
                message = STORE.types[JOINT_STATE](
                    header=STORE.types["std_msgs/msg/Header"](
                        stamp=STORE.types["builtin_interfaces/msg/Time"](
                            sec=math.floor(stamp), nanosec=round((stamp - math.floor(stamp)) * 1e9)
                        ),
                        frame_id="",
                    ),
                    name=[],
                    position=np.asarray(q, dtype=float),
                    velocity=np.zeros(0),
                    effort=np.zeros(0),
                )
                writer.write(connection, round(stamp * 1e9), STORE.serialize_cdr(message, JOINT_STATE))
    recording = load_recording(path)
    assert recording.arm == "PSM2"
    np.testing.assert_array_equal(recording.q_phy, folder.q_phy)
    np.testing.assert_array_equal(recording.q_cmd, folder.q_cmd)
