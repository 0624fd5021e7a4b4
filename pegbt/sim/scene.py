"""The arms in the world: each control tick, the world sees every tool where its physical joints put it,
each jaw stops where the block it grips stops it, and what happened goes into the simulator's log.

Shared by the simulator's two interfaces (`pegbt.sim.endpoint`, `pegbt.sim.dvrk_endpoint`), whose arms
differ in how they are commanded, not in how they act on the world.
"""

from __future__ import annotations

from collections.abc import Mapping

from pegbt.sim.arm import SimArm
from pegbt.sim.interfaces import SimWorld
from pegbt.sim.log import SimLog
from pegbt.sim.tools import ToolState, wrist_give


class Scene:
    """A world and the arms acting in it, logging the world's events to `log`."""

    def __init__(self, world: SimWorld, arms: Mapping[str, SimArm], log: SimLog) -> None:
        self.world = world
        self._arms = arms
        self._log = log
        self._arm_to_board = {name: world.arm_to_board(name) for name in arms}
        self._events_logged = 0  # world events already in the log

    def update(self, elapsed: float) -> None:
        """Move the world to `elapsed` (simulated s) with each tool where its physical joints put it; a
        gripped block stops the jaw."""
        tools = {
            name: ToolState.from_joints(
                arm.physical,
                float(arm.jaw.encoder[0]),
                self._arm_to_board[name],
                wrist_give(arm.physics, float(arm.physical[5]), self.world.cell.tool),
            )
            for name, arm in self._arms.items()
        }
        self.world.update(elapsed, tools)
        for name, arm in self._arms.items():
            arm.jaw.stop_at(self.world.jaw_stop(name))
        self.log_events()

    def log_events(self) -> None:
        """Put the world's new events (from a step, or a capture's noise burst) in the simulator's log."""
        events = self.world.events
        for event in events.since(self._events_logged):
            self._log.record_event(event)
        self._events_logged = len(events)
