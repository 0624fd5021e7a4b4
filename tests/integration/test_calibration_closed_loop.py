"""Calibration in the loop: collect from the simulator over zenoh, fit, and compensate the transfer waypoints."""

import json

import numpy as np
import pytest

from pegbt.calibration.base import new_model
from pegbt.calibration.closed_loop import collect_on_simulator, simulator_tip_errors
from pegbt.calibration.task import task_box, transfer_goals
from pegbt.physics import ArmPhysics
from pegbt.physics.recording import load_recording
from pegbt.sim.arm import DEFAULT_JOINTS


@pytest.fixture(scope="module")
def collected(tmp_path_factory):
    """400 set-points of PSM1 collected from a lockstep simulator with the dvrk-real cables."""
    return load_recording(
        collect_on_simulator("PSM1", tmp_path_factory.mktemp("sim") / "sim_PSM1", 400, seed=0)
    )


@pytest.mark.slow  # the module's collection on the simulator
def test_a_collected_recording_is_in_the_dataset_layout_and_covers_the_task(collected):
    assert collected.arm == "PSM1" and len(collected) == 400
    assert json.loads((collected.path / "meta.json").read_text())["arm"] == "PSM1"
    assert collected.sampling.mode == "setpoints"  # each sample after 0.3 s of rest, as the dVRK recordings
    lower, upper = task_box("PSM1")
    assert np.all(collected.q_cmd >= lower - 1e-9) and np.all(collected.q_cmd <= upper + 1e-9)
    goals = transfer_goals("PSM1")
    assert np.all(goals >= lower) and np.all(goals <= upper)
    # The simulator's arm has the cables of its preset: the recording is what they do to the set-points
    # (after the arm's start, settled at its default joints).
    replayed = ArmPhysics.load("dvrk-real", "PSM1").simulate(np.vstack([DEFAULT_JOINTS, collected.q_cmd]))[1:]
    assert np.allclose(collected.q_phy, replayed, rtol=0, atol=1e-6)


def test_compensation_cuts_the_tip_error_at_transfer_waypoints_on_the_simulator(collected):
    model = new_model("physics", "PSM1").fit(collected)
    goals = transfer_goals("PSM1")[:4]  # grasp, lift, above the goal peg, lowered onto it
    uncompensated = simulator_tip_errors("PSM1", goals)
    compensated = simulator_tip_errors("PSM1", goals, model)
    assert uncompensated.mean() > 1.0  # mm: the cables matter
    assert compensated.mean() < uncompensated.mean() / 20
