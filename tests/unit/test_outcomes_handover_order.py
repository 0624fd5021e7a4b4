"""A handover played as `trees/shared/handover.yaml` runs it: the receiver takes the block again after a
miss while the giver holds it out (`receive`'s `takes`), fetches a block that slipped on its way to the goal
peg (`fetch`), and a giver's pick from the board looks at the `strays` pegs once nothing lies loose; under
the paper's protocol (one attempt) none of that happens."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest

from pegbt.errors import PegbtError
from pegbt.frames import yaw_of, yaw_pose
from pegbt.motion.settings import motion_settings
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes import trying
from pegbt.sim2real.outcomes.bench import Bench
from pegbt.sim2real.outcomes.exchange import TAKES
from pegbt.sim2real.outcomes.phasesim import REGRASPS, simulate_transfer
from pegbt.sim2real.outcomes.transfer_order import RECEIVER as RECEIVER_OF
from pegbt.sim2real.outcomes.transfer_order import transfers
from pegbt.sim2real.outcomes.trialsim import chosen_block
from pegbt.sim2real.outcomes.trying import FETCH_REGRASPS
from pegbt.workcell import ORDERS_FILE, transfer_strays
from pegbt.yamlfile import read_settings_file

GIVER = transfers("handover")[0][0]  # PSM2 gives the first six
RECEIVER = RECEIVER_OF[GIVER]


def _on_board(world: World, block: int, xy: tuple[float, float]) -> None:
    lying = world.blocks[block]
    lying.pose = yaw_pose([*xy, world.cell.board.surface_z], yaw_of(lying.pose))
    lying.peg = None


@pytest.mark.parametrize(
    ("tree", "subtree", "arg", "simulated"),
    [
        ("one_transfer.yaml", "transfer_block", "regrasps", REGRASPS),
        ("handover.yaml", "give", "regrasps", REGRASPS),
        ("handover.yaml", "receive", "takes", TAKES),
        ("handover.yaml", "fetch", "regrasps", FETCH_REGRASPS),
    ],
)
def test_the_simulated_recoveries_are_the_trees(tree: str, subtree: str, arg: str, simulated: int) -> None:
    """The phase simulator retries as often as the shared subtrees do by default (no tree overrides them)."""
    args = read_settings_file(ORDERS_FILE.parent / tree).section("subtrees")[subtree]["args"]
    assert args[arg]["default"].integer() == simulated


def test_each_transfers_strays_are_read_from_an_orders_file(tmp_path: Path) -> None:
    orders = tmp_path / "orders.yaml"
    orders.write_text("lists:\n  mine:\n    - {pick: 1, place: 7, strays: [6]}\n    - {pick: 0, place: 6}\n")
    assert transfer_strays("mine", orders) == ((6,), ())


@pytest.mark.parametrize(
    ("strays", "field"),
    [("[12]", r"lists\.mine\[0\]\.strays\[0\]"), ("6", r"lists\.mine\[0\]\.strays: expected a list")],
)
def test_malformed_strays_are_refused_naming_file_line_and_field(
    tmp_path: Path, strays: str, field: str
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(f"lists:\n  mine:\n    - {{pick: 1, place: 7, strays: {strays}}}\n")
    with pytest.raises(PegbtError, match=rf"bad.yaml:3:\d+: {field}"):
        transfer_strays("mine", bad)


def test_a_giver_looks_at_the_strays_pegs_only_once_nothing_lies_loose() -> None:
    world = World(0)
    world.blocks[0].pose[:2, 3] = world.cell.pegs.positions[6]
    world.blocks[0].peg = 6  # dropped at the meeting point onto peg 6
    assert chosen_block(world, 7, dropped=True, strays=(6,)) == 0
    assert chosen_block(world, 7, dropped=True) is None  # a transfer without strays does not look there
    assert chosen_block(world, 7, dropped=False, strays=(6,)) is None  # nor before it lost its block
    _on_board(world, 1, (0.078, 0.026))
    assert chosen_block(world, 7, dropped=True, strays=(6,)) == 1  # a loose block comes first


@pytest.fixture
def receiver_jaw(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    """The receiver's jaw angles at the meeting point, as the simulated handover commands them."""
    angles: list[float] = []
    jaw = Bench.jaw

    def counted(bench: Bench, angle: float, segment: str) -> None:
        if bench.name == RECEIVER and segment == "handover":
            angles.append(angle)
        jaw(bench, angle, segment)

    monkeypatch.setattr(Bench, "jaw", counted)
    return angles


def test_a_receiver_that_misses_takes_the_block_again_up_to_its_takes(
    receiver_jaw: list[float], caplog: pytest.LogCaptureFixture
) -> None:
    """Default world, uncalibrated, layout 1, transfer 1: the receiver's jaw closes beside the block held
    out every time."""
    caplog.set_level(logging.ERROR, logger="pegbt")
    closed = motion_settings().transfer.jaw_closed
    once = simulate_transfer(WorldEffects(), "handover", "uncalibrated", 1, index=1, attempts=1)
    assert not once.succeeded and once.phase == "handover"
    assert receiver_jaw.count(closed) == 1
    receiver_jaw.clear()
    recovering = simulate_transfer(WorldEffects(), "handover", "uncalibrated", 1, index=1, attempts=4)
    assert not recovering.succeeded and recovering.phase == "grasp"  # as the tick log names the miss
    assert receiver_jaw.count(closed) == TAKES
    assert recovering.seconds > once.seconds


def test_a_block_that_slips_from_the_receiver_is_fetched(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """Default world, uncalibrated, layout 1, transfer 0: the block strikes peg 7 as the receiver lowers it;
    the receiver picks it off the board and places it."""
    caplog.set_level(logging.ERROR, logger="pegbt")
    picks: list[str] = []
    attempt = trying.pick_and_carry

    def recorded(*args: Any, **kwargs: Any) -> Any:
        picks.append(args[2])  # the arm
        return attempt(*args, **kwargs)

    monkeypatch.setattr(trying, "pick_and_carry", recorded)
    once = simulate_transfer(WorldEffects(), "handover", "uncalibrated", 1, index=0, attempts=1)
    assert not once.succeeded and once.phase == "lower"
    assert picks == [GIVER]
    picks.clear()
    fetched = simulate_transfer(WorldEffects(), "handover", "uncalibrated", 1, index=0, attempts=4)
    assert fetched.succeeded and fetched.phase == "lower"  # placed, after its first failure
    assert picks[0] == GIVER and picks[1:] and set(picks[1:]) == {RECEIVER}
