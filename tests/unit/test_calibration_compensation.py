"""Compensation (Alg. 1): it reaches what was asked on an arm with known effects, and never leaves limits."""

import logging

import numpy as np
import pytest
import torch
from calibration_helpers import TRUTH, set_points, synthetic

from pegbt.calibration.base import CalibrationModel, new_model
from pegbt.calibration.compensation import CALIBRATION_DIR, Compensator
from pegbt.calibration.physics_model import PhysicsModel
from pegbt.errors import PegbtError
from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics, Effect


def _stream(points: np.ndarray, steps: int = 20) -> np.ndarray:
    """10 ms steps along straight lines between set-points."""
    return np.concatenate([np.linspace(a, b, steps, endpoint=False) for a, b in zip(points[:-1], points[1:])])


def _wrist_error(reached: np.ndarray, desired: np.ndarray) -> float:
    return float(np.sqrt(np.mean((reached[:, 3:] - desired[:, 3:]) ** 2)))


@pytest.mark.parametrize("kind", ["physics", "hybrid"])
def test_compensation_reaches_the_goals_on_an_arm_with_known_effects(kind):
    model = new_model(kind, "PSM1", **({"epochs": 100} if kind == "hybrid" else {})).fit(
        synthetic(400, noise=0.002)
    )
    desired = set_points(60, seed=11, margin=0.3)
    compensator = Compensator(model)
    compensator.reset(desired[0])
    issued = np.array([compensator.goal(q) for q in desired])
    truth = ArmPhysics(TRUTH)
    compensated = _wrist_error(truth.simulate(np.vstack([desired[:1], issued]))[1:], desired)
    uncompensated = _wrist_error(truth.simulate(desired), desired)
    assert compensated < 0.15 * uncompensated


def test_streamed_steps_are_compensated_too():
    model = PhysicsModel("PSM1").fit(synthetic(400, noise=0.002))
    desired = _stream(set_points(30, seed=12, margin=0.3))
    compensator = Compensator(model)
    compensator.reset(desired[0])
    issued = np.array([compensator.step(q) for q in desired])
    truth = ArmPhysics(TRUTH)
    reached = truth.simulate(np.vstack([desired[:1], issued]))[1:]
    assert _wrist_error(reached[20:], desired[20:]) < 0.1 * _wrist_error(truth.simulate(desired), desired)


def test_lstm_compensation_uses_its_model_and_reduces_its_error():
    """Alg. 1 proper: no explicit physics, the iteration alone brings f(q_c) to q_d."""
    model = new_model("lstm", "PSM1", epochs=30, hidden=32).fit(synthetic(300))
    desired = set_points(30, seed=13, margin=0.3)
    compensator = Compensator(model)
    compensator.reset(desired[0])
    predicted, raw = [], []
    for q in desired:
        state = compensator.state
        raw.append(model.forward(q, state))
        predicted.append(model.forward(compensator.goal(q), state))
    assert _wrist_error(np.array(predicted), desired) < 0.3 * _wrist_error(np.array(raw), desired)


def test_commands_never_leave_the_joint_or_velocity_limits(caplog):
    """An arm whose wrist reads 0.4 rad low: near the upper limit the compensated command would leave it."""
    model = PhysicsModel.from_effects("PSM1", [Effect("offset", "q5", {"value": -0.4})], source="test")
    limits = arm_settings("PSM1")
    desired = np.tile([0.0, 0.0, 0.15, 0.0, 0.0, 0.0], (300, 1))
    desired[:, 4] = np.linspace(0.0, limits.upper[4], 300)
    compensator = Compensator(model)
    compensator.reset(desired[0])
    with caplog.at_level(logging.WARNING, logger="pegbt.calibration"):
        issued = np.array([compensator.step(q) for q in desired])
    assert np.all(issued >= limits.lower) and np.all(issued <= limits.upper)
    assert np.all(np.abs(np.diff(issued, axis=0)) <= limits.velocity * limits.control_period + 1e-12)
    assert compensator.counts["joint_limit"] > 0 and compensator.counts["velocity_limit"] > 0
    assert 1 <= len(caplog.records) <= 4  # logged when it starts, not on every step
    assert "joint limits" in caplog.text


