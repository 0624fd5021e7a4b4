"""On the real dVRK recordings the diagnosis finds the wrist physics and the held-out fit improves."""

from functools import cache
from pathlib import Path

import pytest

from pegbt.physics import ArmPhysics
from pegbt.physics.recording import load_recording
from pegbt.sim2real.diagnose import Diagnosis, diagnose


@cache
def _diagnosed(folder: Path) -> Diagnosis:
    return diagnose(load_recording(folder), n_bootstrap=20)


@pytest.fixture
def grey1(dvrk_data):
    return _diagnosed(dvrk_data / "random_smooth_grey1_PSM1")


def test_wrist_heldout_error_falls_to_a_few_hundredths_of_a_radian(grey1):
    assert grey1.sampling.mode == "setpoints"
    before, after = grey1.rmse_before(), grey1.rmse_after()
    for q in ("q4", "q5", "q6"):
        assert before[q] > 0.1
        assert after[q] < 0.04, (q, after[q])


def test_the_named_wrist_effects_are_the_papers_offset_coupling_and_hysteresis(grey1):
    named = {(e.effect.effect, e.effect.joint, e.effect.params.get("source")) for e in grey1.effects}
    assert ("offset", "q4", None) in named
    assert ("coupling", "q6", "q5") in named
    assert ("hysteresis", "q5", "q6") in named  # q5 moves with the direction of q6: coupled hysteresis
    assert any(
        kind in ("backlash", "hysteresis") and joint == "q6" and source in (None, "q6")
        for kind, joint, source in named
    )
    assert any("not identifiable" in s and "set-points" in s for s in grey1.not_identifiable)


def test_the_refitted_preset_reproduces_the_recording_it_came_from(dvrk_data):
    recording = load_recording(dvrk_data / "random_smooth_grey2_PSM2")
    error = recording.q_phy - ArmPhysics.load("dvrk-real", "PSM2").simulate(recording.q_cmd)
    rmse = (error**2).mean(0) ** 0.5
    assert rmse[3] < 0.02 and rmse[4] < 0.03 and rmse[5] < 0.03


@pytest.mark.slow
def test_new2s_insertion_offset_is_real_at_the_papers_resolution_and_reported_as_geometry(dvrk_data):
    """new2's q3 sits 0.74 mm short of its command: above the tracker's 0.5 mm, it holds up held out
    (nested), and it is reported as a zero offset of the arm, not one of the 8 cable effects named."""
    resolution = (0.01, 0.01, 0.0005, 0.01, 0.01, 0.01)
    diagnosis = diagnose(
        load_recording(dvrk_data / "random_smooth_new2_PSM2"), n_bootstrap=0, resolution=resolution
    )
    assert not [e for e in diagnosis.effects if e.effect.joint in ("q1", "q2", "q3")]
    assert len(diagnosis.effects) <= 8
    (q3,) = diagnosis.zero_offsets
    assert (q3.effect.effect, q3.effect.joint) == ("offset", "q3")
    assert abs(q3.effect.params["value"]) > 0.0005
    assert diagnosis.rmse_after()["q3"] < 0.98 * diagnosis.rmse_before()["q3"]
    assert sum("offset on q3" in named for named in diagnosis.fold_named) >= 3


@pytest.mark.slow
def test_grey1s_arm_joints_move_as_one_displacement_of_the_tool_not_as_cable_effects(dvrk_data):
    """grey1's q1–q3 errors are one geometric displacement (a few mm, as a tracker registration error
    gives), not a q2→q3 coupling: reported as geometry, taken out, and no effect is named on q1–q3."""
    resolution = (0.01, 0.01, 0.0005, 0.01, 0.01, 0.01)
    diagnosis = diagnose(
        load_recording(dvrk_data / "random_smooth_grey1_PSM1"), n_bootstrap=0, resolution=resolution
    )
    assert diagnosis.geometry is not None
    assert 0.003 < sum(v * v for v in diagnosis.geometry.displacement_m) ** 0.5 < 0.01
    assert diagnosis.geometry.heldout_ratio[0] < 0.6 and diagnosis.geometry.heldout_ratio[1] < 0.6
    assert not [e for e in diagnosis.effects if e.effect.joint in ("q1", "q2", "q3")]
    after, before = diagnosis.rmse_after(), diagnosis.rmse_before()
    assert after["q1"] < 0.6 * before["q1"] and after["q2"] < 0.6 * before["q2"]  # held out, nested
