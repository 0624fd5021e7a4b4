"""The one recording module: which arm, which sampling, where the problem is."""

import json

import numpy as np
import pytest

from pegbt.errors import PegbtError
from pegbt.physics.recording import RecordingWriter, load_recording, write_recording


def _arrays(n: int = 60, interval: float = 0.5):
    scale = np.array([0.5, 0.5, 0.05, 0.5, 0.5, 0.5])  # within the arm's limits (rad, m)
    centre = np.array([0.0, 0.0, 0.15, 0.0, 0.0, 0.0])
    q_cmd = centre + scale * np.column_stack([np.sin(np.arange(n) * 0.3 + k) for k in range(6)])
    return q_cmd, q_cmd + 0.01, interval * np.arange(n)


def test_the_arm_comes_from_meta_json_else_from_the_name(tmp_path):
    q_cmd, q_phy, t = _arrays()
    assert (
        load_recording(write_recording(tmp_path / "random_smooth_grey2_PSM2", q_cmd, q_phy, t)).arm == "PSM2"
    )
    assert load_recording(write_recording(tmp_path / "named_PSM2", q_cmd, q_phy, t, arm="PSM1")).arm == "PSM1"
    assert load_recording(write_recording(tmp_path / "unnamed", q_cmd, q_phy, t)).arm is None
    (tmp_path / "unnamed" / "meta.json").write_text(json.dumps({"arm": "ECM"}))
    with pytest.raises(PegbtError, match="unknown arm 'ECM'") as error:
        load_recording(tmp_path / "unnamed")
    assert error.value.file == str(tmp_path / "unnamed" / "meta.json") and error.value.field == "arm"


def test_a_stream_and_settled_set_points_are_told_apart(tmp_path):
    q_cmd, q_phy, _ = _arrays()
    stream = load_recording(write_recording(tmp_path / "stream", q_cmd, q_phy, 0.01 * np.arange(60)))
    settled = load_recording(write_recording(tmp_path / "settled", q_cmd, q_phy, 0.5 * np.arange(60)))
    untimed = load_recording(write_recording(tmp_path / "untimed", q_cmd, q_phy, None))
    assert stream.sampling.mode == "stream" and "10.0 ms" in stream.sampling.reason
    assert settled.sampling.mode == "setpoints" and "0.50 s" in settled.sampling.reason
    assert untimed.sampling.mode == "setpoints" and untimed.t is None


def test_a_bad_sample_is_named_by_file_field_and_sample(tmp_path):
    q_cmd, q_phy, t = _arrays()
    q_phy[17, 4] = np.nan
    folder = write_recording(tmp_path / "rec", q_cmd, q_phy, t)
    with pytest.raises(PegbtError, match="NaN or infinite value in sample 17") as error:
        load_recording(folder)
    assert (error.value.file, error.value.field, error.value.line) == (
        str(folder / "q_phy.npy"),
        "q_phy",
        None,
    )
    csv = tmp_path / "rec.csv"
    header = (
        "t," + ",".join(f"q{i}_cmd" for i in range(1, 7)) + "," + ",".join(f"q{i}_meas" for i in range(1, 7))
    )
    np.savetxt(csv, np.column_stack([t, q_cmd, q_phy]), delimiter=",", header=header, comments="")
    with pytest.raises(PegbtError, match="sample 17") as error:
        load_recording(csv)
    assert (error.value.file, error.value.field, error.value.line) == (str(csv), "q_phy", 19)


def test_the_writer_refuses_what_the_loader_would(tmp_path):
    writer = RecordingWriter(tmp_path / "few", "PSM1")
    for n in range(10):
        writer.add(np.full(6, 0.1 * n), np.zeros(6), 0.5 * n)
    with pytest.raises(PegbtError, match="only 10 sample"):
        writer.close()
    assert not (tmp_path / "few").exists()  # nothing that looks like a recording is written
    with pytest.raises(PegbtError, match="unknown arm"):
        RecordingWriter(tmp_path / "x", "PSM3")
