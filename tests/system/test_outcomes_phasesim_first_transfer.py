"""The phase simulator beside a trial's first transfer, world for world: a bending peg (1.5 mm), the unilateral
task uncalibrated, worlds 500–504, each trial one transfer (peg 1 to peg 7) with its three recoveries, read
from its tick log alone. The trial's arm starts at the simulator's start joints and parks before it looks;
a recovery lets go, parks and looks again with the arm as the failed attempt left it. Where the phase
simulator started every attempt at rest over the previous goal peg, its first attempts all placed the
block, where three trials of these five lost it at `lower` (six of ten on worlds 500–509)."""

from __future__ import annotations

from pathlib import Path

import pytest
from trial_helpers import short_task

from pegbt.evaluation.trial import TrialSpec, run_trial
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import TransferCauses, failure_phase, transfer_outcomes, transfer_scopes
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import simulate_transfer

pytestmark = [pytest.mark.system, pytest.mark.slow]

SEEDS = range(500, 505)  # a one-transfer trial costs about 10 s of CPU


def _trial(tmp_path: Path, tree: Path, world: Path, seed: int) -> tuple[str, str]:
    """The trial's first attempt and its transfer's outcome, each `placed` or the phase of the failure."""
    log_path = tmp_path / f"trial-{seed}.jsonl"
    record = run_trial(
        TrialSpec("unilateral", "uncalibrated", seed, log_path, keep_log=True, world_effects=world, tree=tree)
    )
    assert record.log, record.error
    log = read_tick_log(log_path)
    (outcome,) = transfer_outcomes(log)
    causes = TransferCauses(log)
    scope = transfer_scopes(log)[1]
    recovered = [step for step in causes.recovered if any(step.path.startswith(s + "/") for s in scope)]
    first = failure_phase(recovered[0]) if recovered else None
    if not outcome.succeeded:
        first = first or outcome.phase
    return str(first or "placed"), "placed" if outcome.succeeded else str(outcome.phase)


def test_first_transfers_agree_with_trials_attempt_for_attempt(tmp_path: Path) -> None:
    world = tmp_path / "hidden.yaml"
    world.write_text("effects:\n  - {kind: peg_compliance, deflection: 0.0015}\n")
    hidden = WorldEffects.of({"peg_compliance": {"deflection": 0.0015}})
    tree = short_task(tmp_path, regrasps=3)
    trials = [_trial(tmp_path, tree, world, seed) for seed in SEEDS]
    first = [
        simulate_transfer(hidden, "unilateral", "uncalibrated", seed, index=0, attempts=1) for seed in SEEDS
    ]
    whole = [simulate_transfer(hidden, "unilateral", "uncalibrated", seed, index=0) for seed in SEEDS]
    simulated = [
        ("placed" if f.succeeded else str(f.phase), "placed" if w.succeeded else str(w.phase))
        for f, w in zip(first, whole)
    ]
    assert sum(t[0] == s[0] for t, s in zip(trials, simulated)) >= 4, (trials, simulated)
    assert sum(t[1] == s[1] for t, s in zip(trials, simulated)) >= 4, (trials, simulated)
