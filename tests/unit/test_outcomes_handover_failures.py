"""A handover that fails after the giver holds the block out ends as a whole trial ends it
(`trees/shared/handover.yaml`): no arm goes on holding the block, and the next handover's receiver comes
from home, where `receive` parked it. The receiver's planning is refused here on purpose (its wait pose out
of reach, its carry unplannable), which the default world's geometry seldom does."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from pegbt.behaviours.resources.arm_motion import ArmMotion
from pegbt.errors import PegbtError
from pegbt.motion.ik import IKSolution
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes import exchange, trialsim
from pegbt.sim2real.outcomes.bench import START, Replay
from pegbt.sim2real.outcomes.phasesim import carry_out
from pegbt.sim2real.outcomes.transfer_result import TransferResult

SEED, INDEX = 1, 1  # calibrated, this handover places its block (PSM2 to PSM1, onto peg 6)
ARMS = ("PSM1", "PSM2")


def _handover(world: World, attempts: int) -> TransferResult:
    rng = np.random.default_rng([SEED, 7])
    return carry_out(world, "handover", "calibrated", INDEX, Replay(), attempts, False, rng)


@pytest.fixture
def no_wait_pose(monkeypatch: pytest.MonkeyPatch) -> Callable[[bool], None]:
    """Refuse the receiver's wait pose and grasp (the one IK of two poses) while switched on."""
    refusing = [False]
    solve = exchange.inverse_kinematics

    def refused(poses: Any, settings: Any = None) -> IKSolution:
        solution = solve(poses, settings)
        if refusing[0] and np.ndim(poses) == 3 and len(poses) == 2:
            return dataclasses.replace(solution, reachable=np.zeros(2, dtype=bool))
        return solution

    monkeypatch.setattr(exchange, "inverse_kinematics", refused)
    return lambda on: refusing.__setitem__(0, on)


@pytest.fixture
def no_receivers_carry(monkeypatch: pytest.MonkeyPatch) -> None:
    """Refuse to plan the receiver's carry from the meeting point (`from_handover`'s waypoints)."""
    made: list[TransferWaypoints] = []
    waypoints, transfer = exchange.from_handover, ArmMotion.transfer

    def recorded(*args: Any, **kwargs: Any) -> TransferWaypoints:
        made.append(waypoints(*args, **kwargs))
        return made[-1]

    def refused(self: ArmMotion, planned: TransferWaypoints, **kwargs: Any) -> Any:
        if any(planned is other for other in made):
            raise PegbtError("the carry is out of reach")
        return transfer(self, planned, **kwargs)

    monkeypatch.setattr(exchange, "from_handover", recorded)
    monkeypatch.setattr(ArmMotion, "transfer", refused)


def _loose_under_the_meeting_point(world: World, block: int) -> bool:
    return all(world.held_by(arm) is None for arm in ARMS) and world.blocks[block].peg is None


def test_the_giver_lets_go_when_the_receiver_cannot_wait_above_its_grasp(
    no_wait_pose: Callable[[bool], None], caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.ERROR, logger="pegbt")
    assert _handover(World(SEED), 4).succeeded  # as the world is
    no_wait_pose(True)
    for attempts in (1, 4):  # the paper's protocol and pegbt's: the receiver refuses, the giver lets go
        world = World(SEED)
        result = _handover(world, attempts)
        assert not result.succeeded and result.phase == "handover" and not result.over_goal
        assert _loose_under_the_meeting_point(world, 0)


@pytest.mark.usefixtures("no_receivers_carry")
def test_a_receiver_whose_carry_cannot_be_planned_lets_go_then_fetches_the_block_where_it_recovers(
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.ERROR, logger="pegbt")
    world = World(SEED)
    once = _handover(world, 1)
    assert not once.succeeded and once.phase == "carry"
    assert _loose_under_the_meeting_point(world, 0)
    world = World(SEED)
    fetched = _handover(world, 4)  # picked off the board and carried from there (`fetch`)
    assert fetched.succeeded and fetched.phase == "carry" and fetched.over_goal
    assert all(world.held_by(arm) is None for arm in ARMS)


def test_after_a_handover_failed_the_next_receiver_comes_from_home(
    no_wait_pose: Callable[[bool], None], monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """A calibrated trial whose second handover fails: the receiver of the third comes from home, parked
    from the simulator's start joints as before each half; that of the second came from its last placing."""
    caplog.set_level(logging.ERROR, logger="pegbt")
    index: list[int] = []
    parks: list[tuple[int, str, bool]] = []
    carry, park = trialsim.carry_out, exchange.planned_park

    def numbered(world: World, variant: str, condition: str, at: int, *args: Any) -> TransferResult:
        index.append(at)
        no_wait_pose(at == 1)
        return carry(world, variant, condition, at, *args)

    def parked(world: World, skills: Any, arm: str, start: np.ndarray) -> Any:
        parks.append((index[-1], arm, bool(np.array_equal(start, START))))
        return park(world, skills, arm, start)

    monkeypatch.setattr(trialsim, "carry_out", numbered)
    monkeypatch.setattr(exchange, "planned_park", parked)
    played = trialsim.simulate_trial([WorldEffects()], "handover", "calibrated", 0, 3)
    assert [(row[0].succeeded, row[0].phase) for row in played] == [
        (True, None),
        (False, "handover"),
        (True, None),
    ]
    receiver = [(at, from_start) for at, arm, from_start in parks if arm == "PSM1"]
    assert (0, True) in receiver and (2, True) in receiver  # the first of the half, and after the failure
    assert all(at != 1 for at, _ in receiver)  # from over peg 6, where it placed the first block


@pytest.mark.parametrize(("index", "parks"), [(0, True), (2, False)])
def test_a_handover_simulated_alone_starts_its_receiver_as_a_trial_does(
    index: int, parks: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Alone, as the fit simulates the paper's handovers: the receiver of the first handover of a half is
    parked at home from the start joints first, and a later one's comes from over the goal peg of the handover
    before (taken as placed), never straight from the start joints: the wrist's play at its grasp depends on
    that way."""
    parked: list[bool] = []
    starts: list[np.ndarray] = []
    park, start = exchange.planned_park, exchange._receiver_start

    def parking(world: World, skills: Any, arm: str, q0: np.ndarray) -> Any:
        parked.append(arm == "PSM1" and bool(np.array_equal(q0, START)))
        return park(world, skills, arm, q0)

    def receiver_start(trying: Any, *args: Any) -> np.ndarray:
        starts.append(start(trying, *args))
        return starts[-1]

    monkeypatch.setattr(exchange, "planned_park", parking)
    monkeypatch.setattr(exchange, "_receiver_start", receiver_start)
    rng = np.random.default_rng([SEED, 7])
    carry_out(World(SEED), "handover", "uncalibrated", index, Replay(), 1, True, rng)
    assert len(starts) == 1
    assert any(parked) == parks
    assert np.array_equal(starts[0], START) == parks
