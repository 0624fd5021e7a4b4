"""Measurement faults are not physics: on set-point recordings whose truth is known, with tracker glitches
(every joint jumps at once for a sample) and a window where the tracker lost the tool injected, the faults
are found and reported, left out of selection and fit, and the physics is still named; a real effect the
faults would hide is found once they are left out; `pegbt calibrate train` leaves out the same samples and
says so."""

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

import pegbt.sim2real.diagnose as diagnose_module
from pegbt.cli import main
from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.faults import MeasurementFaults, detect_faults
from pegbt.physics.recording import Recording, load_recording, write_recording
from pegbt.sim2real.diagnose import diagnose
from pegbt.sim2real.synth import effect_label, with_tracker_faults
from tests.sim2real_helpers import commands

RESOLUTION = (0.01, 0.01, 0.0005, 0.01, 0.01, 0.01)
SIGMA = np.array([0.001, 0.001, 0.0001, 0.004, 0.004, 0.004])
TRUTH = [
    Effect("offset", "q4", {"value": 0.15}),
    Effect("coupling", "q5", {"source": "q6", "k": 0.2}),
    Effect("backlash", "q6", {"half_width": 0.04}),
]


def _faulty(effects, seed, glitches=60):
    """Settled set-points 0.8 s apart with `glitches` tracker glitches and a window where it lost the tool
    (`with_tracker_faults`). Returns the recording, the true fault mask and the lost window."""
    _, q_cmd = commands(seed, seconds=1600, rate_hz=1.25)
    rng = np.random.default_rng(seed)
    q_phy = ArmPhysics(effects).simulate(q_cmd) + rng.normal(0, 1, q_cmd.shape) * SIGMA
    n = len(q_cmd)
    clean = Recording(Path(f"<faulty {seed}>"), q_cmd, q_phy, np.arange(n) * 0.8)
    recording, truth = with_tracker_faults(clean, glitches, rng, SIGMA)
    return recording, truth, slice(n - n // 6 + n // 18, n - n // 18)


@pytest.fixture(scope="module")
def faulty():
    return _faulty(TRUTH, seed=2)


def test_glitches_and_a_lost_window_are_found_and_clean_samples_kept(faulty):
    recording, truth, lost = faulty
    found = detect_faults(recording.q_cmd, recording.q_phy)
    assert (found.mask & truth).sum() >= 0.95 * truth.sum()
    assert (found.mask & ~truth).sum() <= 0.005 * (~truth).sum()
    ((a, b),) = found.windows
    assert abs(a - lost.start) <= 6 and abs(b - (lost.stop - 1)) <= 6  # a glitch beside it may join it
    assert found.glitches >= 55
    assert found.sentence(recording.times).startswith(
        f"the tracker lost the tool from {recording.times[a]:.4g}"
    )


def test_a_clean_recording_has_none():
    recording, _, _ = _faulty(TRUTH, seed=5, glitches=0)
    clean = recording.subset(
        np.r_[np.ones(recording.n - recording.n // 6, dtype=bool), np.zeros(recording.n // 6, dtype=bool)]
    )
    assert detect_faults(clean.q_cmd, clean.q_phy).count == 0


def test_the_diagnosis_excludes_them_reports_them_and_still_names_the_physics(faulty, tmp_path):
    recording, truth, _ = faulty
    folder = write_recording(tmp_path / "rec", recording.q_cmd, recording.q_phy, None, resolution=RESOLUTION)
    out = tmp_path / "out"
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["sim2real", "diagnose", str(folder), "--out", str(out), "--bootstrap", "0"]) == 0
    report = json.loads((out / "report.json").read_text())
    faults = report["measurement_faults"]
    assert faults["samples_excluded"] >= 0.95 * truth.sum() and len(faults["windows"]) == 1
    assert "the tracker lost the tool" in faults["text"] and "samples excluded" in faults["text"]
    assert report["fit"]["samples_excluded"] == faults["samples_excluded"]
    assert report["fit"]["samples"] == recording.n - faults["samples_excluded"]
    named = {(e["effect"], e["joint"]) for e in report["effects"]}
    assert named == {("offset", "q4"), ("coupling", "q5"), ("backlash", "q6")}
    before, after = report["fit"]["heldout_rmse_before"], report["fit"]["heldout_rmse_after"]
    assert all(after[q] <= 0.3 * before[q] for q in ("q4", "q5", "q6"))
    assert "Measurement faults: the tracker lost the tool" in (out / "report.md").read_text()


def test_faults_that_hide_a_real_effect_no_longer_do(monkeypatch):
    hidden = [Effect("backlash", "q5", {"half_width": 0.008})]
    recording, _, _ = _faulty(hidden, seed=7, glitches=120)
    named = {(e.effect.effect, e.effect.joint) for e in diagnose(recording, n_bootstrap=0).effects}
    assert ("backlash", "q5") in named
    monkeypatch.setattr(
        diagnose_module,
        "detect_faults",
        lambda q_cmd, q_phy, limits: MeasurementFaults(np.zeros(len(q_cmd), bool), (), 0),
    )
    blind = {(e.effect.effect, e.effect.joint) for e in diagnose(recording, n_bootstrap=0).effects}
    assert ("backlash", "q5") not in blind


def test_calibrate_train_leaves_out_the_same_samples_and_says_so(faulty, tmp_path):
    recording, _, _ = faulty
    folder = write_recording(tmp_path / "rec", recording.q_cmd, recording.q_phy, None)
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = main(
            [
                "calibrate",
                "train",
                str(folder),
                "--arm",
                "PSM1",
                "--model",
                "physics",
                "--out",
                str(tmp_path / "m.json"),
            ]
        )
    assert status == 0
    expected = detect_faults(recording.q_cmd, recording.q_phy)
    assert f"; {expected.count} samples excluded" in printed.getvalue()
    assert expected.count > 0


@pytest.mark.slow
def test_on_a_real_recording_injected_faults_are_found_and_change_nothing_it_names(dvrk_data):
    """grey2 (PSM2), with as many glitches as a raw recording of the paper's set-up and a lost-tracking
    window injected: the faults are found, and the same physics is named as on the clean recording."""
    recording = load_recording(dvrk_data / "random_smooth_grey2_PSM2")
    faulty, truth = with_tracker_faults(recording, 181, np.random.default_rng(0))
    clean, diagnosis = (diagnose(r, n_bootstrap=0, resolution=RESOLUTION) for r in (recording, faulty))
    found = diagnosis.faults.mask
    assert (found & truth).sum() >= 0.95 * truth.sum() and (found & ~truth).sum() <= 0.02 * (~truth).sum()
    assert {effect_label(e.effect) for e in diagnosis.effects} == {
        effect_label(e.effect) for e in clean.effects
    }
    before, after = diagnosis.rmse_before(), diagnosis.rmse_after()
    assert all(after[q] <= 0.3 * before[q] for q in ("q4", "q5", "q6"))
