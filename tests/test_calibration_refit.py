"""Recalibrating a re-homed arm: a physics model keeps its shape and refits its offsets from the first
20 set-points of a re-homed copy of its recording, whose true offsets are known."""

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest

from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.evaluation import evaluate
from pegbt.calibration.physics_model import PhysicsModel
from pegbt.calibration.refit import refit_offsets
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
    refitted = refit_offsets(old, session, 20)
    assert refitted.settled.physics.offset == pytest.approx([0, 0, 0, 0.05, -0.08, 0], abs=0.005)
    assert {e.effect for e in refitted.effects} == {"coupling", "hysteresis", "backlash", "offset"}
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
    assert "offsets moved by" in printed.getvalue()
    loaded = CalibrationModel.load(tmp_path / "new.json")
    assert loaded.settled.physics.offset[4] == pytest.approx(-0.08, abs=0.005)
    assert loaded.metadata.training["refit_samples"] == 20
    with pytest.raises(PegbtError, match="--samples must be"):
        refit_offsets(old, session, 0)
