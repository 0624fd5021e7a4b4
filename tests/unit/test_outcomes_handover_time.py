"""A handover's receiver gets ready while the giver picks (the paper's place thread, pegbt's parallel
trees): the phase simulator plays its way to the waiting pose after the giver's, but a transfer's seconds
leave it out."""

from __future__ import annotations

import pytest

from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes import exchange
from pegbt.sim2real.outcomes.bench import Bench
from pegbt.sim2real.outcomes.phasesim import simulate_transfer


def test_the_receivers_way_to_the_meeting_is_not_added_to_the_transfer(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    clock = [0.0]
    update = World.update

    def tracked(self: World, time: float, *args: object, **kwargs: object) -> object:
        clock[0] = max(clock[0], time)
        return update(self, time, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(World, "update", tracked)
    result = simulate_transfer(
        WorldEffects(), "handover", "calibrated", 0, index=1, attempts=1, registered=True
    )
    assert result.succeeded
    assert result.seconds < clock[0] - 1.0  # the receiver's approach from its start: about 1.8 s


def test_the_receivers_placing_overlaps_the_givers_next_pick(monkeypatch: pytest.MonkeyPatch) -> None:
    """The paper's `run_pick` thread starts the next order once the giver has let go while `run_place`
    carries, lowers and opens (FLSPegTransfer_handover.py): a transfer's seconds end at the giver's
    letting go when the receiver's placing and way back take less than the giver's pick."""
    jaws: list[tuple[str, float]] = []
    jaw = Bench.jaw

    def tracked(self: Bench, angle: float, segment: str) -> None:
        jaw(self, angle, segment)
        jaws.append((segment, self.world.time))

    monkeypatch.setattr(Bench, "jaw", tracked)
    result = simulate_transfer(
        WorldEffects(), "handover", "calibrated", 0, index=1, attempts=1, registered=True
    )
    assert result.succeeded
    let_go = max(t for segment, t in jaws if segment == "handover")
    released = max(t for segment, t in jaws if segment == "release")
    assert released - let_go > 1.0  # the receiver's carry, lowering and opening
    # none of it, nor the receiver's way to the waiting pose from over peg 6, where it let go of the handover
    # before: about 0.7 s
    assert result.seconds < let_go - 0.5


def test_a_placing_longer_than_the_next_pick_adds_what_it_outlasts() -> None:
    assert exchange._overlapped(5.0, 4.0, 1.5, 1.5) == 5.0
    assert exchange._overlapped(5.0, 2.0, 1.5, 1.5) == pytest.approx(6.0)
