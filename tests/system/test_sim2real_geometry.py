"""q1–q3 moving as one displacement of the tool is told from cable effects: a recording whose measured
joints are the closed-form inverse kinematics (`pegbt.motion.ik`, not the check's own Jacobian) of the
commanded tool pose displaced by a fixed vector is reported as geometry with that vector, and no cable
effect is named for it (what an offset takes up is a zero offset of the arm, reported apart); a constant
offset on q3 alone is such a zero offset too; a q2→q3 coupling of the same size, and a recording with no arm-joint
error, are not read as geometry."""

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest

from pegbt.cli import main
from pegbt.motion.ik import inverse_kinematics
from pegbt.motion.kinematics import forward_kinematics
from pegbt.physics import ArmPhysics, Effect
from pegbt.physics.recording import Recording, write_recording
from pegbt.sim2real.diagnose import diagnose
from tests.sim2real_helpers import commands

RESOLUTION = (0.01, 0.01, 0.0005, 0.01, 0.01, 0.01)
SIGMA = np.array([0.001, 0.001, 0.0001, 0.003, 0.003, 0.003])
WRIST = [Effect("offset", "q4", {"value": 0.1}), Effect("coupling", "q6", {"source": "q5", "k": 0.15})]


def _arm_commands(seed: int) -> np.ndarray:
    """Set-points over the dVRK recordings' range: insertion 0.14–0.23 m, yaw and pitch ±0.25 rad."""
    _, q = commands(seed, seconds=1200, rate_hz=1.25)
    q[:, :2] = 0.25 * q[:, :2] / np.abs(q[:, :2]).max(axis=0)
    q[:, 2] = 0.185 + 0.045 * (q[:, 2] - q[:, 2].mean()) / np.abs(q[:, 2] - q[:, 2].mean()).max()
    return q


def _measured(q_cmd: np.ndarray, effects: list[Effect], displacement: np.ndarray, seed: int) -> Recording:
    q_phy = ArmPhysics(effects).simulate(q_cmd)
    poses = forward_kinematics(q_phy)
    poses[:, :3, 3] += displacement
    solved = inverse_kinematics(poses)
    assert solved.reachable.all()
    q_phy = solved.q + np.random.default_rng(seed).normal(0, 1, q_cmd.shape) * SIGMA
    return Recording(Path(f"<geometry {seed}>"), q_cmd, q_phy, None, "PSM1")


def test_a_displaced_tool_is_reported_as_geometry_with_its_displacement(tmp_path):
    displacement = np.array([-0.003, -0.0015, 0.005])  # as grey1 shows
    recording = _measured(_arm_commands(1), WRIST, displacement, 1)
    folder = write_recording(tmp_path / "rec", recording.q_cmd, recording.q_phy, None, "PSM1", RESOLUTION)
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        args = ["sim2real", "diagnose", str(folder), "--out", str(tmp_path / "out"), "--bootstrap", "0"]
        assert main(args) == 0
    assert "geometry: q1–q3 move together as if the tool were displaced by" in printed.getvalue()
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    geometry = report["geometry"]
    assert geometry["displacement_m"] == pytest.approx(list(displacement), abs=0.0005)
    assert all(g < 0.8 * p for g, p in zip(geometry["heldout_ratio"], geometry["physics_ratio"]))
    assert "not a cable effect" in geometry["text"]
    assert "- Geometry: q1–q3 move together" in (tmp_path / "out" / "report.md").read_text()
    named = {(e["effect"], e["joint"]) for e in report["effects"]}
    assert {("offset", "q4"), ("coupling", "q6")} <= named
    # taken out before the cable effects are chosen: what is left of it is constant, offsets of the arm
    assert not {joint for _, joint in named} & {"q1", "q2", "q3"}
    assert {e["effect"] for e in report["zero_offsets"]} <= {"offset"}


def test_an_insertion_offset_is_a_zero_offset_of_the_arm_not_a_cable_effect(tmp_path):
    """A tool that sits 0.8 mm short of its command (as new2's does) beside wrist cable effects."""
    effects = [*WRIST, Effect("offset", "q3", {"value": -0.0008})]
    recording = _measured(_arm_commands(3), effects, np.zeros(3), 3)
    folder = write_recording(tmp_path / "rec", recording.q_cmd, recording.q_phy, None, "PSM1", RESOLUTION)
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        args = ["sim2real", "diagnose", str(folder), "--out", str(tmp_path / "out"), "--bootstrap", "0"]
        assert main(args) == 0
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert {(e["effect"], e["joint"]) for e in report["effects"]} == {("offset", "q4"), ("coupling", "q6")}
    (zero,) = report["zero_offsets"]
    assert (zero["effect"], zero["joint"]) == ("offset", "q3")
    assert zero["params"]["value"] == pytest.approx(-0.0008, abs=0.00005)
    assert "zero offset of the arm, geometry and not a cable effect: q3 sits -0.000" in printed.getvalue()
    assert (
        "- Zero offset of the arm, geometry and not a cable effect: q3 sits"
        in (tmp_path / "out" / "report.md").read_text()
    )
    model = {(e["effect"], e["joint"]) for e in report["model"]["effects"]}
    assert ("offset", "q3") in model  # the model, and a calibration from it, still compensate it


@pytest.mark.parametrize(
    "arm_effects",
    [[Effect("coupling", "q3", {"source": "q2", "k": 0.0026})], []],
    ids=["q2-to-q3 coupling", "no arm-joint error"],
)
def test_cable_effects_and_a_clean_arm_are_not_read_as_geometry(arm_effects):
    recording = _measured(_arm_commands(2), WRIST + arm_effects, np.zeros(3), 2)
    diagnosis = diagnose(recording, n_bootstrap=0, resolution=RESOLUTION)
    assert diagnosis.geometry is None
    named = {(e.effect.effect, e.effect.joint) for e in diagnosis.effects}
    assert (("coupling", "q3") in named) == bool(arm_effects)
