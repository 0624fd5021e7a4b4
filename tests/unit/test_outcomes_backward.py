"""Of two effects named one after the other, the first must still earn its place once the second is in the
world: a registration offset chosen first (it raises the rate part of the way) and a bending peg added on
top is, where the peg alone does as well, the peg alone (the concealed campaign's false discovery). So is
such a path that ended a tie and is named whole, kept alone on fresh seeds or deciding the tie."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.diagnose import Settings, _replicated, _resolved
from pegbt.sim2real.outcomes.fit import Candidate, Profile, Verdict
from pegbt.sim2real.outcomes.phasesim import TransferResult
from tests.outcomes_helpers import lift_success

PEG = WorldEffects.of({"peg_compliance": {"deflection": 0.0015}})
OFFSET = Candidate("registration_offset", "x", (0.001,))
BENDING = Candidate("peg_compliance", "deflection", (0.0015,))
GRIP = Candidate("grip_compliance", "displacement", (0.0015,))  # changes nothing here
SETTINGS = Settings(fit="unilateral", transfers=16, located=240, points=4)


def stand_in_mapper(
    tasks: Sequence[tuple[tuple[WorldEffects, ...], str, str, int]],
) -> list[list[TransferResult]]:
    """A bending peg sets the rate (`lift_success`); an offset without it raises the rate a third of the way
    there, and adds nothing beside it."""
    out = []
    for worlds, variant, condition, seed in tasks:
        u = np.random.default_rng([seed, 99]).random()
        row = []
        for world in worlds:
            rate = lift_success(world, variant, condition)
            if world.has("registration_offset") and not world.has("peg_compliance"):
                base = lift_success(WorldEffects(), variant, condition)
                rate = base + (lift_success(PEG, variant, condition) - base) / 3
            placed = bool(u < rate)
            row.append(TransferResult(placed, None if placed else "lift", 4.0))
        out.append(row)
    return out


def _cells() -> list[Cell]:
    """The bending peg's expected counts, 480 transfers a condition."""
    return [
        Cell("unilateral", c, 480, round(480 * lift_success(PEG, "unilateral", c)))
        for c in ("uncalibrated", "calibrated")
    ]


def _profile(candidate: Candidate, base: WorldEffects = WorldEffects()) -> Profile:
    return Profile(candidate, candidate.grid, [{}], np.zeros((1, 2)), base)


def test_an_effect_that_only_stood_in_for_the_next_is_dropped() -> None:
    cells = _cells()
    offset = _profile(OFFSET)
    both = _profile(BENDING, offset.world())
    alone = _profile(BENDING)
    verdict = Verdict((offset, both), (), (offset, alone), np.zeros(2), ())
    kept, dropped = _replicated(stand_in_mapper, verdict, cells, SETTINGS, None)
    assert [p.world() for p in kept.named] == [PEG]
    assert dropped == ("registration_offset.x",)


def test_the_second_effect_is_named_alone_only_if_it_holds_alone() -> None:
    """The offset only stood in beside a 1.5 mm bend; but fitted alone the bend came out at a hundredth of
    a millimetre, which fits no better than the default world on fresh seeds: neither is named."""
    faint = Candidate("peg_compliance", "deflection", (0.00001,))
    offset = _profile(OFFSET)
    verdict = Verdict(
        (offset, _profile(BENDING, offset.world())), (), (offset, _profile(faint)), np.zeros(2), ()
    )
    kept, dropped = _replicated(stand_in_mapper, verdict, _cells(), SETTINGS, None)
    assert kept.named == () and dropped == ("registration_offset.x", "peg_compliance.deflection")


def test_two_effects_that_both_act_are_both_kept() -> None:
    cells = _cells()
    slight = Candidate("peg_compliance", "deflection", (0.0003,))
    offset = _profile(OFFSET)
    both = _profile(slight, offset.world())
    alone = _profile(slight)

    def adding(tasks: Sequence[tuple[tuple[WorldEffects, ...], str, str, int]]) -> list[list[TransferResult]]:
        """An offset beside a slightly bending peg places as the bending peg does: the pair is needed."""
        swapped = [
            (
                tuple(PEG if w.has("registration_offset") and w.has("peg_compliance") else w for w in worlds),
                variant,
                condition,
                seed,
            )
            for worlds, variant, condition, seed in tasks
        ]
        return stand_in_mapper(swapped)

    verdict = Verdict((offset, both), (), (offset, alone), np.zeros(2), ())
    kept, dropped = _replicated(adding, verdict, cells, SETTINGS, None)
    assert [p.candidate.kind for p in kept.named] == ["registration_offset", "peg_compliance"]
    assert dropped == ()


def _tied_path() -> Verdict:
    """A tie between a yielding grip and the path of an offset then a bending peg on top, whose offset
    only stands in for the peg; the peg was also fitted alone."""
    offset, grip = _profile(OFFSET), _profile(GRIP)
    end = _profile(BENDING, offset.world())
    tried = (offset, _profile(BENDING), grip)
    return Verdict((), (grip, end), tried, np.zeros(2), (), paths=((grip,), (offset, end)))


def test_a_tied_path_that_alone_holds_is_weighed_and_named_as_its_second() -> None:
    """The grip fails on fresh seeds and the path holds; the tie is kept for the weighing, where the path
    leads by far: its offset only stood in, so the peg is named alone."""
    kept, dropped = _replicated(stand_in_mapper, _tied_path(), _cells(), SETTINGS, None)
    assert kept.named == () and len(kept.tied) == 2 and dropped == ()
    verdict, said, dropped = _resolved(stand_in_mapper, kept, _cells(), SETTINGS)
    assert said.startswith("The tie is decided") and [p.world() for p in verdict.named] == [PEG]
    assert dropped == ("registration_offset.x",)


def test_a_tie_decided_for_a_path_whose_first_effect_only_stood_in_names_its_second() -> None:
    verdict, said, dropped = _resolved(stand_in_mapper, _tied_path(), _cells(), SETTINGS)
    assert said.startswith("The tie is decided") and verdict.tied == ()
    assert [p.world() for p in verdict.named] == [PEG]
    assert dropped == ("registration_offset.x",)


def test_a_tie_decided_for_a_path_of_which_nothing_holds_alone_names_nothing() -> None:
    offset, grip = _profile(OFFSET), _profile(GRIP)
    end = _profile(BENDING, offset.world())
    faint = _profile(Candidate("peg_compliance", "deflection", (0.00001,)))
    tie = Verdict((), (grip, end), (offset, faint, grip), np.zeros(2), (), paths=((grip,), (offset, end)))
    verdict, said, dropped = _resolved(stand_in_mapper, tie, _cells(), SETTINGS)
    assert verdict.named == () and verdict.tied == ()
    assert said.startswith("The tie is decided") and said.endswith(
        "no effect of its path holds alone on fresh seeds."
    )
    assert dropped == ("registration_offset.x", "peg_compliance.deflection")
