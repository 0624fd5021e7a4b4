"""`pegbt calibrate train|eval` in this process, the recording layout, and the stored skill models."""

import json

import numpy as np
import pytest
from calibration_helpers import synthetic, write

from pegbt.calibration.base import CalibrationModel
from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.physics.recording import RecordingWriter, load_recording


def test_train_then_eval_on_a_written_recording(tmp_path, capsys):
    folder = write(synthetic(800, noise=0.001), tmp_path / "rec_PSM1")
    out = tmp_path / "model.json"
    assert (
        main(["calibrate", "train", str(folder), "--arm", "PSM1", "--model", "physics", "--out", str(out)])
        == 0
    )
    assert "held-out samples" in capsys.readouterr().out
    assert json.loads(out.read_text())["heldout"]["samples"] == 240
    assert main(["calibrate", "eval", str(out), str(folder), "--json", "--from-fraction", "0.7"]) == 0
    scores = json.loads(capsys.readouterr().out)
    assert set(scores["joint_rmse"]) == {"q1", "q2", "q3", "q4", "q5", "q6"}
    assert set(scores["joint_rmse_uncompensated"]) == set(scores["joint_rmse"])
    assert scores["tip_err_mm_mean"] < 0.2 * scores["tip_err_mm_mean_uncompensated"]
    assert scores["joint_rmse"]["q5"] < 0.01 < scores["joint_rmse_uncompensated"]["q5"]


def test_recordings_are_checked_when_loaded(tmp_path):
    folder = write(synthetic(120), tmp_path / "rec")
    np.save(folder / "q_cmd.npy", np.zeros((120, 7)))
    with pytest.raises(PegbtError, match="N×6") as error:
        load_recording(folder)
    assert error.value.file == str(folder / "q_cmd.npy") and error.value.field == "q_cmd"
    np.save(folder / "q_cmd.npy", np.zeros((119, 6)))
    with pytest.raises(PegbtError, match="different lengths"):
        load_recording(folder)
    with pytest.raises(PegbtError, match="no such recording"):
        load_recording(tmp_path / "absent")


def test_the_writer_writes_what_the_loader_reads(tmp_path):
    writer = RecordingWriter(tmp_path / "collected", "PSM2")
    insertion = np.array([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])  # m: within the arm's insertion range
    for n in range(60):
        writer.add(insertion + np.full(6, 0.001 * n), insertion + 0.02 + np.full(6, 0.001 * n), 0.4 * n)
    with pytest.raises(PegbtError, match="time must increase"):
        writer.add(np.ones(6), np.zeros(6), 0.4 * 59)
    recording = load_recording(writer.close())
    assert recording.arm == "PSM2" and len(recording) == 60 and recording.sampling.mode == "setpoints"
    assert np.allclose(recording.t, 0.4 * np.arange(60)) and np.allclose(recording.q_phy[0], insertion + 0.02)


def test_the_stored_skill_models_load_for_their_arms():
    from pegbt.calibration.compensation import CALIBRATION_DIR
    from pegbt.calibration.modelfile import model_file_name

    for arm in ("PSM1", "PSM2"):
        model = CalibrationModel.load(CALIBRATION_DIR / model_file_name(arm, "hybrid"), arm=arm)
        assert model.kind == "hybrid" and model.metadata is not None
        assert "grey" in model.metadata.training["recording"]
