"""The additions that pass are ranked on fresh seeds as precisely as the real fit cells are counted: on
fewer simulated transfers than a large campaign holds, the simulated side's own noise picks the leader,
and a world the real counts cannot tell from it is never followed as a tie (the benchmark's grip seed 1,
named a 0.18 mm bend in its place)."""

from __future__ import annotations

from collections.abc import Callable

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Outcomes
from pegbt.sim2real.outcomes.diagnose import RANK_SEED, TIE_SEED, Settings, diagnose
from pegbt.sim2real.outcomes.phasesim import TransferResult
from tests.outcomes_helpers import Tasks, grip_or_bend, logged_cell, rate_mapper

HIDDEN = WorldEffects.of({"peg_compliance": {"deflection": 0.0018}})
SETTINGS = Settings(fit="unilateral", transfers=12, located=48, points=4)
REAL = 600  # real transfers a fit cell: more than `located`


def _ranked_seeds() -> tuple[Callable[[Tasks], list[list[TransferResult]]], dict[WorldEffects, set[int]]]:
    """`rate_mapper` of a bending peg or a yielding grip lifting a quarter, and per world the seeds of the
    ranking's block it was simulated on."""
    inner = rate_mapper(grip_or_bend(0.25), "lift")
    seen: dict[WorldEffects, set[int]] = {}

    def mapper(tasks: Tasks) -> list[list[TransferResult]]:
        for worlds, _, _, seed in tasks:
            if RANK_SEED <= seed < TIE_SEED:
                for world in worlds:
                    seen.setdefault(world, set()).add(seed - RANK_SEED)
        return inner(tasks)

    return mapper, seen


def test_passing_additions_are_ranked_on_as_many_transfers_as_the_largest_real_fit_cell() -> None:
    cells = tuple(
        logged_cell(HIDDEN, v, c, REAL if v == "unilateral" else 120, 3)
        for v in ("unilateral", "bilateral")
        for c in ("uncalibrated", "calibrated")
    )
    mapper, seen = _ranked_seeds()
    diagnose(Outcomes(cells, "a bending peg"), SETTINGS, mapper)
    kinds = {effect.kind for world in seen for effect in world}
    assert {"peg_compliance", "grip_compliance"} <= kinds  # both passed, so both were ranked
    assert all(seeds == set(range(REAL)) for seeds in seen.values())
