"""A handover's receiver gets ready while the giver picks (the paper's place thread, pegbt's parallel
trees): the phase simulator plays its way to the waiting pose after the giver's, but a transfer's seconds
leave it out."""

from __future__ import annotations

import pytest

from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
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
