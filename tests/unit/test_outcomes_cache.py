"""The memo of simulated transfers the benchmark's diagnoses share is right only if a transfer is a function
of its inputs (world, variant, condition, seed): the same alone, among other worlds (the arm replayed from
them) and again; and a diagnosis through a memo other diagnoses filled reports what a fresh one does."""

from __future__ import annotations

from typing import Any

import pytest

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cache import MemoMapper
from pegbt.sim2real.outcomes.cells import Cell, Outcomes
from pegbt.sim2real.outcomes.diagnose import Settings, diagnose
from pegbt.sim2real.outcomes.report import report_dict
from pegbt.sim2real.outcomes.simulate import _run
from tests.outcomes_helpers import fake_mapper, real_counts

CELLS = [(v, c) for v in ("unilateral", "bilateral", "handover") for c in ("uncalibrated", "calibrated")]
SETTINGS = Settings(fit="unilateral", transfers=16, located=32, points=4)
WORLDS = (
    WorldEffects.of({"peg_compliance": {"deflection": 0.0015}}),
    WorldEffects.of({"registration_offset": {"x": 0.002}}),
    WorldEffects(),
)


@pytest.mark.parametrize(("variant", "seed"), [("unilateral", 3), ("bilateral", 8), ("handover", 15)])
def test_a_transfer_is_the_same_alone_among_other_worlds_and_again(variant: str, seed: int) -> None:
    together = _run((WORLDS, variant, "uncalibrated", seed))
    alone = [_run(((world,), variant, "uncalibrated", seed))[0] for world in reversed(WORLDS)][::-1]
    assert alone == together
    assert _run((WORLDS[::-1], variant, "uncalibrated", seed)) == together[::-1]


def _outcomes(world: WorldEffects, seed: int) -> Outcomes:
    return Outcomes(
        tuple(Cell(v, c, 120, real_counts(world, v, c, 120, seed + i)) for i, (v, c) in enumerate(CELLS)),
        "test",
    )


def _without_time(report: dict[str, Any]) -> dict[str, Any]:
    return {key: value for key, value in report.items() if key != "seconds"}


def test_a_diagnosis_through_a_memo_other_diagnoses_filled_reports_what_a_fresh_one_does() -> None:
    memo = MemoMapper(fake_mapper)
    diagnose(_outcomes(WorldEffects.of({"peg_compliance": {"deflection": 0.002}}), seed=5), SETTINGS, memo)
    filled = memo.simulated
    real = _outcomes(WorldEffects.of({"peg_compliance": {"deflection": 0.0015}}), seed=0)
    cached = diagnose(real, SETTINGS, memo)
    fresh = diagnose(real, SETTINGS, fake_mapper)
    assert _without_time(report_dict(cached)) == _without_time(report_dict(fresh))
    assert cached.simulated == fresh.simulated  # what the diagnosis needs, however much was remembered
    assert memo.simulated - filled < fresh.simulated  # most of it was
