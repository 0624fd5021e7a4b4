"""Every leaf behaviour's declaration: its name, what it does, its parameters, the blackboard keys and
resources it uses, and where its implementation is (`module:attribute`, imported only when a tree is
built to run). The validator and `pegbt tree check|schema` read this table alone, so checking a tree
imports none of the libraries the leaves run with (py_trees, Open3D, SciPy, zenoh); a unit test builds
every leaf declared here, so a declaration and its implementation cannot drift apart.
"""

from __future__ import annotations

from typing import Any

from pegbt.behaviours.params import (
    PATIENCE,
    RESOURCES,
    arm_param,
    carry_params,
    handover_number,
    held_param,
    keep_apart_param,
    key_param,
    let_go_early_param,
    peg_param,
    stop_above_param,
)
from pegbt.executive.conditions import OPERATORS
from pegbt.executive.params import MAX_SECONDS, Param
from pegbt.executive.registry import declare
from pegbt.handover_protocol import Giver, Receiver
from pegbt.pegboard import N_PEGS
from pegbt.psm import ARMS
from pegbt.runconditions import CONDITIONS

MAX_SAMPLES = 1_000_000  # set-points: about 95 hours of collection at 174 a minute
MAX_SETTLE = 60.0  # s a set-point is held before it is sampled
SETTLE = 0.3  # s: `pegbt.calibration.collect.SETTLE_S`, as the dVRK recordings rest before a sample
DESIGNS = ("smooth", "spread")  # `pegbt.calibration.collect.DESIGNS`: how a collection picks its set-points
MAX_RISE = 0.165  # m: the PSM's whole insertion travel (0.08-0.245 m, skills/psm.yaml)
OUTCOMES = ("success", "failure", "running")  # what a `scripted` leaf may return

declare(
    "collect_calibration",
    "drive `arm` through `samples` set-points over the task's joints (uncompensated; `design` smooth: a random "
    "smooth path, spread: each joint's range covered, for a refit), hold each `settle` s, and record set-point "
    "and physical joints to the recording folder `out`",
    "pegbt.behaviours.actions.collect_calibration:CollectCalibration",
    params=(
        arm_param(blackboard=True),
        Param("samples", int, "set-points to record", minimum=2, maximum=MAX_SAMPLES, blackboard=True),
        Param(
            "settle",
            float,
            "seconds to hold each set-point before sampling it",
            default=SETTLE,
            minimum=0.0,
            maximum=MAX_SETTLE,
        ),
        Param(
            "design",
            str,
            "how the set-points are drawn: smooth (to train a model) or spread (to refit one)",
            default="smooth",
            choices=DESIGNS,
            blackboard=True,
        ),
        Param("out", str, "recording folder to write (relative to the working directory)", blackboard=True),
        Param(
            "seed",
            int,
            "seed of the random set-points",
            default=0,
            minimum=0,
            maximum=2**32 - 1,
            blackboard=True,
        ),
    ),
    resources=("robot",),
)

declare(
    "wait",
    "run for `seconds` of the executive's clock, then succeed",
    "pegbt.behaviours.actions.generic:Wait",
    params=(Param("seconds", float, "how long, s", minimum=0.0, maximum=MAX_SECONDS, blackboard=True),),
)

declare(
    "set_blackboard",
    "write `value` (or the value of another key, `$key`) to blackboard `key`, then succeed",
    "pegbt.behaviours.actions.generic:set_blackboard",
    params=(
        Param("key", str, "key to write", key="write"),
        Param("value", Any, "value to write; `$other` copies key `other`", blackboard=True),
    ),
)

declare(
    "log",
    "log `message` (and `value`, e.g. `$key`) to the run's output and the tick log, then succeed",
    "pegbt.behaviours.actions.generic:Log",
    params=(
        Param("message", str, "text to log"),
        Param(
            "value",
            Any,
            "optional value appended to the message; `$key` shows a blackboard value",
            default=None,
            blackboard=True,
        ),
        Param("level", str, "log level", default="info", choices=("debug", "info", "warning", "error")),
    ),
)

