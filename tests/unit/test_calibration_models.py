"""The calibration models: one interface, one file format, an exact physics inverse."""

import json

import numpy as np
import pytest
from calibration_helpers import TRUTH, set_points, synthetic

from pegbt.calibration.base import CalibrationModel, new_model
from pegbt.calibration.physics_model import PhysicsModel
from pegbt.errors import PegbtError
from pegbt.physics import ArmPhysics, Effect
from pegbt.sim2real import identify

TINY = {"lstm": {"epochs": 2, "hidden": 16}, "physics": {}, "hybrid": {"epochs": 5}}


@pytest.fixture(scope="module")
def trained() -> dict[str, CalibrationModel]:
    recording = synthetic(300)
    return {kind: new_model(kind, "PSM1", **TINY[kind]).fit(recording) for kind in TINY}


@pytest.mark.parametrize("kind", list(TINY))
def test_save_and_load_give_the_same_model(kind, trained, tmp_path):
    model = trained[kind]
    path = model.save(tmp_path / f"{kind}.json")
    loaded = CalibrationModel.load(path, arm="PSM1")
    q = set_points(50, seed=7)
    assert type(loaded) is type(model)
    assert np.array_equal(loaded.predict(q), model.predict(q))
    document = json.loads(path.read_text())
    assert document["kind"] == kind and document["arm"] == "PSM1"
    assert document["joints"] == ["q1", "q2", "q3", "q4", "q5", "q6"]
    assert document["training"]["samples"] == 300 and document["training"]["created"]


@pytest.mark.parametrize("kind", list(TINY))
def test_one_command_at_a_time_matches_the_whole_sequence(kind, trained):
    """forward/advance (what compensation uses) predict what predict() does over a recording."""
    model = trained[kind]
    q = set_points(40, seed=3)
    state = model.initial_state(q[0])
    stepped = []
    for row in q:
        stepped.append(model.forward(row, state))
        state = model.advance(state, row)
    assert np.allclose(np.array(stepped), model.predict(q), atol=1e-5)


def test_the_physics_model_takes_its_effects_from_the_sim2real_identification():
    recording = synthetic(400, noise=0.002)
    model = PhysicsModel("PSM1").fit(recording)
    assert list(model.effects) == identify(recording.q_cmd, recording.q_phy, arm="PSM1")
    fitted, truth = ArmPhysics(model.effects), ArmPhysics(TRUTH)
    assert {(e.effect, e.joint) for e in model.effects} == {(e.effect, e.joint) for e in TRUTH}
    assert np.allclose(fitted.offset, truth.offset, atol=2e-3)
    assert np.allclose(fitted.coupling, truth.coupling, atol=2e-3)
    assert np.allclose(fitted.half_width, truth.half_width, atol=2e-3)


EVERY_KIND = {
    "offset": [Effect("offset", "q4", {"value": 0.2})],
    "scale": [Effect("scale", "q6", {"value": 0.9})],
    "coupling": [Effect("coupling", "q5", {"source": "q6", "k": 0.15})],
    "backlash": [Effect("backlash", "q5", {"half_width": 0.04})],
    "own hysteresis": [Effect("hysteresis", "q4", {"source": "q4", "half_width": 0.05, "k": 0.3})],
    "driven hysteresis": [Effect("hysteresis", "q5", {"source": "q6", "half_width": 0.14, "k": -0.67})],
    "test truth": TRUTH,
    "dvrk-real PSM1": list(ArmPhysics.load("dvrk-real", "PSM1").effects),
    "dvrk-real PSM2": list(ArmPhysics.load("dvrk-real", "PSM2").effects),
}


@pytest.mark.parametrize("case", list(EVERY_KIND))
def test_physics_inverse_is_exact_for_every_effect_kind(case):
    """The analytic inverse, fed its own history, puts the true arm exactly on every desired point."""
    effects = EVERY_KIND[case]
    model = PhysicsModel.from_effects("PSM1", effects, source="test truth")
    desired = set_points(200, seed=5, margin=0.3)
    state = model.initial_state(desired[0])
    issued = [desired[0]]
    for q_d in desired[1:]:
        q_c = model.command_for(q_d, state)
        state = model.advance(state, q_c)
        issued.append(q_c)
    truth = ArmPhysics(effects)
    assert np.allclose(truth.simulate(np.array(issued))[1:], desired[1:], rtol=0, atol=1e-12)
    assert not np.allclose(truth.simulate(desired), desired, atol=1e-3)  # there was work to do


