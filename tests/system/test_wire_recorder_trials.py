"""`--record FILE.mcap` of whole runs, read back by the `mcap` library's readers and `mcap-ros2-support`'s
decoder, which know nothing of pegbt: a unilateral trial's every topic and type, and a calibration collection
recorded as a bag holding every sample of its folder."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from bag_helpers import read_all

mcap_reader = pytest.importorskip("mcap.reader")

REPO = Path(__file__).resolve().parents[2]
JOINT_STATE = "sensor_msgs/msg/JointState"


@pytest.mark.slow
def test_a_recorded_unilateral_trial_reads_back_with_every_topic_and_type(tmp_path):
    from pegbt.executive.logfile import read_tick_log
    from pegbt.executive.runoptions import RunOptions
    from pegbt.executive.session import run_tree_file

    path = tmp_path / "trial.mcap"
    output = run_tree_file(
        RunOptions(
            REPO / "trees" / "unilateral.yaml",
            tmp_path / "trial.jsonl",
            {"endpoint": "auto", "seed": 3},
            record=path,
            record_cloud_step=10,
        )
    )
    assert output.ok
    with path.open("rb") as stream:
        reader = mcap_reader.make_reader(stream)
        assert reader.get_header().profile == "ros2"
        metadata = {record.name: record.metadata for record in reader.iter_metadata()}
        summary = reader.get_summary()
    assert metadata["pegbt"]["log_time"].startswith("ns of simulated time")
    assert {schema.encoding for schema in summary.schemas.values()} == {"ros2msg"}
    assert {channel.message_encoding for channel in summary.channels.values()} == {"cdr"}
    messages = read_all(path)
    types = {topic: kind for topic, kind, _, _ in messages}
    expected = {
        **{
            f"/{arm}/{topic}": JOINT_STATE
            for arm in ("PSM1", "PSM2")
            for topic in ("measured_js", "setpoint_js")
        },
        **{
            f"/{arm}/jaw/{topic}": JOINT_STATE
            for arm in ("PSM1", "PSM2")
            for topic in ("measured_js", "setpoint_js")
        },
        **{f"/{arm}/operating_state": "crtk_msgs/msg/OperatingState" for arm in ("PSM1", "PSM2")},
        "/PSM1/follow_jt": "trajectory_msgs/msg/JointTrajectory",
        "/PSM1/jaw/move_jp": JOINT_STATE,
        "/camera/trigger": "std_msgs/msg/Empty",
        "/camera/depth/points": "sensor_msgs/msg/PointCloud2",
        "/pegbt/ticks": "std_msgs/msg/String",
        "/pegbt/events": "std_msgs/msg/String",
    }
    assert {topic: types.get(topic) for topic in expected} == expected
    for topic, kind, log_time, decoded in messages:
        if kind == JOINT_STATE and "/jaw/" not in topic:
            assert len(decoded.position) == 6, topic
        if kind in (JOINT_STATE, "sensor_msgs/msg/PointCloud2"):  # logged at its stamp: simulated time
            assert log_time == decoded.header.stamp.sec * 10**9 + decoded.header.stamp.nanosec
    last_tick = read_tick_log(tmp_path / "trial.jsonl").last_t
    assert max(log_time for _, _, log_time, _ in messages) <= (last_tick + 1.0) * 1e9  # not the wall clock
    clouds = [decoded for topic, _, _, decoded in messages if topic == "/camera/depth/points"]
    assert all(5_000 < cloud.width < 20_000 and len(cloud.data) == 16 * cloud.width for cloud in clouds)
    assert all([field.name for field in cloud.fields] == ["x", "y", "z", "rgba"] for cloud in clouds)  # kept
    ticks = [json.loads(decoded.data) for topic, _, _, decoded in messages if topic == "/pegbt/ticks"]
    log = read_tick_log(tmp_path / "trial.jsonl")
    assert sum(len(tick["changes"]) for tick in ticks) == len(log.transitions)
    assert ticks[-1]["type"] == "end" and ticks[-1]["outcome"] == "success"
    events = [json.loads(decoded.data) for topic, _, _, decoded in messages if topic == "/pegbt/events"]
    assert sum(event.get("kind") == "place" for event in events) == 12


@pytest.mark.slow
def test_a_collection_recorded_as_a_bag_holds_every_sample_of_its_folder(tmp_path):
    import subprocess
    import sys

    from pegbt.physics.recording import load_recording

    bag, folder = tmp_path / "collect.mcap", tmp_path / "collect"
    done = subprocess.run(
        [sys.executable, "-m", "pegbt", "calibrate", "collect", "--arm", "PSM2", "--minutes", "0.4"]
        + ["--record", str(bag), "--out", str(folder), "--log", str(tmp_path / "collect.jsonl")],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    from_bag, from_folder = load_recording(bag), load_recording(folder)  # the bag with its default topics
    assert from_bag.arm == "PSM2" and from_bag.n >= from_folder.n
    index = np.searchsorted(from_bag.t, from_folder.t - 1e-6)  # stamps hold whole nanoseconds
    np.testing.assert_allclose(from_bag.t[index], from_folder.t, atol=1e-9)
    np.testing.assert_allclose(from_bag.q_phy[index], from_folder.q_phy, atol=1e-12)
    np.testing.assert_allclose(from_bag.q_cmd[index], from_folder.q_cmd, atol=1e-12)
