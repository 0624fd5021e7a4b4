"""Does `pegbt log why` name the phase and cause the simulator confirms? One answer per failed transfer.

The tick log says which failures the tree did not get over and what caused each (`pegbt.executive.causes
.failure_chains`, what `pegbt log why` prints); the transfer a failure belongs to is the subtree around the
transfer's `begin_transfer` leaf (and, for a handover, the receiver's subtree that finishes the same
transfer key: `pegbt.executive.phases.transfer_scopes`). The first cause of the chains inside a failed
transfer is its stated cause; its phase (`pegbt.executive.phases.failure_phase`: the leaf, and for a carry
the segment of its motion that was playing) is compared with the phase the ground truth gives
(`pegbt.evaluation.truth`: for a block lost from the jaw, whether it was on its start peg, its goal peg or
between), and its step with the truth's step. A transfer the tree thought done whose goal peg the next look
finds empty has no failed leaf: `why` names the phase that look gives it (`transfer_outcomes`: the block
lowered or released above the peg), as its transfer list prints it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pegbt.evaluation.truth import Cause, confirms, failure_cause, final_check_cause, setbacks
from pegbt.executive.causes import FailureStep
from pegbt.executive.logfile import TickLog
from pegbt.executive.phases import TransferCauses, failure_phase, transfer_outcomes, transfer_scopes

# The step, in the ground truth's words, each phase of `pegbt.executive.phases` belongs to.
STEP_OF_PHASE = {
    "sense": "sense",
    "reach": "reach",
    "grasp": "grasp",
    "lift": "carry",
    "carry": "carry",
    "lower": "carry",
    "handover": "handover",
    "release": "place",
}


@dataclass(frozen=True)
class WhyCheck:
    """For one failed transfer (0: the run's own failure): what `why` named (its step and phase), what ended it
    by the simulator, and whether the simulator saw a setback of the named phase just before the named
    failure."""

    transfer: int
    named: str  # "leaf path: feedback", or "" when why named nothing in the transfer
    named_step: str | None
    truth: Cause
    confirmed: bool = False
    named_phase: str | None = None

    @property
    def agrees(self) -> bool:
        """`why` named a phase, and it is the simulator's final cause's or one the simulator saw happen then."""
        return self.named_phase is not None and (self.named_phase == self.truth.phase or self.confirmed)


def check_why(
    log: TickLog, transfers: Sequence[Mapping[str, Any]], entries: Sequence[Mapping[str, Any]]
) -> list[WhyCheck]:
    """Compare, for each failed transfer of `transfers` (as the judge reports them), the first cause `why` names
    inside it with the simulator's log; and, when the run itself failed, the run's first cause (transfer 0)
    with what the simulator says of the pegs its leaf checked (or saw just before, if it checks none)."""
    causes = TransferCauses(log)
    scopes = transfer_scopes(log)
    looked = {o.transfer: o.phase for o in transfer_outcomes(log, causes) if not o.succeeded}
    checks = []
    for transfer in (transfer for transfer in transfers if not transfer["succeeded"]):
        named = causes.first_cause(scopes.get(transfer["index"], []))
        truth = failure_cause(transfer, entries, transfers)
        by_look = looked.get(transfer["index"])
        if named is None and by_look is not None:
            said = f"peg {transfer['place']} seen without the block at the next look: {by_look}"
            checks.append(WhyCheck(transfer["index"], said, STEP_OF_PHASE[by_look], truth, False, by_look))
            continue
        phase = failure_phase(named)
        seen = setbacks(transfer, entries, transfers)
        confirmed = named is not None and phase is not None and confirms(phase, named.t, seen)
        checks.append(
            WhyCheck(transfer["index"], _describe(named), named_step(named), truth, confirmed, phase)
        )
    run = next((chain for chain in causes.chains if chain.handled == "run"), None)
    if run is not None:
        named = run.first_cause
        pegs = (
            next((node["params"].get("pegs") for node in log.nodes if node["path"] == named.path), None) or []
        )
        cause = final_check_cause(pegs, entries, named.t)
        checks.append(WhyCheck(0, _describe(named), named_step(named), cause, False, failure_phase(named)))
    return checks


def named_step(step: FailureStep | None) -> str | None:
    """The step, in the ground truth's words, that a failure stands for: that of its phase."""
    phase = failure_phase(step)
    return None if phase is None else STEP_OF_PHASE[phase]


def _describe(step: FailureStep | None) -> str:
    return f"{step.path}: {step.feedback}" if step else ""