declare(
    "scripted",
    "return the given outcomes one per tick, across retries (for testing recovery logic)",
    "pegbt.behaviours.actions.generic:scripted",
    params=(
        Param("outcomes", list[str], "outcomes in order", choices=OUTCOMES, minimum=1),
        Param(
            "then",
            str,
            "after the list: repeat the last outcome, or start the list again",
            default="last",
            choices=("last", "cycle"),
        ),
        Param("message", str, "feedback message when the outcome is failure (why it failed)", default=""),
    ),
)

declare(
    "select_grasp",
    "choose `arm`'s grasp of the block on peg `peg` from `/blocks` (or, with `dropped`, of a block lying off "
    "the pegs, nearest to that peg); writes `block` and `grasp`",
    "pegbt.behaviours.actions.grasping:SelectGrasp",
    params=(
        arm_param(),
        peg_param("peg", "peg the block should be on"),
        Param(
            "dropped",
            bool,
            "if the peg is empty, take the block lying on the board nearest to it (`$key`: only "
            "once the transfer has lost its block, so an empty pick peg is reported, not covered up)",
            default=False,
            blackboard=True,
        ),
        Param(
            "strays",
            list[int],
            "with `dropped`: pegs a lost block may have fallen onto and no block belongs on yet "
            "(the peg under the handover's meeting point); a block there is taken if none lies on the board",
            choices=tuple(range(N_PEGS)),
            default=[],
        ),
        Param(
            "another",
            bool,
            "pick again: if the block is the one last chosen (still within `SAME_BLOCK` of "
            "where it was seen), prefer another of its candidates than the one that failed (`$key`)",
            default=False,
            blackboard=True,
        ),
        Param(
            "handover_to",
            str,
            "a giver's pick: only grasps from which the block can be handed to this arm "
            "(`handover_poses` finds a grasp of the receiver clear of the giver's tool); '': any grasp",
            default="",
            choices=("", *ARMS),
        ),
        key_param("block", "write", "the block chosen (perception's estimate)"),
        key_param("grasp", "write", "the grasp chosen (tip pose in the arm frame)"),
    ),
    reads=("/blocks", "/board"),
    resources=RESOURCES,
)

declare(
    "approach",
    "move `arm` over its chosen grasp at the transfer height and down onto it, opening the jaw on the way",
    "pegbt.behaviours.actions.grasping:Approach",
    params=(
        arm_param(),
        key_param("grasp", "read", "the chosen grasp"),
        key_param("block", "read", "the block to grasp"),
        keep_apart_param(),
        Param(
            "close_on_arrival",
            list[str],
            "the conditions under which the jaw closes as the tip arrives, meeting the block's wall then (a "
            "block on a peg or the board stands still); under the others it narrows to `jaw_at_grasp` and "
            "`grasp` closes it from there",
            default=[],
            choices=CONDITIONS,
        ),
    ),
    reads=("/board",),
    resources=RESOURCES,
)

declare(
    "grasp",
    "close `arm`'s jaw and check from the jaw's encoder that it stopped on a block; writes `holding`",
    "pegbt.behaviours.actions.grasping:CloseOnBlock",
    params=(arm_param(), held_param(), key_param("holding", "write", "whether the jaw holds a block")),
    resources=RESOURCES,
)

declare(
    "release",
    "open `arm`'s jaw, letting go of whatever it holds; writes `holding` false",
    "pegbt.behaviours.actions.grasping:Release",
    params=(
        arm_param(),
        key_param("holding", "write", "whether the jaw holds a block (now false)"),
        Param(
            "once_clear",
            bool,
            "done once the measured jaw has opened past where it clears the block's wall (24°, "
            "`jaw_clear_of_wall`), its opening going on: a giver's rise after it starts then, not at the "
            "opening's end",
            default=False,
        ),
    ),
    resources=RESOURCES,
)

