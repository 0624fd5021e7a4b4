"""`pegbt calibrate collect` on the embedded simulator: the chosen arm's set-points recorded in the dataset
layout."""

from __future__ import annotations

import numpy as np

from pegbt.calibration.collect import SETTLE_S, setpoints_for_minutes
from pegbt.calibration.task import task_box
from pegbt.cli import main
from pegbt.physics.recording import MIN_SAMPLES, load_recording


def test_collect_records_the_chosen_arm_on_the_embedded_simulator(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    count, step = setpoints_for_minutes(0.3, "PSM2", seed=3)
    assert count == int(0.3 * 60 / step) >= MIN_SAMPLES and step > SETTLE_S
    assert main(["calibrate", "collect", "--arm", "PSM2", "--minutes", "0.3", "--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert f"PSM2: {count} set-points in 0.3 min, {step:.2f} s each" in out
    assert "recording: runs/calibration/sim-PSM2" in out
    recording = load_recording(tmp_path / "runs" / "calibration" / "sim-PSM2")
    assert recording.arm == "PSM2" and recording.n == count
    lower, upper = task_box("PSM2")
    assert np.all(recording.q_cmd >= lower - 1e-9) and np.all(recording.q_cmd <= upper + 1e-9)
    assert np.all(np.diff(recording.t) >= step - SETTLE_S)  # each sample a move and a settle after the last
    wrist_error = np.abs(recording.q_phy - recording.q_cmd)[:, 3:]
    assert wrist_error.max() > 0.01  # the simulator's dvrk-real cables: physical joints are not the commands
    assert not (tmp_path / "runs" / "calibration" / "sim-PSM1").exists()
