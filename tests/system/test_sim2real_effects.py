"""Each library effect, hidden in a recording, is named on the right joint with the right parameters;
negative controls name nothing; what the data cannot show is said, not guessed."""

import numpy as np
import pytest

from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import Recording
from pegbt.sim2real.diagnose import diagnose
from tests.sim2real_helpers import recording_with


def _named(recording, **kwargs):
    diagnosis = diagnose(recording, n_bootstrap=0, **kwargs)
    return diagnosis, {
        (e.effect.effect, e.effect.joint, e.effect.params.get("source")): e.effect for e in diagnosis.effects
    }


@pytest.mark.parametrize(
    "effect, checked",
    [
        (Effect("offset", "q4", {"value": 0.05}), "value"),
        (Effect("scale", "q2", {"value": 1.04}), "value"),
        (Effect("coupling", "q5", {"source": "q6", "k": 0.2}), "k"),
        (Effect("backlash", "q6", {"half_width": 0.03}), "half_width"),
        (Effect("hysteresis", "q5", {"source": "q6", "half_width": 0.08, "k": -0.4}), "k"),
        (Effect("lag", "q1", {"tau": 0.06}), "tau"),
        (Effect("delay", "q2", {"seconds": 0.04}), "seconds"),
    ],
)
def test_each_effect_is_named_with_its_parameters(effect, checked):
    _, named = _named(recording_with([effect], seed=3))
    key = (effect.effect, effect.joint, effect.params.get("source"))
    assert key in named, f"{effect} not named; named {list(named)}"
    truth, found = effect.params[checked], named[key].params[checked]
    reference = abs(truth - 1) if effect.effect == "scale" else abs(truth)
    assert abs(found - truth) <= 0.15 * reference
    assert set(named) == {key}, f"extra effects named: {set(named) - {key}}"


def test_partial_play_on_a_joint_is_named_hysteresis_of_the_joint_on_itself():
    effect = Effect("hysteresis", "q6", {"source": "q6", "half_width": 0.06, "k": 0.6})
    _, named = _named(recording_with([effect], seed=5))
    found = named[("hysteresis", "q6", "q6")]
    assert found.params["k"] == pytest.approx(0.6, rel=0.15)
    assert found.params["half_width"] == pytest.approx(0.06, rel=0.15)


def test_a_small_effect_under_a_large_one_is_still_found():
    effects = [
        Effect("offset", "q5", {"value": 0.3}),
        Effect("coupling", "q5", {"source": "q6", "k": 0.25}),
        Effect("backlash", "q5", {"half_width": 0.01}),
    ]
    _, named = _named(recording_with(effects, seed=8))
    assert {("offset", "q5", None), ("coupling", "q5", "q6"), ("backlash", "q5", None)} <= set(named)
    assert named[("backlash", "q5", None)].params["half_width"] == pytest.approx(0.01, rel=0.15)


def test_negative_controls_under_white_and_ar1_noise_name_almost_nothing():
    """No effect: at most one of twelve recordings may name anything (the guard allows 5 % per recording)."""
    naming = []
    for noise in ("white", "ar1"):
        for seed in range(20, 26):
            diagnosis, named = _named(recording_with([], seed=seed, noise=noise))
            naming.append(bool(named))
            assert all(e.explains < 0.01 for e in diagnosis.effects)
            after, before = diagnosis.rmse_after(), diagnosis.rmse_before()
            assert all(after[q] <= before[q] * 1.05 for q in before)
    assert sum(naming) <= 1


def test_a_joint_that_never_reverses_is_reported_not_identifiable():
    recording = recording_with([], seed=2)
    q_cmd = recording.q_cmd.copy()
    q_cmd[:, 4] = np.linspace(-0.6, 0.6, recording.n)  # q5 only ever rises
    q_phy = ArmPhysics([Effect("backlash", "q5", {"half_width": 0.05})]).simulate(q_cmd, recording.t)
    q_phy += np.random.default_rng(0).normal(0, 0.002, q_phy.shape)
    diagnosis, named = _named(Recording(recording.path, q_cmd, q_phy, recording.t))
    assert ("backlash", "q5", None) not in named
    assert any("not identifiable: q5 never reverses" in s for s in diagnosis.not_identifiable)


def test_settled_set_points_say_lag_and_delay_cannot_be_identified():
    recording = recording_with([Effect("offset", "q4", {"value": 0.1})], seed=4)
    every = slice(None, None, 40)
    setpoints = Recording(
        recording.path, recording.q_cmd[every], recording.q_phy[every], recording.t[every] * 40
    )
    diagnosis, named = _named(setpoints)
    assert diagnosis.sampling.mode == "setpoints"
    assert ("offset", "q4", None) in named
    assert any(s.startswith("lag and delay") and "set-points" in s for s in diagnosis.not_identifiable)


def test_a_partial_model_is_asked_only_for_what_it_still_lacks(tmp_path):
    preset = tmp_path / "partial.json"
    preset.write_text(
        '{"effects": [{"effect": "coupling", "joint": "q5", "params": {"source": "q6", "k": 0.2}}]}'
    )
    effects = [Effect("coupling", "q5", {"source": "q6", "k": 0.2}), Effect("offset", "q5", {"value": -0.1})]
    _, named = _named(recording_with(effects, seed=6), sim=str(preset))
    assert set(named) == {("offset", "q5", None)}


def test_identify_returns_the_whole_model_for_calibration():
    from pegbt.sim2real import identify

    effects = [Effect("offset", "q4", {"value": 0.2}), Effect("coupling", "q6", {"source": "q5", "k": 0.15})]
    recording = recording_with(effects, seed=7)
    model = ArmPhysics(identify(recording.q_cmd, recording.q_phy, recording.t))
    error = recording.q_phy - model.simulate(recording.q_cmd, recording.t)
    assert (error**2).mean() ** 0.5 < 0.0025  # only the 2 mrad noise is left