declare(
    "handover_poses",
    "where the handover happens: the giver's tip pose at the meeting point, the pose the block it holds will "
    "have there, and the receiver's grasp of it (nearest the receiver, on another wall than the giver's jaw, "
    "clear of the giver's tool)",
    "pegbt.behaviours.actions.handover:HandoverPoses",
    params=(
        arm_param("the giver"),
        Param("receiver", str, "the receiver", choices=ARMS),
        key_param("grasp", "read", "the giver's grasp"),
        key_param("block", "read", "the block the giver holds (as perceived on its peg)"),
        key_param("meeting", "write", "the giver's tip pose at the meeting point (giver frame)"),
        key_param("block_pose", "write", "the block's pose at the meeting point (board frame)"),
        key_param("receiver_grasp", "write", "the receiver's grasp of the block there"),
    ),
    reads=("/board",),  # the giver's carry to the meeting point is planned as soon as it is known
    resources=RESOURCES,
)

declare(
    "carry_to_handover",
    "lift the block held by `arm` (the giver) off its peg and carry it to the meeting pose; fails at once "
    "if the block slips",
    "pegbt.behaviours.actions.handover:CarryToHandover",
    params=carry_params(
        key_param("grasp", "read", "the giver's grasp"),
        key_param("block", "read", "the block held"),
        key_param("meeting", "read", "the giver's tip pose at the meeting point"),
        Param(
            "rise",
            float,
            "how far the `rise` after letting go moves up, m: planned while this carry plays and the block "
            "is held out (taken by a `rise` of that height); 0: none",
            default=0.0,
            minimum=0.0,
            maximum=MAX_RISE,
        ),
        Param(
            "then",
            dict,
            "the giver's next handover (a loop's next item: its `pick`): with a planner, the `rise` planned "
            "here goes on into the approach of that block, as a `rise` given the same `then` plans it (then "
            "it reads `/blocks`); {}: none",
            default={},
        ),
        Param(
            "ease",
            bool,
            "ease the squeeze to `grip_confirmed_below` under the block's wall (the grip the lift began with) "
            "by the time the arm stops, as `keep_holding`'s `ease` does once it holds the block out",
            default=False,
        ),
        keep_apart=keep_apart_param(0.0),
    ),
    reads=("/board",),
    resources=RESOURCES,
)

declare(
    "go_to_handover",
    "move `arm` (the receiver) to wait, jaw open, straight above its grasp of the block at the meeting point",
    "pegbt.behaviours.actions.handover:GoToHandover",
    params=(
        arm_param(),
        key_param("grasp", "read", "the receiver's grasp at the meeting point"),
        keep_apart_param(0.0),
    ),
    resources=RESOURCES,
)

declare(
    "await_meeting",
    "the receiver `arm`, waiting above its grasp, waits until it may descend: once the giver holds the block "
    "out, or as late in the giver's carry as lets its tip keep above the block's top until the carry ends "
    "(a tree period ahead: `descend_to_grasp` holds still until then)",
    "pegbt.behaviours.actions.handover:AwaitMeeting",
    params=(
        arm_param(),
        key_param("grasp", "read", "the receiver's grasp at the meeting point"),
        handover_number("read"),
        PATIENCE,
    ),
    resources=RESOURCES,
)

declare(
    "descend_to_grasp",
    "move `arm` straight down onto its grasp (the receiver taking the block at the meeting point), held "
    "still until the set-off `await_meeting` waits for while the giver's carry plays",
    "pegbt.behaviours.actions.handover:DescendToGrasp",
    params=(
        arm_param(),
        key_param("grasp", "read", "the grasp to descend onto"),
        key_param(
            "block_pose",
            "read",
            "the block's pose at the meeting point, from which the carry that follows is planned while "
            "the receiver descends and takes the block (unset: planned when it starts)",
        ),
        handover_number("read"),
        keep_apart_param(0.0),
    ),
    reads=("/board",),
    resources=RESOURCES,
)

declare(
    "carry_from_handover",
    "carry the block that `arm` (the receiver) took at the meeting point over peg `place` and lower it onto "
    "the peg; fails at once if the block slips",
    "pegbt.behaviours.actions.handover:CarryFromHandover",
    params=carry_params(
        peg_param("place", "goal peg"),
        key_param("grasp", "read", "the receiver's grasp"),
        key_param("block_pose", "read", "the block's pose at the meeting point (board frame)"),
        let_go_early_param(),
        stop_above_param(),
        keep_apart=keep_apart_param(0.0),
    ),
    reads=("/board",),
    resources=RESOURCES,
)

