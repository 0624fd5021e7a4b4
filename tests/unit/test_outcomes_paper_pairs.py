"""The paper's bilateral action pairs in the phase simulator's paper protocol (`paperpairs`;
BerkeleyAutomation/FLSpegtransferHO, `FLSPegTransfer_dual.py`): the two arms move a pair of blocks at once,
and a pair whose blocks are not both found on their pick pegs is skipped, both arms' transfers of it."""

from __future__ import annotations

import logging

import pytest

from pegbt.errors import PegbtError
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.paperpairs import action_partner, partners_skipped
from pegbt.sim2real.outcomes.phasesim import simulate_transfer
from pegbt.sim2real.outcomes.transfer_order import transfers

# `FLSPegTransfer_dual.py`'s `action_list`: [[PSM2's pick, PSM1's pick], [PSM2's place, PSM1's place]]
PAPER_ACTIONS = [
    [[0, 1], [7, 8]],
    [[2, 3], [6, 11]],
    [[4, 5], [9, 10]],
    [[7, 8], [0, 1]],
    [[6, 11], [2, 3]],
    [[9, 10], [4, 5]],
]
CHAMFERS = WorldEffects.of({"chamfer_capture": {"capture_radius": 0.0033}})


@pytest.fixture(autouse=True)
def _quiet(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.ERROR, logger="pegbt")


def test_the_trees_bilateral_transfers_pair_as_the_papers_action_list() -> None:
    order = transfers("bilateral")
    pairs = []
    for index, (arm, start, goal) in enumerate(order):
        partner = action_partner("bilateral", index)
        assert partner is not None and action_partner("bilateral", partner) == index
        if arm == "PSM2":
            _, other_start, other_goal = order[partner]
            pairs.append([[start, other_start], [goal, other_goal]])
    assert sorted(pairs) == sorted(PAPER_ACTIONS)
    assert action_partner("unilateral", 6) is None and action_partner("handover", 6) is None


def paper(effects: WorldEffects, seed: int, index: int) -> tuple[bool, bool]:
    result = simulate_transfer(
        effects, "bilateral", "uncalibrated", seed, index=index, attempts=1, registered=True
    )
    return result.succeeded, result.skipped


def test_a_way_back_is_skipped_when_its_partners_block_was_lost() -> None:
    """Layout 0, default world: PSM2 places its block on peg 7 (0 -> 7), PSM1 loses its own at the lift
    (1 -> 8), so the pair back (7 -> 0, 8 -> 1) is not attempted, PSM2's transfer included."""
    assert paper(WorldEffects(), 0, 0) == (True, False)
    assert paper(WorldEffects(), 0, 3) == (False, False)
    assert paper(WorldEffects(), 0, 6)[1]


def test_a_way_back_whose_pair_was_placed_is_attempted() -> None:
    """Layout 0 with chamfers that catch the block within 3.3 mm: both blocks of the second pair are placed
    (2 -> 6, 3 -> 11), so PSM2 carries its block back (6 -> 2)."""
    assert paper(CHAMFERS, 0, 1) == (True, False)
    assert paper(CHAMFERS, 0, 4) == (True, False)
    assert not paper(CHAMFERS, 0, 7)[1]


def _trial(*pegs: tuple[int, int]) -> list[dict[str, int]]:
    return [{"index": index, "pick": pick, "place": place} for index, (pick, place) in enumerate(pegs)]


def test_a_skipped_transfer_the_trial_or_the_order_does_not_know_is_an_error_naming_it() -> None:
    """A caller's bug, not a transfer to pass over: its partner would be counted as attempted."""
    trial = _trial((0, 7), (1, 8), (7, 0), (8, 1))
    assert partners_skipped("bilateral", trial, {2}) == {3}
    with pytest.raises(
        PegbtError, match=r"skipped transfer 5 is not one of the trial's transfers \(\[0, 1, 2, 3\]\)"
    ):
        partners_skipped("bilateral", trial, {2, 5})
    with pytest.raises(
        PegbtError, match=r"skipped transfer 1 \(1 -> 7\) is not one of bilateral's transfers"
    ) as raised:
        partners_skipped("bilateral", _trial((0, 7), (1, 7)), {1})
    assert raised.value.field == "skipped"
