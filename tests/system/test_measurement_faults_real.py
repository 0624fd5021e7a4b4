"""Measurement faults on a real recording: injected tracker faults are found and change nothing of the physics
it names."""

from pathlib import Path

import numpy as np
import pytest

from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import Recording, load_recording
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