declare(
    "transfer",
    "lift the held block off its peg, carry it over peg `place` and lower it onto the peg (one trajectory: "
    "SQP-optimised or rest-to-rest cubics, as the condition says); fails at once if the block slips from "
    "the jaw; writes the plan's duration to `plan_s`",
    "pegbt.behaviours.actions.moving:Transfer",
    params=carry_params(
        peg_param("place", "goal peg"),
        key_param("grasp", "read", "the grasp holding the block"),
        key_param("block", "read", "the block held"),
        Param(
            "then",
            dict,
            "the transfer that follows with this arm (a loop's next item: its `pick`), whose approach is "
            "planned while this carry plays, onto the grasp `select_grasp` will choose; {}: none",
            default={},
        ),
        let_go_early_param(),
        stop_above_param(),
    ),
    reads=("/board", "/blocks"),
    resources=RESOURCES,
)

declare(
    "find_held_block",
    "the paper's look at the block `arm` holds at rest over peg `place` (`find_block_servo`): `/cloud`'s "
    "points 30–60 mm above the board within 10 mm of the peg, the block model registered to them, and the "
    "move (arm frame) that puts the block's bottom on the peg's axis written to `servo`; none with fewer "
    "than 400 points or a fit that cannot be the held block's (`pegbt.perception.servo.plausible`)",
    "pegbt.behaviours.actions.placing:FindHeldBlock",
    params=(
        arm_param(),
        peg_param("place", "goal peg"),
        key_param("servo", "write", "the move (arm frame, m) over the peg"),
    ),
    reads=("/cloud", "/board"),
    resources=RESOURCES,
)

declare(
    "find_handed_block",
    "the paper's look at the block the giver holds out at rest (`find_block_servo_handover`): `/cloud`'s points "
    "within 10 mm of the axis of the block planned held out at `block_pose` and from 5 mm above its top to "
    "5 mm below its bottom, less those on both tools, the block model registered to them; the receiver "
    "`arm`'s grasp of the seen block and the seen pose replace `grasp` and `block_pose`; fails with fewer "
    "than 100 points, a fit that cannot be the held block's, or no grasp of it",
    "pegbt.behaviours.actions.handover_look:FindHandedBlock",
    params=(
        arm_param(),
        key_param("giver_grasp", "read", "the giver's grasp of the block (its wall is not the receiver's)"),
        key_param("grasp", "write", "the receiver's grasp of the block as seen"),
        key_param("block_pose", "write", "the block's pose at the meeting point: as planned, then as seen"),
    ),
    reads=("/cloud", "/board"),
    resources=RESOURCES,
)

declare(
    "over_seen_grasp",
    "move `arm` (the receiver), rest to rest and jaw open, to 3 mm over the grasp point of its `grasp` (the "
    "paper's `pick_block` before it descends)",
    "pegbt.behaviours.actions.handover_look:OverSeenGrasp",
    params=(
        arm_param(),
        key_param("grasp", "read", "the receiver's grasp of the block as seen (`find_handed_block`)"),
        keep_apart_param(0.0),
    ),
    resources=RESOURCES,
)

declare(
    "servo_over_peg",
    "move `arm`, at rest over peg `place`, by `servo` and lower the block to the drop height (rest-to-rest, "
    "as the paper's `servoing_block`); fails at once if the block slips, and without moving if `servo` is "
    "longer than a look can ask",
    "pegbt.behaviours.actions.placing:ServoOverPeg",
    params=carry_params(
        peg_param("place", "goal peg"),
        key_param("servo", "read", "the move (arm frame, m) over the peg (`find_held_block`)"),
    ),
    resources=RESOURCES,
)

