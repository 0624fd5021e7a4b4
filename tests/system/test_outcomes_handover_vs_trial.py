"""The handover's phase simulator beside a whole trial on the same world and transfers: a bending peg
(1.5 mm), uncalibrated, world 501. The trial's outcomes are read from its tick log alone, as a real robot's
would be; the phase simulator plays the trial's transfers in order on one world (`simulate_trial`), its
receiver taking the block again after a miss and fetching one that slipped, as the fit simulates a handover
trial under pegbt's trees."""

from __future__ import annotations

from pathlib import Path

import pytest

from pegbt.evaluation.trial import TrialSpec, run_trial
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import transfer_outcomes
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.trialsim import simulate_trial

pytestmark = [pytest.mark.system, pytest.mark.slow]

SEED = 501


def test_the_handover_played_in_order_agrees_with_a_whole_trial(tmp_path: Path) -> None:
    world = tmp_path / "hidden.yaml"
    world.write_text("effects:\n  - {kind: peg_compliance, deflection: 0.0015}\n")
    log = tmp_path / "trial.jsonl"
    run_trial(TrialSpec("handover", "uncalibrated", SEED, log, keep_log=True, world_effects=world))
    trial = ["placed" if o.succeeded else o.phase for o in transfer_outcomes(read_tick_log(log))]
    hidden = WorldEffects.of({"peg_compliance": {"deflection": 0.0015}})
    played = simulate_trial([hidden], "handover", "uncalibrated", SEED, len(trial))
    simulated = ["placed" if r.succeeded else r.phase for (r,) in played]
    assert len(trial) == 12, trial
    # world 501 agrees on 8 of 12 transfers (6 with each transfer alone and no exchange retried, main at
    # eabb103); the rest differ on ways back, where the trial's giver missed or its receiver refused a block
    # fetched off the board that the phase simulator handed over and lost lowering it
    assert sum(t == s for t, s in zip(trial, simulated)) >= 8, (trial, simulated)
