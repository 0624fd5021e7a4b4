"""Calibration on the real dVRK recordings: the physics and hybrid models reduce the held-out wrist error."""

import pytest

from pegbt.calibration.base import new_model
from pegbt.calibration.evaluation import evaluate
from pegbt.physics.recording import load_recording


@pytest.mark.parametrize("kind", ["physics", "hybrid"])
def test_on_real_data_the_model_reduces_the_held_out_wrist_error(kind, dvrk_data):
    recording = load_recording(dvrk_data / "random_smooth_grey1_PSM1")
    n_train = recording.head(0.7)
    model = new_model(kind, "PSM1").fit(recording.slice(0, n_train))
    scores = evaluate(model, recording, start=n_train)
    for joint in ("q4", "q5", "q6"):
        assert scores["joint_rmse"][joint] < 0.6 * scores["joint_rmse_uncompensated"][joint]
    assert scores["tip_err_mm_mean"] < 0.5 * scores["tip_err_mm_mean_uncompensated"]