def test_a_desired_command_outside_the_limits_is_refused():
    compensator = Compensator(PhysicsModel.from_effects("PSM1", TRUTH, source="test"))
    with pytest.raises(PegbtError, match="q3 \\(insertion\\)"):
        compensator.goal([0, 0, 0.5, 0, 0, 0])
    with pytest.raises(PegbtError, match="is nan"):
        compensator.goal([0, 0, 0.15, 0, float("nan"), 0])


def test_nan_from_a_model_is_an_error():
    model = new_model("hybrid", "PSM1", epochs=1).fit(synthetic(200))
    with torch.no_grad():
        model.net[0].weight.fill_(float("nan"))
    compensator = Compensator(model)
    with pytest.raises(PegbtError, match="not finite"):
        compensator.goal(set_points(2, seed=1)[1])


def test_a_diverging_model_falls_back_to_the_raw_command_with_a_warning(caplog):
    """A model whose error grows with the correction (f(q) = q + 6 (q − q_raw)) cannot be iterated."""
    model = new_model("lstm", "PSM1", epochs=1, hidden=8).fit(synthetic(200))
    model.forward = lambda q_c, state, q_raw=set_points(2, seed=2)[1]: q_c + 6 * (q_c - q_raw) + 0.05
    compensator = Compensator(model)
    with caplog.at_level(logging.WARNING, logger="pegbt.calibration"):
        issued = compensator.goal(set_points(2, seed=2)[1])
    assert np.array_equal(issued, set_points(2, seed=2)[1])
    assert compensator.counts["fallback"] == 1 and "uncompensated" in caplog.text


@pytest.mark.parametrize(
    "path", ["sim-dvrk-real/PSM1-physics.json", "sim-dvrk-real/PSM2-physics.json", "PSM1-hybrid.json"]
)
def test_a_trajectory_at_once_is_what_step_gives_row_by_row(path, caplog):
    """The shipped models (the simulator's and a real arm's), along a stream through the wrist's plays;
    the limits bite on the way (the clamp counts and warnings match too)."""
    model = CalibrationModel.load(CALIBRATION_DIR / path)
    limits = arm_settings(model.arm)
    desired = _stream(set_points(12, seed=21, margin=0.05), steps=15)
    desired[40:60, 4] = limits.upper[4]  # compensation pushes past the limit here
    by_row, at_once = Compensator(model), Compensator(model)
    by_row.reset(desired[0])
    at_once.reset(desired[0])
    with caplog.at_level(logging.WARNING, logger="pegbt.calibration"):
        expected = np.array([by_row.step(q) for q in desired])
        warned, caplog.records[:] = len(caplog.records), []
        got = at_once.trajectory(desired)
    assert got.tobytes() == expected.tobytes()
    assert by_row.counts["joint_limit"] > 0 and by_row.counts["velocity_limit"] > 0 and warned > 0
    assert at_once.counts == by_row.counts and len(caplog.records) == warned
    assert at_once.step(desired[-1]).tobytes() == by_row.step(desired[-1]).tobytes()  # the same history


def test_a_trajectory_with_a_row_outside_the_limits_is_refused_whole():
    model = CalibrationModel.load(CALIBRATION_DIR / "sim-dvrk-real/PSM1-physics.json")
    desired = _stream(set_points(4, seed=22, margin=0.3))
    compensator = Compensator(model)
    compensator.reset(desired[0])
    before = compensator.state
    outside, broken = desired.copy(), desired.copy()
    outside[37, 2] = 0.5
    broken[12, 4] = float("nan")
    with pytest.raises(PegbtError, match="row 37 .*q3 \\(insertion\\)"):
        compensator.trajectory(outside)
    with pytest.raises(PegbtError, match="row 12 .*is nan"):
        compensator.trajectory(broken)
    with pytest.raises(PegbtError, match="N×6"):
        compensator.trajectory(desired[:, :5])
    assert compensator.state is before
