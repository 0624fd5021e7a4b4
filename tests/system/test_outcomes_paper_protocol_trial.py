"""The paper's protocol in whole trials beside the phase simulator's (`registered`, one attempt), on the
world the paper's table fits (grip compliance 2 mm): unilateral, uncalibrated, seeds 7000 and 7001. Each
trial's outcomes are read from its tick log alone; each of its transfers is simulated on its own.

The bar: over seeds 7000-7009 the two agreed on 93 of 120 transfers (77.5 %; per seed 7 to 11 of 12) and
placed 24 and 28; on these two seeds 18 of 24, placed 6 and 7. 16 of 24 and placed within 2 leave a
transfer or two of the seeds' spread, and the trees' own protocol fails both on the same seeds and world
(recovering, never looking before lowering: 15 of 24, placed 3 against 7), so they tell the protocols
apart."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from pegbt.errors import PegbtError
from pegbt.evaluation.trial import TrialSpec, run_trial
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import transfer_outcomes
from pegbt.sim.world_effects import WorldEffects, write_world_file
from pegbt.sim2real.outcomes.phasesim import simulate_transfer
from pegbt.sim2real.outcomes.ticklogs import read_tick_logs

pytestmark = [pytest.mark.system, pytest.mark.slow]

SEEDS = (7000, 7001)
FITTED = WorldEffects.of({"grip_compliance": {"displacement": 0.002}})  # the paper table's fit


@pytest.fixture(scope="module")
def trials(tmp_path_factory: pytest.TempPathFactory) -> dict[int, Path]:
    """Tick logs of the two trials under `--protocol paper` in the fitted world."""
    out = tmp_path_factory.mktemp("paper")
    world = write_world_file(FITTED, out / "world.yaml")
    logs = {}
    for seed in SEEDS:
        log = out / "logs" / f"unilateral-uncalibrated-paper-{seed}.jsonl"
        log.parent.mkdir(exist_ok=True)
        spec = TrialSpec(
            "unilateral", "uncalibrated", seed, log, keep_log=True, world_effects=world, protocol="paper"
        )
        record = run_trial(spec)
        assert record.outcome != "error", record.error
        logs[seed] = log
    return logs


def test_whole_trials_under_the_paper_s_protocol_agree_with_the_phase_simulator(trials):
    agree = placed = simulated_placed = 0
    for seed, log in trials.items():
        trial = ["placed" if o.succeeded else o.phase for o in transfer_outcomes(read_tick_log(log))]
        assert len(trial) == 12, trial
        simulated = [
            "placed" if r.succeeded else r.phase
            for r in (
                simulate_transfer(
                    FITTED, "unilateral", "uncalibrated", seed, index=k, attempts=1, registered=True
                )
                for k in range(12)
            )
        ]
        agree += sum(t == s for t, s in zip(trial, simulated))
        placed += trial.count("placed")
        simulated_placed += simulated.count("placed")
    assert agree >= 16, (agree, placed, simulated_placed)
    assert abs(placed - simulated_placed) <= 2


def test_the_logs_of_the_paper_s_protocol_are_counted_as_the_paper_counted(trials, tmp_path):
    """A way back whose block the way out lost is not an attempt (the paper's robot skipped it); a folder
    mixing protocols is refused, naming the log and the header's field."""
    outcomes = read_tick_logs(next(iter(trials.values())).parent)
    (cell,) = outcomes.cells
    assert outcomes.attempts_end_at_lost_block and (cell.variant, cell.condition) == (
        "unilateral",
        "uncalibrated",
    )
    sensed = sum(
        1 for log in trials.values() for o in transfer_outcomes(read_tick_log(log)) if o.phase == "sense"
    )
    assert sensed > 0 and cell.attempted == 24 - sensed and "sense" not in cell.failures
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    for seed, log in trials.items():
        lines = log.read_text().splitlines()
        if seed == SEEDS[1]:
            header = json.loads(lines[0])
            header["run"]["options"]["protocol"] = "pegbt"
            lines[0] = json.dumps(header)
        (mixed / log.name).write_text("\n".join(lines) + "\n")
    with pytest.raises(PegbtError, match="names protocol 'pegbt'") as raised:
        read_tick_logs(mixed)
    assert (raised.value.line, raised.value.field) == (1, "run.options.protocol")
