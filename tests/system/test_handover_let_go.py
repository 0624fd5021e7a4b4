"""The giver rises out of the block it handed over only once its jaw has let go of it: while the receiver
grips the block too, a giver rising with its jaw still squeezing would drag the block up through the
receiver's jaw (1.6-2.3 mm in the simulator before the rise waited, docs/internals/motion.md)."""

from __future__ import annotations

import pytest
from trial_helpers import one_handover

from pegbt.evaluation.trial import TrialSpec, run_trial, truth_path
from pegbt.executive.logfile import read_tick_log
from pegbt.sim.log import read_sim_log

pytestmark = pytest.mark.system


def test_the_giver_rises_only_once_the_simulator_has_its_jaw_let_go(tmp_path):
    spec = TrialSpec(
        "handover",
        "optimized",
        3,
        tmp_path / "let-go.jsonl",
        None,
        tree=one_handover(tmp_path),
        keep_log=True,
    )
    record = run_trial(spec)
    assert [transfer["succeeded"] for transfer in record.transfers] == [True]
    entries = read_sim_log(truth_path(spec.log))
    (taken,) = [e for e in entries if e["kind"] == "grasp" and "handover from PSM2" in e.get("detail", "")]
    (let_go,) = [e for e in entries if e["kind"] == "release" and e["arm"] == "PSM2"]
    log = read_tick_log(spec.log)
    (rise,) = [node["id"] for node in log.nodes if node["type"] == "rise" and node["params"]["arm"] == "PSM2"]
    rising = min(change.t for change in log.transitions if change.node == rise and change.after == "RUNNING")
    assert taken["time"] < let_go["time"] <= rising
