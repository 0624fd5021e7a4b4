"""Recalibrating a re-homed arm: a physics model keeps its effects and refits what moved from 20 set-points
of a re-homed copy of its recording whose truth is known (offsets alone; a coupling's gain; a narrower
play), keeps what set-points in a corner of the range cannot tell, and on the real recordings recovers
most of what a model trained on the new session gains."""

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest

from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.collect import random_setpoints, spread_setpoints
from pegbt.calibration.evaluation import evaluate
from pegbt.calibration.physics_model import PhysicsModel
from pegbt.calibration.refit import MIN_REFIT_SAMPLES, MIN_SPAN, refit, refit_at
from pegbt.calibration.task import task_box
from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import Recording, write_recording
from tests.sim2real_helpers import commands

SHAPE = [
    Effect("coupling", "q5", {"source": "q6", "k": 0.2}),
    Effect("hysteresis", "q5", {"source": "q6", "half_width": 0.1, "k": -0.4}),
    Effect("backlash", "q6", {"half_width": 0.04}),
]
FIRST = [Effect("offset", "q4", {"value": 0.15}), Effect("offset", "q6", {"value": 0.1})]
REHOMED = [Effect("offset", "q4", {"value": 0.05}), Effect("offset", "q5", {"value": -0.08})]


def _session(offsets, seed):
    _, q_cmd = commands(seed, seconds=400, rate_hz=1.25)
    noise = np.random.default_rng(seed).normal(0, 1, q_cmd.shape) * [
        0.001,
        0.001,
        0.0001,
        0.002,
        0.002,
        0.002,
    ]
    return Recording(
        Path(f"<session {seed}>"), q_cmd, ArmPhysics(SHAPE + offsets).simulate(q_cmd) + noise, arm="PSM1"
    )


def test_refit_on_20_set_points_recovers_the_new_offsets_and_the_tip_error():
    old = PhysicsModel.from_effects("PSM1", SHAPE + FIRST, "first set-up")
    session = _session(REHOMED, seed=3)
    refitted, moved = refit(old, session, 20)
    assert refitted.settled.physics.offset == pytest.approx([0, 0, 0, 0.05, -0.08, 0], abs=0.005)
    assert {e.effect for e in refitted.effects} <= {"coupling", "hysteresis", "backlash", "offset", "scale"}
    physics = refitted.settled.physics
    assert physics.coupling[4, 5] == pytest.approx(0.2, abs=0.02)  # the gains stay near the old model's
    assert physics.scale == pytest.approx(np.ones(6), abs=0.02)
    start = session.head(0.7)
    truth = PhysicsModel.from_effects("PSM1", SHAPE + REHOMED, "truth")
    stale, fresh, best = (evaluate(m, session, start)["tip_err_mm_mean"] for m in (old, refitted, truth))
    assert fresh < 1.1 * best < 0.5 * stale


def test_calibrate_refit_writes_a_model_and_refuses_other_kinds(tmp_path):
    old = PhysicsModel.from_effects("PSM1", SHAPE + FIRST, "first set-up")
    model_path = old.save(tmp_path / "old.json")
    session = _session(REHOMED, seed=4)
    folder = write_recording(tmp_path / "new", session.q_cmd, session.q_phy, None, arm="PSM1")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = main(
            [
                "calibrate",
                "refit",
                str(model_path),
                str(folder),
                "--samples",
                "20",
                "--out",
                str(tmp_path / "new.json"),
            ]
        )
    assert status == 0
    assert "q5: gains kept: offset on q5 0 → -0.0" in printed.getvalue()
    loaded = CalibrationModel.load(tmp_path / "new.json")
    assert loaded.settled.physics.offset[4] == pytest.approx(-0.08, abs=0.005)
    assert loaded.metadata.training["refit_samples"] == 20
    with pytest.raises(PegbtError, match="--samples must be"):
        refit(old, session, MIN_REFIT_SAMPLES - 1)


def test_refit_finds_which_gain_moved_and_keeps_the_rest():
    old = PhysicsModel.from_effects("PSM1", SHAPE + FIRST, "first set-up")
    moved_shape = [Effect("coupling", "q5", {"source": "q6", "k": 0.35}), *SHAPE[1:]]
    _, q_cmd = commands(5, seconds=400, rate_hz=1.25)
    noise = np.random.default_rng(5).normal(0, 0.002, q_cmd.shape) * [0.5, 0.5, 0.05, 1, 1, 1]
    session = Recording(
        Path("<moved gain>"), q_cmd, ArmPhysics(moved_shape + REHOMED).simulate(q_cmd) + noise, arm="PSM1"
    )
    refitted, report = refit(old, session, 20)
    priors = {joint.joint: joint.prior for joint in report}
    assert np.isfinite(priors["q5"])  # the set-points say q5's gains moved
    physics = refitted.settled.physics
    assert physics.scale[:3] == pytest.approx(np.ones(3), abs=0.002)  # nothing moved there but offsets
    assert 0.27 < physics.coupling[4, 5] < 0.37  # from 0.2 toward the new 0.35, the prior holding it back
    offsets_only, _ = refit(old, session, 20, gains=False)
    assert offsets_only.settled.physics.coupling[4, 5] == 0.2
    start = session.head(0.7)
    fresh, stale = (evaluate(m, session, start)["tip_err_mm_mean"] for m in (refitted, offsets_only))
    assert fresh < 0.7 * stale


