"""The phase simulator beside whole bilateral trials on the same worlds: a bending peg (1.5 mm), bilateral
uncalibrated, worlds 500 and 501. Each trial's transfers are read from its tick log alone; the two arms' run at
once, so each is matched to the phase simulator's by its pegs (`transfers("bilateral")`), simulated on its
own. The per-phase totals are what the fit compares: they must agree within chance."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
from scipy import stats

from pegbt.evaluation.trial import TrialSpec, run_trial
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import begun_transfers, transfer_outcomes
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import simulate_transfer, transfers

pytestmark = [pytest.mark.system, pytest.mark.slow]

SEEDS = range(500, 502)  # about 24 transfers: each whole trial with its recoveries costs about 45 s of CPU
# a trial whose look at half time finds no trustworthy block (every block of the first half dropped around
# the board) ends there, which the tree allows: each trial still begins its first half's six transfers
LEAST_TRANSFERS = 6 * len(SEEDS)
LEVEL = 0.01  # a χ² test of the two tables of totals: they differ beyond chance below this p-value


def test_bilateral_per_phase_totals_agree_with_whole_trials(tmp_path: Path) -> None:
    world = tmp_path / "hidden.yaml"
    world.write_text("effects:\n  - {kind: peg_compliance, deflection: 0.0015}\n")
    hidden = WorldEffects.of({"peg_compliance": {"deflection": 0.0015}})
    order = [(pick, place) for _, pick, place in transfers("bilateral")]
    trial, simulated = Counter[str](), Counter[str]()
    for seed in SEEDS:
        log_path = tmp_path / f"trial-{seed}.jsonl"
        record = run_trial(
            TrialSpec("bilateral", "uncalibrated", seed, log_path, keep_log=True, world_effects=world)
        )
        assert record.log and not record.error, record.error
        log = read_tick_log(log_path)
        for outcome, begin in zip(transfer_outcomes(log), begun_transfers(log)):
            index = order.index((begin["params"]["pick"], begin["params"]["place"]))
            result = simulate_transfer(hidden, "bilateral", "uncalibrated", seed, index=index)
            trial["placed" if outcome.succeeded else str(outcome.phase)] += 1
            simulated["placed" if result.succeeded else str(result.phase)] += 1
    categories = sorted(set(trial) | set(simulated))
    table = [[trial[c] for c in categories], [simulated[c] for c in categories]]
    assert sum(table[0]) >= LEAST_TRANSFERS, trial
    p = stats.chi2_contingency(table).pvalue
    assert p > LEVEL, (trial, simulated, p)
