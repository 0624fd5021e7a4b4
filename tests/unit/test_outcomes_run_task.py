"""A task's transfer is the one its seed names, with the protocol's attempts: `_run` once passed the
attempts where `simulate_transfer` takes the transfer's index, so every task simulated transfer 4 (1
with the paper's protocol), never the way back. Under pegbt's trees a unilateral seed is one
transfer of a trial played in order (`trialsim`), so the trial is played up to it."""

from __future__ import annotations

import pytest

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes import simulate, workers
from pegbt.sim2real.outcomes.phasesim import TransferResult


@pytest.mark.parametrize(
    ("variant", "attempts"),
    [
        ("unilateral", simulate.ONE_ATTEMPT),
        ("bilateral", simulate.ONE_ATTEMPT),
        ("bilateral", simulate.WITH_RECOVERY),
    ],
)
def test_a_task_simulates_its_seeds_transfer_with_the_protocols_attempts(monkeypatch, variant, attempts):
    asked = []

    def record(effects, variant, condition, seed, replay=None, index=None, attempts=4, registered=False):
        asked.append((seed, index, attempts, registered))
        return TransferResult(True, None, 1.0)

    monkeypatch.setattr(simulate, "simulate_transfer", record)
    simulate._run(((WorldEffects(),), variant, "uncalibrated", 7), attempts=attempts, registered=True)
    assert asked == [(7, None, attempts, True)]


def test_under_the_trees_a_task_plays_its_trial_up_to_its_seeds_transfer(monkeypatch):
    asked = []

    def record(worlds, variant, condition, layout, count, attempts=4, registered=False):
        asked.append((layout, count, attempts, registered))
        return [[TransferResult(k == count - 1, None, 1.0) for _ in worlds] for k in range(count)]

    monkeypatch.setattr(simulate, "simulate_trial", record)
    (result,) = simulate._run(((WorldEffects(),), "unilateral", "uncalibrated", 12 * 3 + 7), attempts=4)
    assert asked == [(3, 8, 4, False)]  # trial 3's transfers 0-7: seed 43 is its transfer 7
    assert result.succeeded


def test_a_trials_seeds_are_simulated_once_and_come_back_in_order(monkeypatch):
    asked = []

    def record(worlds, variant, condition, layout, count, attempts=4, registered=False):
        asked.append((layout, count))
        return [[TransferResult(True, None, float(12 * layout + k)) for _ in worlds] for k in range(count)]

    monkeypatch.setattr(simulate, "simulate_trial", record)
    seeds = [14, 3, 12, 5, 0]
    tasks = [((WorldEffects(),), "unilateral", "uncalibrated", seed) for seed in seeds]
    results = workers.LocalMapper(0)(tasks)
    assert [r[0].seconds for r in results] == seeds
    assert sorted(asked) == [(0, 6), (1, 3)]