declare(
    "rise",
    "move `arm` straight up along the pegs' axis by `height` metres (a giver letting go, a tool backing off)",
    "pegbt.behaviours.actions.moving:Rise",
    params=(
        arm_param(),
        Param("height", float, "how far, m", minimum=0.0, maximum=MAX_RISE),
        keep_apart_param(),
        Param(
            "then",
            dict,
            "a giver's next handover (a loop's next item: its `pick`): with a planner the rise goes on into "
            "the approach of that block in one motion (up the held block's axis, then over), which "
            "`approach` takes, and ends as the jaw is out of the block; without one its grasp is chosen "
            "and its approach planned while this rise plays, as `select_grasp` and `approach` will; {}: none "
            "(with `handover_to`, the giver's last handover of its loop: it rises as far again and ends as the "
            "tip passes `height`, `rise_extent`)",
            default={},
        ),
        Param(
            "handover_to",
            str,
            "a giver's way out of the block it handed over: the receiver; with `then`, the arm that next "
            "handover is for (then it reads `/board` and `/blocks`); without `keep_apart`, the tools keep "
            "`handover.min_tool_distance` apart, not `two_arms.keep_apart` (skills/motion.yaml)",
            default="",
        ),
    ),
    resources=RESOURCES,
)

declare(
    "park",
    "move `arm` out of the camera's view: rise to the transfer height if low, then to its home pose (tool down)",
    "pegbt.behaviours.actions.moving:Park",
    params=(arm_param(), keep_apart_param()),
    resources=RESOURCES,
)

declare(
    "capture",
    "request a point cloud from the depth camera and wait for it; writes it to `/cloud`",
    "pegbt.behaviours.actions.sensing:Capture",
    writes=("/cloud",),
    resources=RESOURCES,
)

declare(
    "register_board",
    "register the pegboard model to `/cloud` (refines the camera's extrinsics, finds the pegs); writes `/board` "
    "and sets `/board_registered`",
    "pegbt.behaviours.actions.sensing:RegisterBoard",
    reads=("/cloud",),
    writes=("/board", "/board_registered"),
    resources=RESOURCES,
)

declare(
    "find_blocks",
    "segment and register every block in `/cloud` on the registered `/board`; writes `/blocks`; fails on a "
    "capture in which no block is trustworthy (a noise burst, say), so that `sense` takes another",
    "pegbt.behaviours.actions.sensing:FindBlocks",
    reads=("/cloud", "/board"),
    writes=("/blocks",),
    resources=RESOURCES,
)

declare(
    "begin_transfer",
    "record the start of a transfer from peg `pick` to peg `place` by `arms`; writes its number to `transfer`",
    "pegbt.behaviours.actions.transfer_records:BeginTransfer",
    params=(
        Param("arms", str, "the arm, or giver→receiver for a handover"),
        peg_param("pick", "start peg"),
        peg_param("place", "goal peg"),
        key_param("transfer", "write", "the transfer's number"),
    ),
    resources=("robot", "skills"),
)

declare(
    "finish_transfer",
    "record how transfer `transfer` ended, as the executive believes (placed, skipped or failed); succeeds",
    "pegbt.behaviours.actions.transfer_records:FinishTransfer",
    params=(
        Param("outcome", str, "the verdict", choices=("placed", "skipped", "failed")),
        Param("note", str, "why, for the result table", default=""),
        key_param("transfer", "read", "the transfer's number"),
    ),
    resources=("robot", "skills"),
)

declare(
    "check_blackboard",
    "succeed if blackboard `key` compares true with `value` (`op`), fail otherwise or if it is unset",
    "pegbt.behaviours.conditions.blackboard:check_blackboard",
    params=(
        Param("key", str, "key to test", key="read"),
        Param("op", str, "comparison", default="==", choices=tuple(OPERATORS)),
        Param("value", Any, "value compared with", default=True),
    ),
)

declare(
    "wait_blackboard",
    "run until blackboard `key` compares true with `value` (`op`), then succeed; an unset key is waited for "
    "(another branch of a parallel sets it: how subtrees synchronise); wrap it in `timeout` to bound the wait",
    "pegbt.behaviours.conditions.blackboard:WaitBlackboard",
    params=(
        Param("key", str, "key to watch", key="read"),
        Param("op", str, "comparison", default="==", choices=tuple(OPERATORS)),
        Param("value", Any, "value compared with", default=True),
    ),
)

declare(
    "check_placed",
    "succeed if the latest `/blocks` shows a trustworthy block on every peg in `pegs`",
    "pegbt.behaviours.conditions.blocks:CheckPlaced",
    params=(
        Param(
            "pegs", list[int], "pegs that should each hold a block", choices=tuple(range(N_PEGS)), minimum=1
        ),
    ),
    reads=("/blocks",),
    resources=RESOURCES,
)

