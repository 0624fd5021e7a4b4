"""A task's transfer is the one its seed names, with the protocol's attempts: `_run` once passed the
attempts where `simulate_transfer` takes the transfer's index, so every task simulated transfer 4 (1
with the paper's protocol), never the way back."""

from __future__ import annotations

import pytest

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes import simulate
from pegbt.sim2real.outcomes.phasesim import TransferResult


@pytest.mark.parametrize("attempts", [simulate.ONE_ATTEMPT, simulate.WITH_RECOVERY])
def test_a_task_simulates_its_seeds_transfer_with_the_protocols_attempts(monkeypatch, attempts):
    asked = []

    def record(effects, variant, condition, seed, replay=None, index=None, attempts=4, registered=False):
        asked.append((seed, index, attempts, registered))
        return TransferResult(True, None, 1.0)

    monkeypatch.setattr(simulate, "simulate_transfer", record)
    simulate._run(((WorldEffects(),), "unilateral", "uncalibrated", 7), attempts=attempts, registered=True)
    assert asked == [(7, None, attempts, True)]
