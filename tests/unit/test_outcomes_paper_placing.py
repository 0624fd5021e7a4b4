"""The paper's placing angle in the phase simulator's paper protocol (`paperplacing`; BerkeleyAutomation/
FLSpegtransferHO, `vision/GraspingPose3D.py` `find_placing_pose`): in all three variants the placing arm
lets go of the block with its tool at roll 0, whatever yaw it grasped at, and the block, turned with the
tool, still lands on its peg."""

from __future__ import annotations

import logging
import math

import pytest

from pegbt.behaviours.poses import yaw_about
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.phasesim import simulate_transfer
from pegbt.sim2real.outcomes.transfer_result import TransferResult


@pytest.fixture(autouse=True)
def _quiet(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.ERROR, logger="pegbt")


def releases(
    monkeypatch: pytest.MonkeyPatch, variant: str, seed: int, index: int, registered: bool
) -> tuple[TransferResult, list[float]]:
    """The transfer's result and the yaw (rad, about each arm's pegs' axis, in its frame) of every tool
    whose opening jaw let go of a block."""
    update = World.update
    yaws: list[float] = []

    def recorded(world: World, time: float, tools: dict) -> list:
        events = update(world, time, tools)
        for event in events:
            if event.kind == "release":
                cell = world.cell
                rotation = cell.board_to_arm(event.arm)[:3, :3] @ tools[event.arm].tip[:3, :3]
                yaws.append(yaw_about(rotation, cell.up_in(event.arm)))
        return events

    monkeypatch.setattr(World, "update", recorded)
    result = simulate_transfer(
        WorldEffects(), variant, "calibrated", seed, index=index, attempts=1, registered=registered
    )
    return result, yaws


# (variant, seed, transfer index): transfers whose grasp is 36-67° from roll 0 (PSM1 -67°, PSM2 36°, PSM1 -58°)
@pytest.mark.parametrize(
    ("variant", "seed", "index"), [("unilateral", 0, 0), ("bilateral", 0, 0), ("handover", 0, 4)]
)
def test_the_paper_places_at_roll_zero_and_on_the_peg(
    monkeypatch: pytest.MonkeyPatch, variant: str, seed: int, index: int
) -> None:
    result, yaws = releases(monkeypatch, variant, seed, index, registered=True)
    assert result.succeeded
    assert math.degrees(abs(yaws[-1])) < 2.0


@pytest.mark.parametrize(("variant", "seed", "index"), [("unilateral", 0, 0), ("handover", 0, 4)])
def test_pegbt_places_at_the_grasps_yaw(
    monkeypatch: pytest.MonkeyPatch, variant: str, seed: int, index: int
) -> None:
    result, yaws = releases(monkeypatch, variant, seed, index, registered=False)
    assert result.succeeded
    assert math.degrees(abs(yaws[-1])) > 20.0
