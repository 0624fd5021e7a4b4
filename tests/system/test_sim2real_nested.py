"""Nested cross-validation: a held-out segment's figure never sees that segment's measurements.

The effects, widths and coefficients behind each held-out prediction are chosen on the rest of the
recording alone. Two recordings with known physics prove it: changing one segment's measurements leaves
that segment's held-out prediction exactly as it was, and an effect that only two segments excite (so no
choice made without one of them can name it) is not credited to those segments, as choosing on the whole
recording would."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import Recording
from pegbt.sim2real.crossval import fold_ranges
from pegbt.sim2real.diagnose import crossval_predict, diagnose
from pegbt.sim2real.report import report_dict
from tests.sim2real_helpers import commands, recording_with

Q4, Q5 = 3, 4


def _rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(((a - b) ** 2).mean()))


def test_a_segments_heldout_prediction_does_not_depend_on_its_own_measurements():
    recording = recording_with([Effect("coupling", "q5", {"source": "q6", "k": 0.1})], seed=11)
    a, b = fold_ranges(recording.n)[2]
    changed_phy = recording.q_phy.copy()
    changed_phy[a:b, Q5] += 0.3 * recording.q_cmd[a:b, 0]  # a coupling q1→q5 in this segment alone
    changed = replace(recording, q_phy=changed_phy)
    first, second = diagnose(recording, n_bootstrap=0), diagnose(changed, n_bootstrap=0)
    assert first.faults.count == second.faults.count == 0
    assert first.fold_ranges == second.fold_ranges
    np.testing.assert_allclose(second.heldout_prediction[a:b], first.heldout_prediction[a:b], atol=1e-12)
    # the segment does move the whole recording's choice, and the other segments' predictions
    assert not np.allclose(second.physics.coupling, first.physics.coupling, atol=1e-3)
    assert not np.allclose(second.heldout_prediction[:a, Q5], first.heldout_prediction[:a, Q5])


@pytest.fixture(scope="module")
def excited_in_two_segments():
    """Backlash on q4, whose command moves only in the second and fourth of the five segments."""
    t, q_cmd = commands(3, seconds=30.0)
    window = np.zeros(len(t))
    for k in (1, 3):
        a, b = fold_ranges(len(t))[k]
        window[a:b] = np.sin(np.linspace(0.0, np.pi, b - a)) ** 2
    centre = q_cmd[:, Q4].mean()
    q_cmd[:, Q4] = centre + window * (q_cmd[:, Q4] - centre)
    truth = ArmPhysics([Effect("backlash", "q4", {"half_width": 0.03})])
    noise = 0.002 * np.random.default_rng(5).standard_normal(q_cmd.shape)
    return diagnose(
        Recording(Path("<two segments>"), q_cmd, truth.simulate(q_cmd, t) + noise, t), n_bootstrap=0
    )


def test_an_effect_named_only_with_the_heldout_segment_is_not_credited_to_it(excited_in_two_segments):
    diagnosis = excited_in_two_segments
    recording = diagnosis.recording
    assert [(e.effect.effect, e.effect.joint) for e in diagnosis.effects] == [("backlash", "q4")]
    # choosing on the whole recording and refitting only coefficients (the optimistic scheme)
    optimistic = crossval_predict(
        diagnosis.fits,
        diagnosis.base,
        recording,
        recording.t,
        diagnosis.residual_before,
        diagnosis.fold_ranges,
    )
    for k, (a, b) in enumerate(diagnosis.fold_ranges):
        raw = _rmse(recording.q_phy[a:b, Q4], diagnosis.simulated[a:b, Q4])
        nested = _rmse(recording.q_phy[a:b, Q4], diagnosis.heldout_prediction[a:b, Q4])
        claimed = _rmse(recording.q_phy[a:b, Q4], optimistic[a:b, Q4])
        assert claimed < 0.003  # the whole recording's choice fits every segment
        assert raw > 0.02 or k == 0  # before q4 first moves, its play has not shown
        if k in (1, 3):  # without this segment only one segment moves q4: nothing can be named
            assert "backlash on q4" not in diagnosis.fold_named[k]
            assert nested == pytest.approx(raw, rel=1e-9)
        else:
            assert "backlash on q4" in diagnosis.fold_named[k]
            assert nested < 0.003


def test_the_report_says_the_heldout_figures_are_nested(excited_in_two_segments):
    report = report_dict(excited_in_two_segments)
    assert report["fit"]["method"].startswith("nested blocked cross-validation")
    assert "chosen again on the rest of the recording alone" in report["fit"]["method"]
    assert report["fit"]["fold_effects"][1] == []
    assert report["fit"]["fold_effects"][0] == ["backlash on q4"]
