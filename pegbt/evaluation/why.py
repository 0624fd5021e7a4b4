"""Does `pegbt log why` name the step and cause the simulator confirms? One answer per failed transfer.

The tick log says which failures the tree did not get over and what caused each (`pegbt.executive.causes
.failure_chains`, what `pegbt log why` prints); the transfer a failure belongs to is the subtree around the
transfer's `begin_transfer` leaf (and, for a handover, the receiver's subtree that finishes the same
transfer key). The first cause of the chains inside a failed transfer is its stated cause; its leaf's kind
gives the step, compared with the step the ground truth gives (`pegbt.evaluation.truth`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pegbt.evaluation.truth import Cause, confirms, failure_cause, final_check_cause, setbacks
from pegbt.executive.causes import (
    FailureStep,
    Timeline,
    failure_chains,
    failure_step,
    fallbacks,
    first_cause,
    recoveries,
)
from pegbt.executive.logfile import TickLog

# The step a failing leaf stands for, by behaviour: the words the ground truth's causes use.
STEP_OF_LEAF = {
    "grasp": "grasp",  # the jaw closed on nothing
    "transfer": "carry",  # the block left the jaw while lifted, carried or lowered
    "carry_to_handover": "carry",
    "carry_from_handover": "carry",
    "keep_holding": "carry",  # the giver's block slipped while it held it out
    "go_to_handover": "handover",  # the receiver did not get to the block held out
    "descend_to_grasp": "handover",
    "release": "place",
    "check_placed": "place",  # "sense" when the peg it misses was not empty but unseen (see `named_step`)
    "select_grasp": "sense",  # no usable block seen where one should be
    "capture": "sense",
    "register_board": "sense",
    "find_blocks": "sense",
    "approach": "reach",  # the arm did not get to the block it saw
}


# A failure whose origin is not a robot leaf (a decorator, a logged message) is read by its words, and a timeout
# by what it halted: the wait it gave up on.
STEP_OF_WORDS = (
    ("missed the block", "grasp"),
    ("on nothing", "grasp"),
    ("slipped", "carry"),
    ("no block seen", "sense"),
    ("poor capture", "sense"),
    ("not located", "sense"),
    ("/handover/", "handover"),
)


@dataclass(frozen=True)
class WhyCheck:
    """For one failed transfer (0: the run's own failure): what `why` named, what ended it by the simulator,
    and whether the simulator saw a setback of the named step just before the named failure."""

    transfer: int
    named: str  # "leaf path: feedback", or "" when why named nothing in the transfer
    named_step: str | None
    truth: Cause
    confirmed: bool = False

    @property
    def agrees(self) -> bool:
        """`why` named a step, and it is the simulator's final cause or one the simulator saw happen then."""
        return self.named_step is not None and (self.named_step == self.truth.step or self.confirmed)


def transfer_scopes(log: TickLog) -> dict[int, list[str]]:
    """Per transfer number (as the judge counts them: in the order their `begin_transfer` leaves ran), the
    subtree paths its failures lie under."""
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
        if node["type"] != "finish_transfer" or _inside(
            node["path"], [p for paths in scopes.values() for p in paths]
        ):
            continue
        owners = [index for index, key in key_of.items() if key == node["params"].get("transfer")]
        if len(owners) == 1:  # a handover's receiver finishes the giver's transfer
            scopes[owners[0]].append(parent_path[node["id"]])
    return scopes


def _inside(path: str, scopes: Sequence[str]) -> bool:
    return any(path.startswith(scope + "/") for scope in scopes)


def check_why(
    log: TickLog, transfers: Sequence[Mapping[str, Any]], entries: Sequence[Mapping[str, Any]]
) -> list[WhyCheck]:
    """Compare, for each failed transfer of `transfers` (as the judge reports them), the first cause `why` names
    inside it with the simulator's log; and, when the run itself failed, the run's first cause (transfer 0)
    with what the simulator says of the pegs its leaf checked (or saw just before, if it checks none)."""
    timeline = Timeline(log)
    chains = failure_chains(log, timeline)
    steps = sorted(
        {(step.t, step.path): step for chain in chains for step in chain.steps}.values(),
        key=lambda step: step.t,
    )
    origins = [recovery.origin for recovery in recoveries(timeline)] + [
        found.origin for found in fallbacks(timeline)
    ]
    recovered = [failure_step(timeline, origin) for origin in sorted(origins, key=lambda origin: origin.seq)]
    scopes = transfer_scopes(log)
    checks = []
    for transfer in (transfer for transfer in transfers if not transfer["succeeded"]):
        scope = scopes.get(transfer["index"], [])
        # the failures the tree did not get over; if it got over all (it thought the block placed), those it recovered
        # from or went past by another alternative or attempt
        inside = [step for step in steps if _inside(step.path, scope)] or [
            step for step in recovered if _inside(step.path, scope)
        ]
        named = first_cause(inside) if inside else None
        step = named_step(named)
        seen = setbacks(transfer, entries, transfers)
        confirmed = named is not None and step is not None and confirms(step, named.t, seen)
        checks.append(
            WhyCheck(
                transfer["index"],
                _describe(named),
                step,
                failure_cause(transfer, entries, transfers),
                confirmed,
            )
        )
    run = next((chain for chain in chains if chain.handled == "run"), None)
    if run is not None:
        named = run.first_cause
        pegs = (
            next((node["params"].get("pegs") for node in log.nodes if node["path"] == named.path), None) or []
        )
        checks.append(
            WhyCheck(0, _describe(named), named_step(named), final_check_cause(pegs, entries, named.t))
        )
    return checks


def named_step(step: FailureStep | None) -> str | None:
    """The step, in the ground truth's words, that a failure stands for: by its leaf, else by what it said."""
    if step is None:
        return None
    if step.type == "check_placed" and "(empty)" not in step.feedback:
        return "sense"  # every peg it checked had a block it could not see reliably
    said = " ".join((step.feedback, *step.halted))
    return STEP_OF_LEAF.get(step.type) or next((s for words, s in STEP_OF_WORDS if words in said), None)


def _describe(step: FailureStep | None) -> str:
    return f"{step.path}: {step.feedback}" if step else ""