def test_lag_and_delay_are_left_to_settle_the_inverse_commands_the_settled_joints():
    """Set-points cannot show lag or delay; the inverse does not lead them, and the arm settles exactly."""
    effects = [Effect("lag", "q5", {"tau": 0.05}), Effect("delay", "q6", {"seconds": 0.02}), *TRUTH]
    model = PhysicsModel.from_effects("PSM1", effects, source="test truth")
    settled_only = PhysicsModel.from_effects("PSM1", TRUTH, source="test truth")
    desired = set_points(20, seed=6, margin=0.3)
    state, state_settled = model.initial_state(desired[0]), settled_only.initial_state(desired[0])
    arm = ArmPhysics(effects)
    arm.reset(desired[0])
    for q_d in desired[1:]:
        q_c = model.command_for(q_d, state)
        assert np.array_equal(q_c, settled_only.command_for(q_d, state_settled))
        state, state_settled = model.advance(state, q_c), settled_only.advance(state_settled, q_c)
        for _ in range(100):  # 1 s of 10 ms steps holding the command: lag and delay die out
            reached = arm.step(q_c, 0.01)
        assert np.allclose(reached, q_d, rtol=0, atol=1e-9)


def test_a_physics_model_file_is_a_physics_file_the_simulator_reads(tmp_path):
    model = PhysicsModel.from_effects("PSM2", TRUTH, source="test truth")
    path = model.save(tmp_path / "psm2.json")
    q = set_points(30, seed=1, arm="PSM2")
    assert np.array_equal(ArmPhysics.load(path, "PSM2").simulate(q), ArmPhysics(TRUTH).simulate(q))


def test_a_model_file_for_another_arm_or_layout_is_refused(trained, tmp_path):
    path = trained["hybrid"].save(tmp_path / "hybrid.json")
    with pytest.raises(PegbtError, match="for 'PSM1', not 'PSM2'") as error:
        CalibrationModel.load(path, arm="PSM2")
    assert error.value.field == "arm" and error.value.file == str(path)
    document = json.loads(path.read_text())
    document["joints"] = ["q1", "q2", "q3", "q4", "q5", "q6", "jaw"]
    path.write_text(json.dumps(document))
    with pytest.raises(PegbtError, match="joint layout"):
        CalibrationModel.load(path)
    document["joints"] = ["q1", "q2", "q3", "q4", "q5", "q6"]
    document["outputs"] = ["q4", "q5", "q6"]
    path.write_text(json.dumps(document))
    with pytest.raises(PegbtError, match="predicts"):
        CalibrationModel.load(path)


def test_a_corrupt_model_file_is_refused(trained, tmp_path):
    path = trained["lstm"].save(tmp_path / "lstm.json")
    document = json.loads(path.read_text())
    name = next(iter(document["arrays"]))
    document["arrays"][name]["shape"] = [3, 3, 3, 3]
    path.write_text(json.dumps(document))
    with pytest.raises(PegbtError, match="corrupt array"):
        CalibrationModel.load(path)
    path.write_text("{not json")
    with pytest.raises(PegbtError) as error:
        CalibrationModel.load(path)
    assert error.value.line == 1


def test_too_few_samples_or_a_still_joint_cannot_be_learned():
    with pytest.raises(PegbtError, match="too few samples"):
        PhysicsModel("PSM1").fit(synthetic(50))
    recording = synthetic(300)
    recording.q_cmd[:, 4] = 0.1
    with pytest.raises(PegbtError, match="q5 never moves") as error:
        new_model("hybrid", "PSM1").fit(recording)
    assert error.value.field == "q5"


def test_a_recording_of_the_other_arm_is_refused():
    with pytest.raises(PegbtError, match="recording is of PSM2"):
        PhysicsModel("PSM1").fit(synthetic(300, arm="PSM2"))
