"""Recalibrating a re-homed arm: a physics model keeps its shape and refits what moved from the first
20 set-points of a re-homed copy of its recording, whose truth is known: offsets alone (the gains keep the
old model's values), or offsets and a coupling's gain (the refit finds which joint's gains moved)."""

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.evaluation import evaluate
from pegbt.calibration.physics_model import PhysicsModel
from pegbt.calibration.refit import MIN_REFIT_SAMPLES, refit
from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import Recording, load_recording, write_recording
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


@pytest.mark.slow
def test_collect_refit_recalibrates_a_rehomed_simulated_arm_from_20_set_points(tmp_path, monkeypatch):
    """`pegbt calibrate collect --refit` against `pegbt sim` whose physics is the model's moved by offsets."""
    from pegbt.sim.process import SimProcess

    monkeypatch.chdir(tmp_path)
    shape = ArmPhysics.load("dvrk-real", "PSM1").effects
    old = PhysicsModel.from_effects("PSM1", shape, "dvrk-real")
    shift = {"q4": 0.06, "q5": -0.05, "q6": 0.04}
    rehomed = [
        Effect("offset", e.joint, {"value": e.params["value"] + shift[e.joint]})
        if e.effect == "offset" and e.joint in shift
        else e
        for e in shape
    ]
    physics = tmp_path / "rehomed.json"
    physics.write_text(json.dumps({"effects": [e.to_dict() for e in rehomed]}))
    model_path = old.save(tmp_path / "old.json")
    printed = io.StringIO()
    with SimProcess(["--physics", str(physics), "--no-world"]) as sim, contextlib.redirect_stdout(printed):
        status = main(
            [
                "calibrate",
                "collect",
                "--arm",
                "PSM1",
                "--refit",
                str(model_path),
                "--samples",
                "20",
                "--endpoint",
                sim.endpoint,
                "--out",
                str(tmp_path / "points"),
                "--model-out",
                str(tmp_path / "new.json"),
            ]
        )
    assert status == 0, printed.getvalue()
    assert "PSM1: 20 set-points to refit" in printed.getvalue()
    recording = load_recording(tmp_path / "points", min_samples=MIN_REFIT_SAMPLES)
    assert recording.n == 20
    refitted = CalibrationModel.load(tmp_path / "new.json")
    moved = refitted.settled.physics.offset - old.settled.physics.offset
    assert moved[3:] == pytest.approx([0.06, -0.05, 0.04], abs=0.01)
    truth = ArmPhysics(rehomed)
    _, q_cmd = commands(9, seconds=200, rate_hz=1.25)
    measured = truth.simulate(q_cmd)
    stale, fresh = (np.abs(m.predict(q_cmd) - measured)[:, 3:].mean() for m in (old, refitted))
    assert fresh < 0.3 * stale
