"""Recalibrating a re-homed arm end to end: 20 set-points collected from a simulator in real time whose arm
was re-homed, then refitted, recalibrate it."""

import contextlib
import io
import json

import numpy as np
import pytest

from pegbt.calibration.base import CalibrationModel
from pegbt.calibration.physics_model import PhysicsModel
from pegbt.calibration.refit import MIN_REFIT_SAMPLES
from pegbt.cli import main
from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import load_recording
from tests.sim2real_helpers import commands


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
