"""Where each transfer of a run failed, from its tick log alone: the phase of its first cause, in the robot's
own terms (the leaf that failed, the segment of its motion that was playing, the jaw, the perception
that followed), never from a simulator's truth, so a real robot's logs are read as a simulator's are.

Phases (`PHASES`): `sense` (the block was not seen where it should be), `reach` (the arm did not get to it),
`grasp` (the jaw closed on nothing), `lift` (lost while lifted off its start peg), `carry` (lost on the way),
`handover` (it did not pass from one arm to the other), `lower` (lost while lowered onto its goal peg),
`release` (let go over its goal peg, and not on it when next seen).

A transfer is the subtree around its `begin_transfer` leaf, numbered in the order those leaves ran (as a
judge counts them; a handover's receiver finishes the giver's transfer from a subtree of its own). It
succeeded when the executive recorded it placed (`finish_transfer`), the last look before it began (since
a transfer picking from its goal peg ended) did not see a block on that peg already (then a block seen
there later is that one, and the carried block, lowered onto a taken peg, ended beside it), and the next
look at its goal peg did not find it empty (a later pick from that peg that saw no block, or the final
check naming it empty). A failed transfer's phase is that of the first cause of the failures inside it the
tree did not get over (else of those it got over); one recorded placed and then found missing failed at
`lower` if its jaw was empty when the lowering ended, else at `release`; one placed on a goal peg seen
taken failed at its first cause's phase (a way back that found its pick peg empty: `sense`), else at
`release`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import Any, NamedTuple

from pegbt.executive.causes import (
    FailureStep,
    Timeline,
    failure_chains,
    failure_step,
    fallbacks,
    first_cause,
    recoveries,
)
from pegbt.executive.logfile import TickLog, Transition

PHASES = ("sense", "reach", "grasp", "lift", "carry", "handover", "lower", "release")
CARRY_LEAVES = (
    "transfer",
    "carry_to_handover",
    "carry_from_handover",
    "servo_over_peg",
)  # their detail names the segment
PHASE_OF_LEAF = {
    "grasp": "grasp",  # the jaw closed on nothing (a giver's pick, or a receiver's take at the handover)
    "transfer": "carry",  # refined by the segment its detail names: lift, carry, lower
    "carry_to_handover": "carry",
    "carry_from_handover": "carry",
    "servo_over_peg": "carry",  # refined as a carry's: the move over the peg is its carry, then lower
    "find_held_block": "sense",
    "keep_holding": "handover",  # the giver's block slipped while it held it out
    "go_to_handover": "handover",  # the receiver did not get to the block held out
    "descend_to_grasp": "handover",
    "find_handed_block": "handover",  # the look at the block held out found no block or no grasp of it
    "over_seen_grasp": "handover",
    "release": "release",
    "check_placed": "release",  # "sense" when the peg it misses was not empty but unseen
    "select_grasp": "sense",  # no usable block seen where one should be
    "capture": "sense",
    "register_board": "sense",
    "find_blocks": "sense",
    "approach": "reach",
}
# A failure whose origin is not a robot leaf (a decorator, a logged message) is read by its words, and a
# timeout by what it halted: the wait it gave up on.
PHASE_OF_WORDS = (
    ("missed the block", "grasp"),
    ("on nothing", "grasp"),
    ("slipped", "carry"),
    ("no block seen", "sense"),
    ("poor capture", "sense"),
    ("not located", "sense"),
    ("/handover/", "handover"),
)
_EMPTY_PEG = re.compile(r"peg (\d+) \(empty\)")
_NONE_SEEN = re.compile(r"no block seen on peg (\d+)")
_SEEN_ON = re.compile(r"trustworthy on pegs: ([^;]*)")  # `find_blocks`' feedback: a peg or "board" per block


class TransferOutcome(NamedTuple):
    """One transfer as its tick log tells it: its number, whether it succeeded, and if not, its phase
    (None: nothing in the log names one, e.g. the run stopped during it)."""

    transfer: int
    succeeded: bool
    phase: str | None


def failure_phase(step: FailureStep | None) -> str | None:
    """The phase a failure stands for: by its leaf (a carry's by the segment it was playing), else by what
    it said."""
    if step is None:
        return None
    if step.type == "check_placed" and "(empty)" not in step.feedback:
        return "sense"  # every peg it checked had a block it could not see reliably
    if step.type in CARRY_LEAVES and step.detail and step.detail.get("segment") in PHASES:
        return str(step.detail["segment"])
    said = " ".join((step.feedback, *step.halted))
    return PHASE_OF_LEAF.get(step.type) or next((p for words, p in PHASE_OF_WORDS if words in said), None)


def transfer_scopes(log: TickLog) -> dict[int, list[str]]:
    """Per transfer number (in the order their `begin_transfer` leaves ran), the subtree paths its failures
    lie under."""
    nodes = log.nodes
    parent_path = {node["id"]: nodes[node["parent"]]["path"] for node in nodes if node["parent"] is not None}
    begins = [node["id"] for node in nodes if node["type"] == "begin_transfer"]
    started = sorted(
        (change.seq, change.node)
        for change in log.transitions
        if change.node in begins and change.after == "SUCCESS"
    )
    scopes = {index: [parent_path[node]] for index, (_, node) in enumerate(started, 1)}
    key_of = {index: nodes[node]["params"].get("transfer") for index, (_, node) in enumerate(started, 1)}
    for node in nodes:
        if node["type"] != "finish_transfer" or inside(
            node["path"], [p for paths in scopes.values() for p in paths]
        ):
            continue
        owners = [index for index, key in key_of.items() if key == node["params"].get("transfer")]
        if len(owners) == 1:  # a handover's receiver finishes the giver's transfer
            scopes[owners[0]].append(parent_path[node["id"]])
    return scopes


def inside(path: str, scopes: Sequence[str]) -> bool:
    return any(path.startswith(scope + "/") for scope in scopes)


class TransferCauses:
    """The failures of a run as each transfer's first cause needs them: those the tree did not get over, and
    those it recovered from or went past by another alternative or attempt."""

    def __init__(self, log: TickLog, timeline: Timeline | None = None) -> None:
        self.log = log
        self.timeline = timeline or Timeline(log)
        self.chains = failure_chains(log, self.timeline)
        self.steps = sorted(
            {(step.t, step.path): step for chain in self.chains for step in chain.steps}.values(),
            key=lambda step: step.t,
        )
        origins = [recovery.origin for recovery in recoveries(self.timeline)] + [
            found.origin for found in fallbacks(self.timeline)
        ]
        self.recovered = [
            failure_step(self.timeline, origin) for origin in sorted(origins, key=lambda origin: origin.seq)
        ]

    def first_cause(self, scope: Sequence[str]) -> FailureStep | None:
        """The first cause inside `scope`: of the failures the tree did not get over; if it got over all (it
        thought the block placed), of those it recovered from or went past."""
        found = [step for step in self.steps if inside(step.path, scope)] or [
            step for step in self.recovered if inside(step.path, scope)
        ]
        return first_cause(found) if found else None


def _beginnings(log: TickLog) -> list[Transition]:
    """The success of each transfer's `begin_transfer` leaf, in the order they began (transfer 1 first)."""
    return [
        change
        for change in log.transitions
        if change.after == "SUCCESS" and log.nodes[change.node]["type"] == "begin_transfer"
    ]


def begun_transfers(log: TickLog) -> list[dict[str, Any]]:
    """The `begin_transfer` node of each transfer the run began, in the order they began (transfer 1 first)."""
    return [log.nodes[change.node] for change in _beginnings(log)]


def transfer_outcomes(log: TickLog, causes: TransferCauses | None = None) -> list[TransferOutcome]:
    """Each transfer the run began, whether it succeeded and, if not, the phase it failed in (see the module
    docstring), from the tick log alone; `causes`: the log's, where the caller has them already."""
    causes = causes or TransferCauses(log)
    scopes = transfer_scopes(log)
    nodes = log.nodes
    began = [change.seq for change in _beginnings(log)]
    begun = begun_transfers(log)
    finished = [
        [
            change
            for change in log.transitions
            if change.after == "SUCCESS"
            and nodes[change.node]["type"] == "finish_transfer"
            and inside(nodes[change.node]["path"], scopes[index])
        ]
        for index in range(1, len(begun) + 1)
    ]
    outcomes = []
    for index, begin in enumerate(begun, 1):
        scope, finishes = scopes[index], finished[index - 1]
        place = begin["params"].get("place")
        emptied = max(  # when the last transfer to pick from this goal peg before this one ended
            (
                ends[-1].seq if ends else math.inf
                for other, ends in zip(begun[: index - 1], finished[: index - 1], strict=True)
                if other["params"].get("pick") == place
            ),
            default=-1,
        )
        verdict = nodes[finishes[-1].node]["params"].get("outcome") if finishes else None
        if verdict != "placed":
            outcomes.append(TransferOutcome(index, False, failure_phase(causes.first_cause(scope))))
            continue
        if _seen_occupied(log, place, began[index - 1], emptied):
            outcomes.append(
                TransferOutcome(index, False, failure_phase(causes.first_cause(scope)) or "release")
            )
            continue
        if not _found_empty(log, place, finishes[-1].seq):
            outcomes.append(TransferOutcome(index, True, None))
            continue
        lowered = [
            change
            for change in log.transitions
            if change.seq < finishes[-1].seq
            and change.after == "SUCCESS"
            and nodes[change.node]["type"] in CARRY_LEAVES
            and inside(nodes[change.node]["path"], scope)
        ]
        empty = bool(lowered) and (lowered[-1].detail or {}).get("held") is False
        outcomes.append(TransferOutcome(index, False, "lower" if empty else "release"))
    return outcomes


def retried(log: TickLog) -> set[int]:
    """The transfers (numbered as `transfer_outcomes` numbers them) inside which a recover node ran its
    recovery or a retry took the block again (`retakes`): tried again after a miss, a slip or a lost
    block, which the paper's robot never did."""
    timeline = Timeline(log)
    paths = [log.nodes[recovery.node]["path"] for recovery in recoveries(timeline)] + retakes(timeline)
    return {index for index, scope in transfer_scopes(log).items() if any(inside(p, scope) for p in paths)}


def retakes(timeline: Timeline) -> list[str]:
    """The paths of the retry nodes that ran their child again after it failed other than at `sense` (a
    handover's receiver that missed the block, or backed off from an offer withdrawn, tries to take it
    again: `receive`'s `tries`); a retry of a look that saw nothing usable (`sense`'s captures taken
    again) is no try again at the block."""
    log, end = timeline.log, len(timeline.log.transitions)
    found = []
    for node in log.nodes:
        if node["type"] != "retry":
            continue
        (child,) = timeline.children[node["id"]]
        for failure in (change for change in timeline.by_node[child] if change.after == "FAILURE"):
            again = timeline.first_after(child, failure.seq)
            finish = timeline.next_finish(node["id"], failure.seq, end)
            if again is None or finish is not None and finish.seq < again.seq:
                continue  # the last attempt, or the retry was halted: not tried again
            if failure_phase(failure_step(timeline, timeline.first_origin(failure))) != "sense":
                found.append(node["path"])
                break
    return found


def _seen_occupied(log: TickLog, peg: object, began: int, emptied: float) -> bool:
    """Whether the last look at the board between seqs `emptied` (when a transfer picking from `peg` last
    ended) and `began` saw a block on `peg`: the goal peg already held one, so a block seen there later is
    no sign that this transfer's went down on it (a block lowered onto a taken peg ends beside it)."""
    for change in reversed(log.transitions):
        if change.seq >= began:
            continue
        if change.seq <= emptied:
            return False
        if log.nodes[change.node]["type"] == "find_blocks" and change.after == "SUCCESS":
            seen = _SEEN_ON.search(change.feedback)
            return seen is not None and str(peg) in seen.group(1).split(", ")
    return False


def _found_empty(log: TickLog, peg: object, after: int) -> bool:
    """Whether the next look at `peg` after seq `after` found it empty: a pick from it that saw no block, or
    a check naming it empty, before any other transfer began to place a block on it."""
    nodes = log.nodes
    for change in log.transitions:
        if change.seq <= after:
            continue
        node = nodes[change.node]
        if (
            node["type"] == "begin_transfer"
            and change.after == "SUCCESS"
            and node["params"].get("place") == peg
        ):
            return False
        if (
            node["type"] == "select_grasp"
            and node["params"].get("peg") == peg
            and change.after in ("SUCCESS", "FAILURE")
        ):
            seen = _NONE_SEEN.search(change.feedback) if change.after == "FAILURE" else None
            return seen is not None and int(seen.group(1)) == peg
        if node["type"] == "check_placed" and change.after in ("SUCCESS", "FAILURE"):
            pegs = node["params"].get("pegs")
            if isinstance(pegs, list) and peg in pegs:
                return change.after == "FAILURE" and str(peg) in _EMPTY_PEG.findall(change.feedback)
    return False
