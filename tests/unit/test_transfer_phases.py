"""A failed transfer's phase, from its tick log alone: one transfer run on the in-memory robot (`fake_arm`)
whose block is scripted to slip out of the jaw at a point of the carrying motion, or is not between the
jaws at all. `transfer_outcomes` and `pegbt log why` name grasp, lift, lower, or release (the block placed
by the executive, and its goal peg empty at the next look)."""

from __future__ import annotations

from pathlib import Path

import py_trees
import pytest
from executive_helpers import write_tree
from fake_arm import fake_robot

from pegbt.behaviours.poses import transfer_for
from pegbt.behaviours.resources.skills import Skills
from pegbt.clock import ManualClock
from pegbt.executive.analysis import why
from pegbt.executive.causes import FailureStep
from pegbt.executive.context import RunContext
from pegbt.executive.loader import load_tree
from pegbt.executive.logfile import read_tick_log
from pegbt.executive.phases import TransferOutcome, failure_phase, transfer_outcomes
from pegbt.executive.runner import run
from pegbt.executive.ticklog import TickLogWriter
from pegbt.executive.work import WorkPool
from pegbt.motion.ik import solve_ik
from pegbt.perception.blocks import block_on_peg
from pegbt.sim.camera import DepthCamera
from pegbt.sim.world import World

PICK, PLACE = 1, 7
TREE = f"""
blackboard: {{/board: null, /blocks: null, /PSM1/block: null, /PSM1/grasp: null}}
tree:
  sequence:
    name: task
    children:
      - sequence:
          name: transfer
          children:
            - begin_transfer: {{name: begin, arms: PSM1, pick: {PICK}, place: {PLACE}, transfer: /PSM1/transfer}}
            - selector:
                name: move it or give up
                children:
                  - sequence:
                      name: move it
                      children:
                        - grasp: {{name: close and check, arm: PSM1, holding: /PSM1/holding}}
                        - transfer: {{name: lift carry and lower, arm: PSM1, place: {PLACE}, block: /PSM1/block, grasp: /PSM1/grasp, plan_s: /PSM1/plan_s, let_go_early: LET_GO}}
                        - release: {{name: release, arm: PSM1, holding: /PSM1/holding}}
                        - finish_transfer: {{name: placed, outcome: placed, transfer: /PSM1/transfer}}
                  - finish_transfer: {{name: failed, outcome: failed, transfer: /PSM1/transfer}}
      - check_placed: {{name: block home, pegs: [{PLACE}]}}
"""


@pytest.fixture(scope="module")
def scene():
    """The starting scene as perception sees it: the board and the blocks (peg 7 empty)."""
    cloud = DepthCamera(seed=0).capture(World(seed=0))
    skills = Skills("uncalibrated")
    board = skills.registration.fit(cloud)
    return cloud, board, skills.locator.locate(cloud, board)


LOOK = "      - capture: {{name: {0}}}\n      - find_blocks: {{name: {0} for blocks}}\n"


@pytest.fixture(scope="module")
def taken_scene():
    """The starting scene with the block of peg 0 moved onto the goal peg (7) already."""
    world = World(seed=0)
    block, pegs = world.blocks[0], world.cell.pegs.positions
    block.pose[:2, 3] += pegs[PLACE] - pegs[block.peg]
    block.peg = PLACE
    cloud = DepthCamera(seed=0).capture(world)
    skills = Skills("uncalibrated")
    board = skills.registration.fit(cloud)
    return cloud, board, skills.locator.locate(cloud, board)


