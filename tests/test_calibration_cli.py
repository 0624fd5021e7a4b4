"""`pegbt calibrate train|eval`, the recording layout, and the real dVRK recordings."""

import json

import numpy as np
import pytest
from calibration_helpers import synthetic, write

from pegbt.calibration.base import CalibrationModel, new_model
from pegbt.calibration.evaluation import evaluate
from pegbt.cli import main
from pegbt.physics.recording import RecordingWriter, load_recording
from pegbt.errors import PegbtError


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


def test_bad_input_is_one_line_and_status_2(tmp_path, pegbt_cli, capsys):
    folder = write(synthetic(300, arm="PSM2"), tmp_path / "rec")
    wrong_arm = pegbt_cli(
        "calibrate", "train", folder, "--arm", "PSM1", "--model", "physics", "--out", tmp_path / "m.json"
    )
    assert wrong_arm.returncode == 2 and "recording is of PSM2" in wrong_arm.stderr
    assert len(wrong_arm.stderr.strip().splitlines()) == 1 and not (tmp_path / "m.json").exists()
    q_phy = np.load(folder / "q_phy.npy")
    q_phy[17, 4] = np.nan
    np.save(folder / "q_phy.npy", q_phy)
    assert (
        main(
            [
                "calibrate",
                "train",
                str(folder),
                "--arm",
                "PSM2",
                "--model",
                "hybrid",
                "--out",
                str(tmp_path / "m.json"),
            ]
        )
        == 2
    )
    assert "q_phy.npy: q_phy: NaN or infinite value in sample 17" in capsys.readouterr().err
    assert main(["calibrate", "eval", str(tmp_path / "nothing.json"), str(folder)]) == 2
    assert "cannot read model file" in capsys.readouterr().err


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


@pytest.mark.parametrize("kind", ["physics", "hybrid"])
def test_on_real_data_the_model_reduces_the_held_out_wrist_error(kind, dvrk_data):
    recording = load_recording(dvrk_data / "random_smooth_grey1_PSM1")
    n_train = recording.head(0.7)
    model = new_model(kind, "PSM1").fit(recording.slice(0, n_train))
    scores = evaluate(model, recording, start=n_train)
    for joint in ("q4", "q5", "q6"):
        assert scores["joint_rmse"][joint] < 0.6 * scores["joint_rmse_uncompensated"][joint]
    assert scores["tip_err_mm_mean"] < 0.5 * scores["tip_err_mm_mean_uncompensated"]


def test_the_stored_skill_models_load_for_their_arms():
    from pegbt.calibration.compensation import CALIBRATION_DIR
    from pegbt.calibration.modelfile import model_file_name

    for arm in ("PSM1", "PSM2"):
        model = CalibrationModel.load(CALIBRATION_DIR / model_file_name(arm, "hybrid"), arm=arm)
        assert model.kind == "hybrid" and model.metadata is not None
        assert "grey" in model.metadata.training["recording"]