declare(
    "keep_holding",
    "run while `arm`'s jaw still holds its block (looking every few ticks' worth of time); fail at once if "
    "the block slipped out: a giver waiting at the meeting point must notice a slip there, or the receiver "
    "closes on nothing and nobody fetches the block",
    "pegbt.behaviours.conditions.blocks:KeepHolding",
    params=(
        arm_param(),
        held_param(),
        Param(
            "ease",
            bool,
            "ease the squeeze to `grip_confirmed_below` under the block's wall as it starts (the grip a lift "
            "carries a block with): a giver holding the block out then lets go from there",
            default=False,
        ),
    ),
    resources=RESOURCES,
)

SAYINGS: dict[str, tuple[Giver | Receiver, str]] = {
    "call_over": (
        Giver.COMING,
        "the giver calls the receiver over for handover `n`: its grasp chosen and the meeting planned, it picks "
        "the block",
    ),
    "offer": (
        Giver.OFFERED,
        "the giver offers handover `n`: picked, the meeting planned; the receiver may come",
    ),
    "hold_out": (Giver.ARRIVED, "the giver says it holds the block out at the meeting point"),
    "withdraw": (Giver.WITHDRAWN, "the giver withdraws its offer: the block slipped, it fetches it again"),
    "hand_over": (Giver.RELEASED, "the giver says it let go of the block the receiver took"),
    "give_up": (Giver.GIVEN_UP, "the giver gives handover `n` up"),
    "ready_for": (Receiver.READY, "the receiver is ready for handover `n` (done with the one before)"),
    "close_on": (Receiver.CLOSING, "the receiver's jaw closes on the block"),
    "back_off": (Receiver.READY, "the receiver backs off: its jaw no longer closes on the block"),
    "take": (Receiver.TAKEN, "the receiver says it holds the block"),
    "refuse": (Receiver.REFUSED, "the receiver gives handover `n` up"),
}
AWAITS: dict[str, tuple[str, str]] = {
    "await_ready": ("ready", "the giver waits until the receiver is ready for handover `n`"),
    "await_taker": ("taken", "the giver waits until the receiver holds the block"),
    "await_closed": ("not closing", "the giver waits until the receiver's jaw is not closing on the block"),
    "await_offer": (
        "offered or given up",
        "the receiver waits until the giver offers the block or gives it up",
    ),
    "await_arrival": (
        "arrived",
        "the receiver waits until the giver holds the block out at the meeting point",
    ),
    "await_release": ("released", "the receiver waits until the giver let go"),
}
CHECKS: dict[str, tuple[str, str]] = {
    "is_taken": ("taken", "whether the receiver holds the block"),
    "receiver_waits": (
        "not refused",
        "whether the receiver still waits for handover `n` (has not refused it)",
    ),
    "not_given_up": ("not given up", "whether the giver still gives handover `n` (has not given it up)"),
    "is_offered": (
        "offered",
        "whether the giver offers the block (coming with it, offered or holding it out)",
    ),
    "is_withdrawn": ("withdrawn", "whether the giver's offer is withdrawn (or was never made, or given up)"),
    "is_held_out": ("arrived", "whether the giver holds the block out at the meeting point"),
}
WATCHES: dict[str, tuple[str, str]] = {
    "unless_refused": (
        "not refused",
        "run while the receiver has not refused handover `n`; fail when it does",
    ),
}
# The leaves that only steer the tree: their failure echoes the other side's, never a cause of its own.
STEERING = frozenset({*CHECKS, *WATCHES})

_SAY = "pegbt.behaviours.actions.handover_protocol:say"
_LOOK = "pegbt.behaviours.conditions.handover_protocol:look"
for _name, (_word, _doc) in SAYINGS.items():
    declare(_name, _doc + "; succeeds", _SAY, params=(handover_number("write"),))
for _name, (_condition, _doc) in AWAITS.items():
    declare(_name, _doc, _LOOK, params=(handover_number("read"), PATIENCE))
for _name, (_condition, _doc) in (CHECKS | WATCHES).items():
    declare(_name, _doc, _LOOK, params=(handover_number("read"),))
