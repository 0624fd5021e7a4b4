"""Recordings read from ROS 2 bags: bags written here by the `mcap-ros2-support` writer (a lone MCAP file)
and by `rosbags`' rosbag2 writer (sqlite3 and MCAP storage), never by pegbt, read through
`load_recording` and diagnosed as the same set-points in the folder layout are."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bag_helpers import JOINT_STATE, STORE, joint_state, setpoint_streams, stream_bag, write_mcap

from pegbt.errors import PegbtError
from pegbt.physics.recording import load_recording

mcap_ros2_writer = pytest.importorskip("mcap_ros2.writer")


def test_each_physical_sample_takes_the_latest_command_and_settled_keeps_held_ones(tmp_path):
    bag, q_cmd = stream_bag(tmp_path)
    every = load_recording(bag, phy="/tracker/PSM1")
    assert every.n == 300 and every.arm == "PSM1"
    expected = q_cmd[np.floor((np.arange(300) * 0.1 + 0.005) / 0.01 + 1e-9).astype(int)]
    np.testing.assert_array_equal(every.q_cmd, expected)
    settled = load_recording(bag, phy="/tracker/PSM1", settled=0.3)
    held = (np.arange(300) * 0.1 + 0.005) % 0.5  # time since each command began
    assert settled.n == int((held >= 0.3).sum()) == 120
    np.testing.assert_allclose(settled.t % 0.5, 0.305, atol=0.1)


def test_bad_bags_say_which_file_and_topic(tmp_path):
    bag, _ = stream_bag(tmp_path)
    with pytest.raises(
        PegbtError, match=r"no topic /PSM1/fiducial_js in the bag \(it has /PSM1/setpoint_js, /tracker/PSM1\)"
    ) as raised:
        load_recording(bag)
    assert raised.value.file == str(bag) and raised.value.field == "/PSM1/fiducial_js"
    wrong = write_mcap(
        tmp_path / "wrong.mcap",
        {"/PSM1/setpoint_js": [(1.0, {"data": "x"})], "/PSM1/fiducial_js": [(1.0, {"data": "y"})]},
        kind="std_msgs/msg/String",
    )
    with pytest.raises(
        PegbtError, match="topic /PSM1/setpoint_js holds std_msgs/msg/String, not sensor_msgs/msg/JointState"
    ):
        load_recording(wrong)
    t = np.arange(60.0)
    late = setpoint_streams(t + 100.0, np.ones((60, 6)), np.ones((60, 6)))
    late["/PSM1/fiducial_js"] = [(s, joint_state(s, np.ones(6))) for s in t]
    with pytest.raises(PegbtError, match="no overlap in time: every /PSM1/fiducial_js message"):
        load_recording(write_mcap(tmp_path / "late.mcap", late))
    with pytest.raises(PegbtError, match="the bag is empty"):
        load_recording(write_mcap(tmp_path / "empty.mcap", {}))
    (tmp_path / "junk.mcap").write_bytes(b"not an mcap file at all")
    with pytest.raises(PegbtError, match="not a readable MCAP file"):
        load_recording(tmp_path / "junk.mcap")
    with pytest.raises(PegbtError, match="not a bag"):
        load_recording(write_recording_folder(tmp_path), cmd="/PSM1/setpoint_js")
    whole = (tmp_path / "empty.mcap").read_bytes()
    for size in (0, 8, len(whole) // 2):  # nothing; mcap's magic alone; cut before a channel
        (tmp_path / "short.mcap").write_bytes(whole[:size])
        with pytest.raises(PegbtError, match=rf"not a readable MCAP file: it ends after {size} bytes"):
            load_recording(tmp_path / "short.mcap")
    folder = tmp_path / "broken_bag"
    folder.mkdir()
    (folder / "metadata.yaml").write_text("rosbag2_bagfile_information: [\n")
    with pytest.raises(PegbtError, match="not a readable rosbag2 folder: YAML syntax") as raised:
        load_recording(folder)
    assert "\n" not in str(raised.value) and raised.value.file == str(folder / "metadata.yaml")
    assert raised.value.line == 2


def test_messages_logged_out_of_stamp_order_or_resent_are_read_once_in_stamp_order(tmp_path):
    t = np.arange(100) * 0.01
    q = np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0]) + np.linspace(0.0, 0.5, 100)[:, None] * [1, 1, 0.1, 1, 1, 1]
    streams = setpoint_streams(t, q, q + 0.001)
    shuffled = np.random.default_rng(0).permutation(100)
    streams["/PSM1/fiducial_js"] = [streams["/PSM1/fiducial_js"][i] for i in shuffled]
    streams["/PSM1/setpoint_js"] += streams["/PSM1/setpoint_js"][40:45]  # re-sent unchanged
    read = load_recording(write_mcap(tmp_path / "shuffled.mcap", streams))
    np.testing.assert_allclose(read.t, t, rtol=0, atol=1e-9)  # stamps are whole nanoseconds
    np.testing.assert_array_equal(read.q_cmd, q)
    np.testing.assert_array_equal(read.q_phy, q + 0.001)
    streams["/PSM1/fiducial_js"][7] = (5.0, joint_state(5.0, np.ones(5)))
    with pytest.raises(PegbtError, match="message 7 of /PSM1/fiducial_js has 5 joint positions"):
        load_recording(write_mcap(tmp_path / "five.mcap", streams))


def write_recording_folder(tmp_path: Path) -> Path:
    from pegbt.physics.recording import write_recording

    q = np.linspace(0, 1, 60)[:, None] * np.ones(6)
    return write_recording(tmp_path / "folder", q, q, np.arange(60.0), "PSM1")


def test_a_bag_cut_short_reads_up_to_the_cut(tmp_path):
    t = np.arange(400) * 0.5
    q = np.linspace(0.0, 0.5, 400)[:, None] * [1.0, 1.0, 0.1, 1.0, 1.0, 1.0] + [
        0.0,
        0.0,
        0.1,
        0.0,
        0.0,
        0.0,
    ]  # in limits
    path = tmp_path / "whole.mcap"
    with path.open("wb") as out:
        writer = mcap_ros2_writer.Writer(out, chunk_size=4096)
        schema = writer.register_msgdef(JOINT_STATE, STORE.generate_msgdef(JOINT_STATE, ros_version=2)[0])
        for stamp, row in zip(t, q):  # interleaved, as a recorder writes them
            for topic in ("/PSM1/setpoint_js", "/PSM1/fiducial_js"):
                writer.write_message(topic, schema, joint_state(stamp, row), log_time=round(stamp * 1e9))
        writer.finish()
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    recording = load_recording(cut)
    assert 100 < recording.n < 400
    np.testing.assert_array_equal(recording.q_phy, q[: recording.n])
