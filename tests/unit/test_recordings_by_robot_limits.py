"""Recordings are judged by the robot's own limits, not the planner's: commands the dVRK takes (roll past
`skills/psm.yaml`'s ±100°, dVRK 1.x's insertion of 0.2412 m) load; a tracker that loses the tool (q3 read
as 0 m) is a measurement fault the diagnosis and `calibrate train` report and leave out; what is not a
recording at all is still refused, and a robot whose own files are narrower judges by them."""

from __future__ import annotations

import contextlib
import io
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from pegbt.cli import main
from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import RecordingError, load_recording, write_recording
from pegbt.sim2real.report import report_markdown
from tests.sim2real_helpers import commands

SHARE = Path(__file__).parents[1] / "data" / "dvrk-share"
SIGMA = np.array([0.001, 0.001, 0.0001, 0.004, 0.004, 0.004])
PHYSICS = [Effect("offset", "q4", {"value": 0.1}), Effect("backlash", "q6", {"half_width": 0.03})]
LOST = slice(300, 360)  # where the tracker lost the tool


def _session(seed: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Settled set-points 0.8 s apart of an arm with cable effects: (q_cmd, q_phy, t)."""
    _, q_cmd = commands(seed, seconds=480, rate_hz=1.25)
    q_cmd[:, 2] = 0.15 + 0.4 * (q_cmd[:, 2] - q_cmd[:, 2].mean())
    rng = np.random.default_rng(seed)
    q_phy = ArmPhysics(PHYSICS).simulate(q_cmd) + rng.normal(0, 1, q_cmd.shape) * SIGMA
    return q_cmd, q_phy, 0.8 * np.arange(len(q_cmd))


def _roll_to(q_cmd: np.ndarray, q_phy: np.ndarray, lowest: float) -> None:
    """Stretch the roll's commands (and what follows them) so that the lowest is `lowest`."""
    scale = lowest / q_cmd[:, 3].min()
    q_cmd[:, 3] *= scale
    q_phy[:, 3] *= scale


def _tracker_lost(tmp_path: Path, lost: slice = LOST) -> Path:
    q_cmd, q_phy, t = _session()
    q_phy[lost, 2] = 0.0  # the tracker lost the tool: the insertion read as 0 m, the rest as before
    q_phy[lost, 3:] = q_phy[lost.start - 1, 3:]
    return write_recording(tmp_path / "raw_verification_PSM1", q_cmd, q_phy, t)


def test_a_roll_commanded_to_minus_1_761_rad_loads(tmp_path: Path) -> None:
    q_cmd, q_phy, t = _session()
    _roll_to(q_cmd, q_phy, -1.76113)  # -100.9°: past skills/psm.yaml's -100°, inside the dVRK's -260°
    recording = load_recording(write_recording(tmp_path / "roll_PSM1", q_cmd, q_phy, t))
    assert recording.q_cmd[:, 3].min() == pytest.approx(-1.76113)


def test_an_insertion_of_0_2412_m_for_three_samples_loads_and_far_beyond_is_refused(tmp_path: Path) -> None:
    q_cmd, q_phy, t = _session()
    q_cmd[100:103, 2] = q_phy[100:103, 2] = 0.2412  # dVRK 1.x took it; dVRK 2.x stops at 0.24 m
    assert load_recording(write_recording(tmp_path / "deep_PSM1", q_cmd, q_phy, t)).n == len(t)
    q_cmd[100:103, 2] = q_phy[100:103, 2] = 0.26
    with pytest.raises(RecordingError, match="q3 .insertion. is 0.26 m at sample 100") as raised:
        load_recording(write_recording(tmp_path / "deeper_PSM1", q_cmd, q_phy, t))
    assert raised.value.field == "q_cmd.q3"


def test_a_tracker_that_loses_the_tool_is_diagnosed_with_its_faults_reported(tmp_path: Path) -> None:
    """The report as `--json` prints it (what `--out` writes, without its plots) and its markdown."""
    folder = _tracker_lost(tmp_path)
    recording = load_recording(folder)
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["sim2real", "diagnose", str(folder), "--bootstrap", "0", "--json"]) == 0
    report = json.loads(printed.getvalue())
    faults = report["measurement_faults"]
    assert faults["windows"][0][:2] == [recording.times[LOST.start], recording.times[LOST.stop - 1]]
    assert faults["unreachable"] == LOST.stop - LOST.start <= faults["samples_excluded"]
    assert "the tracker lost the tool from 240 to 287.2 s (60 samples)" in faults["text"]
    assert "where no arm could be" in report_markdown(report, [])


def test_calibrate_train_reports_and_leaves_out_the_lost_tool(tmp_path: Path) -> None:
    lost = slice(480, 540)  # in the held-out 30 % of 600 samples
    folder, model = _tracker_lost(tmp_path, lost), tmp_path / "model.json"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = main(
            ["calibrate", "train", str(folder), "--arm", "PSM1", "--model", "physics", "--out", str(model)]
        )
    assert status == 0 and "the tracker lost the tool from 384 to 431.2 s" in printed.getvalue()
    heldout = json.loads(model.read_text())["heldout"]
    assert heldout["samples"] == 180 - 60
    assert heldout["joint_rmse"]["q3"] < 0.001  # the 0 m readings scored would make it centimetres


def test_what_is_not_a_recording_is_still_refused(tmp_path: Path) -> None:
    q_cmd, q_phy, t = _session()
    bad = q_cmd.copy()
    bad[7, 3] = np.inf
    with pytest.raises(RecordingError, match="NaN or infinite value in sample 7"):
        load_recording(write_recording(tmp_path / "inf_PSM1", bad, q_phy, t))
    phy_degrees = write_recording(tmp_path / "deg_PSM1", q_cmd, np.degrees(q_phy), t)
    with pytest.raises(RecordingError, match="where no arm could be") as raised:
        load_recording(phy_degrees)
    assert raised.value.file == str(phy_degrees / "q_phy.npy")


def test_a_robot_config_judges_by_the_robots_own_files(tmp_path: Path) -> None:
    q_cmd, q_phy, t = _session()
    _roll_to(q_cmd, q_phy, -1.76113)
    folder = write_recording(tmp_path / "roll_PSM1", q_cmd, q_phy, t)
    share = tmp_path / "share"
    shutil.copytree(SHARE, share)
    tool = share / "tool" / "LARGE_NEEDLE_DRIVER_400006.json"
    tool.write_text(tool.read_text().replace('"qmin": -4.53786', '"qmin": -1.5'))
    with pytest.raises(
        RecordingError, match=r"q4 \(roll\) is -1\.\d+ rad at sample \d+, outside the robot.s joint limits"
    ) as raised:
        load_recording(folder, robot_config=share)
    assert raised.value.field == "q_cmd.q4"
    assert load_recording(folder, robot_config=SHARE).n == len(t)
    assert main(["sim2real", "diagnose", str(folder), "--robot-config", str(share)]) == 2
    assert main(["sim2real", "diagnose", str(folder), "--robot-config", str(tmp_path / "none")]) == 2
