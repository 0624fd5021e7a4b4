"""`pegbt calibrate collect`: the collection tree on the executive, parameterised by the command's options."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.cli import main
from pegbt.errors import PegbtError
from pegbt.executive.loader import load_tree
from pegbt.executive.runoptions import RunOptions
from pegbt.executive.session import run_tree_file
from pegbt.physics.recording import MIN_SAMPLES

REPO = Path(__file__).resolve().parents[2]
COLLECT_TREE = REPO / "trees" / "calibrate_collect.yaml"


def test_too_few_minutes_for_a_recording_are_refused_before_anything_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["calibrate", "collect", "--arm", "PSM1", "--minutes", "0.05"]) == 2
    err = capsys.readouterr().err
    assert "--minutes: 0.05 min holds" in err and f"at least {MIN_SAMPLES}" in err
    assert not (tmp_path / "runs").exists()


def test_a_refit_collection_is_refused_before_anything_runs_when_it_cannot_refit(
    tmp_path, monkeypatch, capsys
):
    from pegbt.calibration.physics_model import PhysicsModel
    from pegbt.physics import ArmPhysics

    monkeypatch.chdir(tmp_path)
    model = PhysicsModel.from_effects("PSM1", ArmPhysics.load("dvrk-real", "PSM1").effects, "dvrk-real")
    path = str(model.save(tmp_path / "psm1.json"))
    assert main(["calibrate", "collect", "--arm", "PSM1"]) == 2
    assert "--minutes" in capsys.readouterr().err
    assert main(["calibrate", "collect", "--arm", "PSM1", "--refit", path, "--samples", "5"]) == 2
    assert "a refit needs at least 10 set-points, got 5" in capsys.readouterr().err
    assert main(["calibrate", "collect", "--arm", "PSM2", "--refit", path]) == 2
    assert "the model is PSM1's, not PSM2's" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists()


def test_a_command_sets_only_the_blackboard_values_the_tree_declares():
    loaded = load_tree(COLLECT_TREE)
    loaded.set_blackboard({"arm": "PSM2", "setpoints": 60})
    assert loaded.initial_blackboard["/arm"] == "PSM2" and loaded.initial_blackboard["/setpoints"] == 60
    with pytest.raises(PegbtError, match="declares no blackboard key 'speed'"):
        loaded.set_blackboard({"speed": 2})
    with pytest.raises(PegbtError, match="'setpoints' holds an int"):
        loaded.set_blackboard({"setpoints": "many"})


def test_a_blackboard_value_is_checked_like_a_literal_when_the_leaf_reads_it(tmp_path):
    """`seconds: $pause` set to a negative number by the command fails when the leaf reads it, naming the parameter."""
    tree = tmp_path / "pause.yaml"
    tree.write_text("blackboard: {pause: 0.1}\ntree: {wait: {name: pause, seconds: $pause}}\n")
    done = run_tree_file(RunOptions(tree, tmp_path / "ok.jsonl", clock="manual", blackboard={"pause": 0.2}))
    assert done.result.outcome == "success" and done.result.duration == pytest.approx(0.2)
    with pytest.raises(
        PegbtError,
        match=r"pause: parameter 'seconds' should be a number >= 0 and <= 86400; blackboard key 'pause' holds -1\.0",
    ):
        run_tree_file(RunOptions(tree, tmp_path / "bad.jsonl", clock="manual", blackboard={"pause": -1.0}))
