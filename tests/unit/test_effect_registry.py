"""A new cable effect is one class: defined here alone and registered, the simulator's arm applies it,
`sim2real synth` conceals it, `sim2real diagnose` names it and the calibration's physics model inverts
it, with no change to any pegbt module."""

import contextlib
import io
import json

import numpy as np
import pytest

from pegbt.calibration.physics_model import PhysicsModel
from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics, Effect, EffectKind, effect_kinds, registered
from pegbt.sim.arm import SimArm


class DeadZone(EffectKind):
    """The joint stays at zero while its target is within ±half_width of zero, and trails it by
    half_width beyond (a drive that must take up slack before it moves the joint away from centre)."""

    name = "dead_zone"
    params = ("half_width",)
    non_negative = frozenset({"half_width"})
    stage = "target"
    width = "half_width"

    def sequence(self, effect, x, t):
        return x - np.clip(x, -effect.params["half_width"], effect.params["half_width"])

    def inverse(self, effect, y, state, previous):
        h = effect.params["half_width"]
        return y + h if y > 0 else y - h if y < 0 else min(max(previous, -h), h)

    def column(self, signal, t, width):
        return -np.clip(signal, -width, width)

    def plausible(self, joint, source, q_cmd, rng):
        return Effect(
            self.name, f"q{joint + 1}", {"half_width": rng.uniform(0.1, 0.2) * np.ptp(q_cmd[:, joint])}
        )

    def largest(self, q_cmd, joint):
        return 0.3 * float(np.ptp(q_cmd[:, joint]))

    def sentence(self, effect, before=None):
        return f"{effect.joint} does not leave zero until its command is {effect.params['half_width']:.3g} past it: a dead zone"


def dead_zone(joint: str, half_width: float) -> Effect:
    return Effect("dead_zone", joint, {"half_width": half_width})


@pytest.fixture
def kind():
    with registered(DeadZone()) as kind:
        yield kind


def test_an_unregistered_kind_is_refused_and_a_registered_one_leaves_with_its_block():
    with pytest.raises(PegbtError, match="unknown effect 'dead_zone'"):
        dead_zone("q5", 0.1)
    with registered(DeadZone()):
        assert dead_zone("q5", 0.1).kind.name == "dead_zone"
    assert "dead_zone" not in {k.name for k in effect_kinds()}


def test_the_simulators_arm_applies_it(kind, tmp_path):
    preset = tmp_path / "physics.json"
    preset.write_text(json.dumps({"arms": {"PSM1": [dead_zone("q5", 0.1).to_dict()]}}))
    arm = SimArm("PSM1", arm_settings("PSM1"), ArmPhysics.load(preset, "PSM1"))
    start = arm.joints.encoder.copy()
    for goal_q5, expected in ((0.05, 0.0), (0.4, 0.3), (-0.25, -0.15)):
        goal = start.copy()
        goal[4] = goal_q5
        assert all(step.outcome != "refused" for step in arm.move_jp(goal, f"to {goal_q5}"))
        for _ in range(2000):
            arm.advance(arm.period)
            if not arm.is_busy:
                break
        encoder = arm.joints.encoder[4]
        assert encoder == pytest.approx(goal_q5, abs=1e-3)
        assert arm.physical[4] == pytest.approx(encoder - np.clip(encoder, -0.1, 0.1), abs=1e-12)
        assert arm.physical[4] == pytest.approx(expected, abs=1e-3)
        assert np.delete(arm.physical, 4) == pytest.approx(np.delete(arm.joints.encoder, 4))


def test_step_by_step_and_whole_sequence_agree(kind):
    physics = ArmPhysics([dead_zone("q6", 0.08), Effect("backlash", "q6", {"half_width": 0.03})])
    t = np.arange(0, 4, 0.01)
    q = np.zeros((len(t), 6))
    q[:, 5] = 0.5 * np.sin(2 * np.pi * t / 2)
    physics.reset(q[0])
    stepped = np.array([physics.step(row, 0.01) for row in q])
    assert stepped == pytest.approx(physics.simulate(q, t), abs=1e-12)


def test_the_calibrations_physics_model_inverts_it(kind):
    model = PhysicsModel.from_effects(
        "PSM1", [dead_zone("q5", 0.1), Effect("backlash", "q5", {"half_width": 0.02})], "test"
    )
    rng = np.random.default_rng(4)
    state = model.initial_state(np.zeros(6))
    for target in rng.uniform(-0.6, 0.6, (40, 6)):
        command = model.command_for(target, state)
        assert model.forward(command, state) == pytest.approx(target, abs=1e-9)
        state = model.advance(state, command)


def test_synth_conceals_it_and_diagnose_names_it(kind, tmp_path):
    out = tmp_path / "synth"
    with contextlib.redirect_stdout(io.StringIO()):
        assert (
            main(["sim2real", "synth", str(out), "--effect", "dead_zone", "--seed", "3", "--snr", "3"]) == 0
        )
    truth = json.loads((out / "truth.json").read_text())
    (hidden,) = truth["effects"]
    assert hidden["effect"] == "dead_zone"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["sim2real", "diagnose", str(out / "recording"), "--json", "--bootstrap", "0"]) == 0
    named = json.loads(printed.getvalue())["effects"]
    found = [e for e in named if e["effect"] == "dead_zone"]
    assert [e["joint"] for e in found] == [hidden["joint"]]
    assert found[0]["params"]["half_width"] == pytest.approx(hidden["params"]["half_width"], rel=0.15)
    assert "a dead zone" in found[0]["text"]
    assert all(e["joint"] == hidden["joint"] for e in named), named
