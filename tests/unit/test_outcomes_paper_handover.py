"""The paper's handover in the phase simulator's paper protocol (`paperhandover`; BerkeleyAutomation/
FLSpegtransferHO, `FLSPegTransfer_handover.py`): the giver holds the block out at `height_handover`, z
−0.110 m in its own frame, its tool along its base's z, and the receiver closes where the camera then sees
the block, not where the giver was sent, its tool along its own base's z."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from pegbt.behaviours.meeting import Meeting
from pegbt.behaviours.paper_meeting import paper_meeting
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes import attempt, exchange
from pegbt.sim2real.outcomes.phasesim import simulate_transfer
from pegbt.sim2real.outcomes.transfer_order import RECEIVER, transfers

INDEX = 4  # layout 0's fifth transfer: PSM2 hands the block on peg 5 to PSM1 for peg 11
HANDOVER_Z = -0.110  # m, z in the giver's frame: `height_handover`, `height_ready` + 0.010


@pytest.fixture(autouse=True)
def _quiet(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.ERROR, logger="pegbt")


@pytest.fixture
def receiver_closing(monkeypatch: pytest.MonkeyPatch):
    """The receiver's tip (board frame) as its jaw first closes, the paper's look seeing the held block
    `shift` (board frame, m) from where it is."""
    receiver = RECEIVER[transfers("handover")[INDEX][0]]
    update, seen = World.update, exchange.seen_held

    def run(shift: np.ndarray) -> np.ndarray:
        tips: list[np.ndarray] = []

        def recorded(world: World, time: float, tools: dict) -> list:
            events = update(world, time, tools)
            tips.extend(
                tools[receiver].tip[:3, 3].copy()
                for e in events
                if e.kind in ("grasp", "grasp_miss") and e.arm == receiver
            )
            return events

        monkeypatch.setattr(World, "update", recorded)
        monkeypatch.setattr(
            exchange, "seen_held", lambda point, truth, noise: seen(point + shift, truth, noise)
        )
        simulate_transfer(
            WorldEffects(), "handover", "uncalibrated", 0, index=INDEX, attempts=1, registered=True
        )
        assert tips, "the receiver never closed its jaw"
        return tips[0]

    return run


def test_the_giver_holds_the_block_out_at_height_handover_in_its_frame_along_its_bases_z(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """`go_handover_traj` sends the giver to `[x, y, height_handover]` at `euler_to_quaternion([0, 0, 0])`,
    and `pick_block` the receiver to its grasp at `euler_to_quaternion([rot, 0, 0])`: both tools along their
    base's z, which the paper-era frames lean 1.3 and 1.7 degrees off the pegs' axis."""
    meetings: list[Meeting] = []

    def recorded(*args) -> Meeting | None:
        meeting = paper_meeting(*args)
        meetings.extend([meeting] if meeting is not None else [])
        return meeting

    monkeypatch.setattr(attempt, "paper_meeting", recorded)
    simulate_transfer(WorldEffects(), "handover", "uncalibrated", 0, index=INDEX, attempts=1, registered=True)
    tip, grasp = meetings[-1].tip, meetings[-1].receiver_grasp.pose
    assert tip[2, 3] == pytest.approx(HANDOVER_Z, abs=1e-9)
    assert tip[:3, :3] == pytest.approx(np.eye(3), abs=1e-9)  # yaw 0, the tool along the base's z
    assert grasp[:3, 2] == pytest.approx([0.0, 0.0, 1.0], abs=1e-9)


def test_the_receiver_takes_the_block_at_the_papers_handover_height(receiver_closing) -> None:
    world = World(0)
    tip = receiver_closing(np.zeros(3))
    giver = transfers("handover")[INDEX][0]
    in_givers_frame = world.cell.board_to_arm(giver) @ np.append(tip, 1.0)
    # the giver's tip at `height_handover`; the receiver's at its grasp, `grasp_depth` under the block's top,
    # which is `grasp_depth` over the giver's: level with it, within the arms' errors
    assert in_givers_frame[2] == pytest.approx(HANDOVER_Z, abs=0.004)


def test_the_receiver_closes_where_the_camera_sees_the_block(receiver_closing) -> None:
    shift = np.array([0.003, 0.0, 0.0])
    moved = receiver_closing(shift) - receiver_closing(np.zeros(3))
    assert moved[:2] == pytest.approx(shift[:2], abs=0.0005)
