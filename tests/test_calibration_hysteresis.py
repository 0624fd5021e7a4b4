"""A physics model whose effects include hysteresis (as `pegbt sim2real` identifies them) predicts it and,
streamed through Alg. 1, compensates it: the arm follows the desired wrist path, not the hysteresis loop."""

from __future__ import annotations

import numpy as np

from pegbt.behaviours.skills import PHYSICS_STREAM
from pegbt.calibration.compensation import Compensator, Iterations
from pegbt.calibration.physics_model import PhysicsModel
from pegbt.physics import ArmPhysics, Effect

EFFECTS = [
    Effect("offset", "q5", {"value": -0.1}),
    Effect("hysteresis", "q5", {"source": "q5", "half_width": 0.1, "k": 0.3}),
    Effect("hysteresis", "q5", {"source": "q6", "half_width": 0.15, "k": -0.4}),
    Effect("hysteresis", "q6", {"source": "q5", "half_width": 0.12, "k": -0.17}),
    Effect("backlash", "q6", {"half_width": 0.05}),
]


def wrist_path(steps: int = 600) -> np.ndarray:
    """Wrist pitch and yaw swinging back and forth (every turn flips the hysteresis), 10 ms apart."""
    t = np.linspace(0.0, 6.0, steps)
    q = np.tile([0.7, 0.1, 0.17, 0.0, 0.0, 0.0], (steps, 1))
    q[:, 4], q[:, 5] = 0.4 * np.sin(2.1 * t), 0.3 * np.sin(1.3 * t + 0.5)
    return q


def test_the_physics_model_predicts_hysteresis_as_the_arm_does():
    model = PhysicsModel.from_effects("PSM1", EFFECTS, source="test")
    desired, arm = wrist_path(), ArmPhysics(EFFECTS)
    arm.reset(desired[0])
    state = model.initial_state(desired[0])
    for q in desired:
        expected = arm.step(q, 0.01)
        assert np.allclose(model.forward(q, state), expected, atol=1e-9)
        state = model.advance(state, q)


def follow(desired: np.ndarray, compensator: Compensator | None) -> np.ndarray:
    """Wrist errors (rad) per step of an arm with `EFFECTS` streamed `desired`, compensated or not."""
    arm = ArmPhysics(EFFECTS)
    arm.reset(desired[0])
    if compensator is not None:
        compensator.reset(desired[0])
    reached = np.array([arm.step(q if compensator is None else compensator.step(q), 0.01) for q in desired])
    return np.abs(reached - desired)[:, 4:].max(axis=1)


def test_streamed_compensation_follows_the_desired_path_through_the_hysteresis():
    desired = wrist_path()
    model = PhysicsModel.from_effects("PSM1", EFFECTS, source="test")
    raw = follow(desired, None)
    compensated = follow(desired, Compensator(model, stream=PHYSICS_STREAM))
    one_per_row = follow(desired, Compensator(model, stream=Iterations(1, 1.0)))
    assert np.mean(raw) > 0.05
    assert np.mean(compensated) < 0.02 * np.mean(raw) and np.percentile(compensated, 95) < 0.002
    assert np.percentile(one_per_row, 95) > 5 * np.percentile(compensated, 95)  # why the skills iterate more
