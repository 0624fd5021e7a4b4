"""What the phase simulator says of one transfer: the record its callers (the fit, the trial played in
order, the memo) keep, apart from the simulation that produced it."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class TransferResult:
    """A simulated transfer: placed or not, the phase of its first failure (a placed transfer may have
    recovered from one), its simulated seconds, and whether it was a way back whose block was never
    placed on its start peg (a tick log's `sense`; the paper's robot skipped it). `over_goal`: the arm
    that carried the block last let go of it over its goal peg; a handover's receiver that did not was
    parked by the trees (`receive`'s failure), and the next handover's receiver comes from home."""

    succeeded: bool
    phase: str | None
    seconds: float
    skipped: bool = False
    over_goal: bool = False
