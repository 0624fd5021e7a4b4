"""The phase simulator's outcomes, first phases and seconds on fixed worlds, variants, conditions and seeds,
and a handover trial's first transfers played in order: what a refactoring must leave as it is. A change
that moves any of them changes the simulator, and says so (before and after, on these seeds) where it is
committed; the figures are then written here again from the changed simulator: `pytest -vv -n 0
tests/unit/test_outcomes_phasesim_fingerprint.py` shows every simulated value beside the one written here
(each test asserts its whole table at once)."""

from __future__ import annotations

import logging

import pytest

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import simulate_transfer
from pegbt.sim2real.outcomes.trialsim import simulate_trial

WORLDS = {"default": WorldEffects(), "bending": WorldEffects.of({"peg_compliance": {"deflection": 0.002}})}
# (variant, condition, seed, world, the paper's protocol): (placed, first failure's phase, seconds)
TRANSFERS = {
    ("unilateral", "uncalibrated", 1, "default", False): (False, "lift", 23.27),
    ("unilateral", "uncalibrated", 1, "bending", False): (True, None, 6.31),
    ("unilateral", "uncalibrated", 5, "default", False): (False, "lower", 22.06),
    ("unilateral", "uncalibrated", 5, "bending", False): (False, "lower", 22.06),
    ("unilateral", "calibrated", 1, "default", False): (True, None, 6.18),
    ("unilateral", "calibrated", 1, "bending", False): (True, None, 6.18),
    ("unilateral", "calibrated", 5, "default", False): (True, None, 6.53),
    ("unilateral", "calibrated", 5, "bending", False): (True, None, 6.53),
    ("bilateral", "uncalibrated", 1, "default", False): (False, "grasp", 18.64),
    ("bilateral", "uncalibrated", 1, "bending", False): (False, "grasp", 18.64),
    ("bilateral", "uncalibrated", 5, "default", False): (False, "lift", 22.31),
    ("bilateral", "uncalibrated", 5, "bending", False): (True, None, 6.15),
    ("bilateral", "calibrated", 1, "default", False): (True, None, 6.42),
    ("bilateral", "calibrated", 1, "bending", False): (True, None, 6.42),
    ("bilateral", "calibrated", 5, "default", False): (True, None, 6.02),
    ("bilateral", "calibrated", 5, "bending", False): (True, None, 6.02),
    ("handover", "uncalibrated", 1, "default", False): (False, "grasp", 13.34),
    ("handover", "uncalibrated", 1, "bending", False): (False, "grasp", 13.34),
    ("handover", "uncalibrated", 5, "default", False): (False, "grasp", 18.22),
    ("handover", "uncalibrated", 5, "bending", False): (False, "grasp", 18.22),
    ("handover", "calibrated", 1, "default", False): (True, None, 6.62),
    ("handover", "calibrated", 1, "bending", False): (True, None, 6.62),
    ("handover", "calibrated", 5, "default", False): (True, None, 6.75),
    ("handover", "calibrated", 5, "bending", False): (True, None, 6.75),
    ("unilateral", "uncalibrated", 1, "default", True): (False, "lift", 3.6),
    ("unilateral", "uncalibrated", 5, "default", True): (True, None, 6.72),
    ("bilateral", "uncalibrated", 1, "default", True): (True, None, 6.63),
    ("bilateral", "uncalibrated", 5, "default", True): (False, "lift", 3.69),
    ("handover", "uncalibrated", 1, "default", True): (False, "release", 6.63),
    ("handover", "uncalibrated", 5, "default", True): (False, "lower", 6.79),
}
# a handover trial, uncalibrated, layout 0, its first five transfers in both worlds (alike there)
TRIAL = [
    (False, "lower", 24.43),
    (False, "grasp", 18.31),
    (False, "lower", 23.79),
    (False, "grasp", 13.68),
    (False, "release", 5.78),
]


@pytest.fixture(autouse=True)
def _quiet(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.ERROR, logger="pegbt")


def test_single_transfers_keep_their_outcomes_phases_and_seconds() -> None:
    simulated = {}
    for variant, condition, seed, world, paper in TRANSFERS:
        result = simulate_transfer(
            WORLDS[world], variant, condition, seed, attempts=1 if paper else 4, registered=paper
        )
        simulated[(variant, condition, seed, world, paper)] = (
            result.succeeded,
            result.phase,
            round(result.seconds, 2),
        )
    assert simulated == TRANSFERS


def test_a_handover_trial_played_in_order_keeps_its_outcomes_phases_and_seconds() -> None:
    played = simulate_trial(list(WORLDS.values()), "handover", "uncalibrated", 0, len(TRIAL))
    simulated = [[(r.succeeded, r.phase, round(r.seconds, 2)) for r in row] for row in played]
    assert simulated == [[expected] * len(WORLDS) for expected in TRIAL]