@pytest.fixture(autouse=True)
def fresh_blackboard():
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def one_transfer(
    tmp_path: Path,
    scene,
    *,
    held: bool,
    slips_at: float | None,
    let_go: tuple[str, ...] = (),
    tree: str = TREE,
) -> Path:
    """Run the transfer of `tree` with the block between the jaws (`held`) and slipping out `slips_at` of
    the way through the arm's motion, letting go early under the conditions `let_go` (the trees: at rest,
    as uncalibrated); the tick log's path."""
    cloud, board, blocks = scene
    clock, skills = ManualClock(), Skills("uncalibrated")
    robot = fake_robot(clock, skills.settings, skills.cell, cloud)
    block = block_on_peg(blocks, PICK)
    grasp = skills.selectors["PSM1"].pick(block)
    arm = robot.arms["PSM1"]
    arm.rest = solve_ik(
        transfer_for(skills.cell, skills.motion, "PSM1", board, block, grasp).poses[0], arm.settings
    )
    arm.block_in_jaw, arm.slips_at = held, slips_at
    context = RunContext(
        clock=clock, resources={"robot": robot, "skills": skills}, work=WorkPool(inline=True)
    )
    built = load_tree(write_tree(tmp_path, tree.replace("LET_GO", f"[{', '.join(let_go)}]"))).build(context)
    built.initial_blackboard.update(
        {"/board": board, "/blocks": blocks, "/PSM1/block": block, "/PSM1/grasp": grasp}
    )
    log = tmp_path / "run.jsonl"
    run(built, period=0.05, timeout=60.0, log=TickLogWriter(log, built, clock_kind="manual"))
    return log


@pytest.mark.parametrize(
    ("held", "slips_at", "phase"),
    [
        (False, None, "grasp"),  # the jaw closes on nothing
        (True, 0.1, "lift"),  # lost as the block leaves its start peg
        (True, 0.93, "lower"),  # lost as it is lowered onto its goal peg
        (True, None, "release"),  # carried and let go, and not on its peg when next seen
    ],
)
def test_a_failed_transfer_names_its_phase(tmp_path, scene, held, slips_at, phase):
    log = read_tick_log(one_transfer(tmp_path, scene, held=held, slips_at=slips_at))
    assert transfer_outcomes(log) == [TransferOutcome(1, False, phase)]
    assert why(log).endswith(f"1: PSM1 peg {PICK} → {PLACE}: failed at {phase}")


def let_go_at(scene) -> float:
    """How far through the transfer's motion its jaw begins to let go of the block (`transfer`)."""
    _, board, blocks = scene
    skills = Skills("uncalibrated")
    block = block_on_peg(blocks, PICK)
    grasp = skills.selectors["PSM1"].pick(block)
    waypoints = transfer_for(skills.cell, skills.motion, "PSM1", board, block, grasp, PLACE)
    duration = skills.arm("PSM1").transfer(waypoints).duration
    transfer = skills.motion.transfer
    lead = (transfer.jaw_release - transfer.jaw_closed) / skills.settings["PSM1"].jaw_velocity
    return (duration - lead) / duration


def test_a_block_lost_as_the_lowering_ends_failed_at_lower(tmp_path, scene):
    """The jaw empty as the lowering ended, after the last look for a slip (the leaf succeeded; its detail
    says the jaw held nothing), and the goal peg empty at the next look: lost while lowered, not at the
    release."""
    log = read_tick_log(one_transfer(tmp_path, scene, held=True, slips_at=0.9999))
    (carried,) = [change for change in log.transitions if change.detail is not None]
    assert carried.after == "SUCCESS" and carried.detail == {"segment": "lower", "held": False}
    assert transfer_outcomes(log) == [TransferOutcome(1, False, "lower")]


def test_a_block_lost_just_before_the_jaw_lets_go_fails_the_carry_at_lower(tmp_path, scene):
    """A carry that lets go as it comes down finds its jaw already empty: it fails there, as for a slip
    seen earlier (so a transfer's recovery picks the block again), and names the lowering."""
    log = read_tick_log(
        one_transfer(tmp_path, scene, held=True, slips_at=let_go_at(scene) - 1e-4, let_go=("uncalibrated",))
    )
    (carried,) = [change for change in log.transitions if change.detail is not None]
    assert carried.after == "FAILURE" and carried.detail == {"segment": "lower", "held": False}
    assert transfer_outcomes(log) == [TransferOutcome(1, False, "lower")]


