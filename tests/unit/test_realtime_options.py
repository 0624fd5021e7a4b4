"""`--clock` and `--interface` as `pegbt run` and `pegbt eval` take them: a robot cannot run on a clock that
only moves when asked, and `eval` hands real time and the interface to the simulator and the run."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.errors import PegbtError
from pegbt.evaluation.trial import TrialSpec, run_options, simulator_args
from pegbt.executive.runoptions import RunOptions
from pegbt.executive.session import run_tree_file

REPO = Path(__file__).resolve().parents[2]


def test_a_robot_cannot_run_on_a_clock_that_only_moves_when_asked(tmp_path):
    with pytest.raises(PegbtError, match="--clock.*manual clock"):
        run_tree_file(RunOptions(REPO / "trees" / "unilateral.yaml", tmp_path / "run.jsonl", clock="manual"))


def test_eval_passes_realtime_and_the_interface_to_the_simulator_and_the_run(tmp_path):
    spec = TrialSpec("unilateral", "optimized", 3, tmp_path / "t.jsonl", realtime=True, interface="dvrk")
    args = simulator_args(spec, tmp_path / "truth.jsonl")
    assert "--lockstep" not in args and args[args.index("--interface") + 1] == "dvrk"
    assert run_options(spec, "tcp/127.0.0.1:7447")["interface"] == "dvrk"
    lockstep = simulator_args(TrialSpec("unilateral", "optimized", 3, tmp_path / "t.jsonl"), tmp_path / "x")
    assert "--lockstep" in lockstep and "--interface" not in lockstep
