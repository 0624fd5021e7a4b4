"""Bags of a real dVRK recording (`../shared/data/dvrk`), written here by the `mcap-ros2-support` writer (a
lone MCAP file) and by `rosbags`' rosbag2 writer (sqlite3 and MCAP storage), never by pegbt, read through
`load_recording` and diagnosed as the same set-points in the folder layout are."""

from __future__ import annotations

import math

import numpy as np
import pytest
from bag_helpers import JOINT_STATE, STORE, setpoint_streams, write_mcap
from rosbags.rosbag2 import StoragePlugin, Writer

from pegbt.physics.recording import dvrk_data_dir, load_recording


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