def test_a_block_let_go_over_a_goal_peg_seen_taken_before_is_not_placed(tmp_path, taken_scene):
    """The look before the transfer saw a block on its goal peg already (a way back whose block's way out
    never left it): the final check's block there is that one, no sign the carried block went down on it
    (the simulator drops a block lowered onto a taken peg beside it). Unseen, it would count as placed."""
    looking = TREE.replace(
        "    children:\n      - sequence:",
        f"    children:\n{LOOK.format('look')}      - sequence:",
    ).replace("      - check_placed:", f"{LOOK.format('look again')}      - check_placed:")
    log = read_tick_log(one_transfer(tmp_path, taken_scene, held=True, slips_at=None, tree=looking))
    ended = [change for change in log.transitions if change.after in ("SUCCESS", "FAILURE")]
    looks = [c.feedback for c in ended if log.nodes[c.node]["type"] == "find_blocks"]
    assert len(looks) == 2 and all(str(PLACE) in look.split("pegs: ")[1].split(", ") for look in looks)
    (checked,) = [c for c in ended if log.nodes[c.node]["type"] == "check_placed"]
    assert checked.after == "SUCCESS"  # a block is seen on the goal peg at the end
    assert transfer_outcomes(log) == [TransferOutcome(1, False, "release")]


def test_a_look_before_the_goal_peg_was_emptied_says_nothing_of_it(tmp_path, scene):
    """A way back (peg 7 to 1) whose goal peg a look saw taken, but before the way out picked its block
    off it: that look is stale, and the block the final check sees on peg 1 counts as placed. (The way
    back here only begins and is recorded placed: what is read is the looks and the record.)"""
    way_back = (
        "      - sequence:\n          name: way back\n          children:\n"
        f"            - begin_transfer: {{name: begin back, arms: PSM1, pick: {PLACE}, place: {PICK}, "
        "transfer: /PSM1/back}\n"
        "            - finish_transfer: {name: placed back, outcome: placed, transfer: /PSM1/back}\n"
    )
    looking = (
        TREE.replace("      - check_placed:", f"{way_back}{LOOK.format('look again')}      - check_placed:")
        .replace(
            "            - selector:",
            LOOK.format("look").replace("      - ", "            - ") + "            - selector:",
            1,
        )
        .replace(f"pegs: [{PLACE}]", f"pegs: [{PICK}]")
    )
    log = read_tick_log(one_transfer(tmp_path, scene, held=True, slips_at=None, tree=looking))
    ended = [change for change in log.transitions if change.after in ("SUCCESS", "FAILURE")]
    looks = [c.feedback for c in ended if log.nodes[c.node]["type"] == "find_blocks"]
    assert len(looks) == 2 and str(PICK) in looks[0].split("pegs: ")[1].split(", ")
    assert transfer_outcomes(log) == [TransferOutcome(1, True, None), TransferOutcome(2, True, None)]


@pytest.mark.parametrize(
    ("leaf", "said"),
    [
        (
            "find_handed_block",
            "2705 points: the block 6.0 mm off where it was planned held out, and PSM1 has no grasp of it",
        ),
        ("find_handed_block", "12 points where the block is held out, too few: no block seen"),
        ("over_seen_grasp", "PSM1 over the grasp: no joint solution"),
    ],
)
def test_a_receiver_that_cannot_take_the_block_it_looked_at_fails_the_handover(leaf: str, said: str) -> None:
    """The paper's look at the block held out (`look_at_handover`) is the handover's, as the phase simulator's
    paper handover counts it (`exchange.hand_over`): not a look for a block to pick (`sense`), nor nothing."""
    step = FailureStep("/handover/receive 5/look", "find it", leaf, 23.9, 270, said, "handover.yaml:343", ())
    assert failure_phase(step) == "handover"