def test_refit_finds_a_narrower_play_from_20_set_points_spread_over_the_session():
    """A re-homing that narrows the wrist's play (0.1 → 0.04 rad) as the shared recordings' set-ups differ:
    the refit narrows the width, which an offsets-only refit cannot, and comes near the truth."""
    old = PhysicsModel.from_effects("PSM1", SHAPE + FIRST, "first set-up")
    narrow = [SHAPE[0], Effect("hysteresis", "q5", {"source": "q6", "half_width": 0.04, "k": -0.4}), SHAPE[2]]
    _, q_cmd = commands(6, seconds=400, rate_hz=1.25)
    noise = np.random.default_rng(6).normal(0, 0.002, q_cmd.shape) * [0.5, 0.5, 0.05, 1, 1, 1]
    session = Recording(
        Path("<narrower play>"), q_cmd, ArmPhysics(narrow + REHOMED).simulate(q_cmd) + noise, arm="PSM1"
    )
    at = np.sort(np.random.default_rng(0).choice(session.head(0.7), 20, replace=False))
    refitted, report = refit_at(old, session, at)
    q5 = next(joint for joint in report if joint.joint == "q5")
    assert q5.width_factor < 1 and not q5.held
    width = next(e.params["half_width"] for e in refitted.effects if e.effect == "hysteresis")
    assert 0.02 <= width <= 0.06
    assert ("hysteresis q6→q5 half_width", 0.1, width) in q5.moved
    start = session.head(0.7)
    truth = PhysicsModel.from_effects("PSM1", narrow + REHOMED, "truth")
    offsets_only = refit_at(old, session, at, gains=False)[0]
    fresh, stale, best = (
        evaluate(m, session, start)["tip_err_mm_mean"] for m in (refitted, offsets_only, truth)
    )
    assert fresh < 1.06 * best < 0.6 * stale  # with the old width kept: 1.10 × best


def test_gains_stay_when_the_set_points_barely_move_the_joints_that_drive_them(tmp_path):
    """The first 20 set-points hold the wrist in a corner (as the shared recordings' do): q5's coupling
    from q6 moved (0.2 → 0.35), but no gain can be told there, so only offsets move, and the report and
    the command say why and what to collect instead."""
    moved_shape = [Effect("coupling", "q5", {"source": "q6", "k": 0.35}), *SHAPE[1:]]
    _, q_cmd = commands(7, seconds=400, rate_hz=1.25)
    q_cmd[:20, 3:] = q_cmd[20, 3:] + np.random.default_rng(7).normal(0, 0.01, (20, 3))  # 1 % of the range
    session = Recording(
        Path("<corner>"), q_cmd, ArmPhysics(moved_shape + REHOMED).simulate(q_cmd), arm="PSM1"
    )
    old = PhysicsModel.from_effects("PSM1", SHAPE + FIRST, "first set-up")
    refitted, report = refit(old, session, 20)
    held = {joint.joint: joint.held for joint in report}
    assert "of the task's range, under the 25 % a refit of gains needs" in held["q5"] and "q6 " in held["q5"]
    assert held["q1"] == ""  # the arm joints moved as usual
    assert refitted.settled.physics.coupling[4, 5] == 0.2
    assert np.isinf(next(joint.prior for joint in report if joint.joint == "q5"))
    assert refitted.settled.physics.offset[3] != old.settled.physics.offset[3]
    folder = write_recording(tmp_path / "corner", session.q_cmd, session.q_phy, None, arm="PSM1")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        args = [
            "calibrate",
            "refit",
            str(old.save(tmp_path / "old.json")),
            str(folder),
            "--out",
            str(tmp_path / "n"),
        ]
        assert main(args) == 0
    assert "note: only offsets moved on q4, q5, q6;" in printed.getvalue()
    assert "pegbt calibrate collect --refit MODEL" in printed.getvalue()


def test_a_refit_collection_spans_what_a_refit_needs_on_every_joint():
    """`collect --refit`'s spread design leaves no joint's gains held for want of span, where a random
    smooth path of 20 set-points often does."""
    lower, upper = task_box("PSM1")
    spread, smooth = [], []
    for seed in range(50):
        for design, spans in ((spread_setpoints, spread), (random_setpoints, smooth)):
            points = design(lower, upper, 20, np.random.default_rng(seed))
            assert np.all(points >= lower) and np.all(points <= upper)
            spans.append((np.ptp(points, axis=0) / (upper - lower)).min())
    assert min(spread) >= MIN_SPAN
    assert np.mean(np.array(smooth) < MIN_SPAN) > 0.3
