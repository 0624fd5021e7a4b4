"""The task variants and run conditions of the reference paper's experiments, as every part names them (the
skills that run them, the leaves whose defaults depend on them, the evaluation's tables, sim2real's outcome
cells): a cell of the paper's Tables II-IV is a variant under a condition.

- `uncalibrated`: rest-to-rest cubic motions, commands sent as planned;
- `calibrated`: the same motions, every commanded row pre-compensated by the arm's calibration model;
- `optimized`: transfers planned as the paper's spline refined by SQP, pre-compensated.

And the protocols a trial runs by (`--protocol`): `pegbt`, the trees' own (recovery, pegbt's heights); `paper`,
the reference paper's (one attempt per block, the arms registered to the camera as the paper's were, and,
planned as rest-to-rest cubics, the carry stopped at the paper's height over the goal peg, where the held
block is looked at before it is lowered, and in a handover the block held out looked at before the receiver
takes it: `protocol_policies`).
"""

from __future__ import annotations

from pegbt.errors import PegbtError

VARIANTS = ("unilateral", "bilateral", "handover")  # one tree each: trees/VARIANT.yaml
LONE_VARIANTS = ("unilateral",)  # one arm works; the other stays parked, over none of the pegs
CONDITIONS = ("uncalibrated", "calibrated", "optimized")
COMPENSATED = ("calibrated", "optimized")  # their commands correct the cables' error at the tip
OPTIMIZED = ("optimized",)  # their transfers are planned by the optimiser
PROTOCOLS = ("pegbt", "paper")
LOOK_POLICY = "/policy/look_before_lowering"  # `trees/shared/place.yaml`: look at the held block, then lower
# `trees/shared/handover.yaml`: look at the block held out, then take it where it is seen
HANDOVER_LOOK_POLICY = "/policy/look_at_handover"
RECOVER_POLICY = "/policy/recover_lost_blocks"  # `trees/shared/recover.yaml`: pick a lost block again


def known_condition(condition: object) -> str:
    """`condition` if it names a run condition, else a `PegbtError` on `--condition`."""
    if condition not in CONDITIONS:
        raise PegbtError(
            f"unknown condition {condition!r}; known: {', '.join(CONDITIONS)}", field="--condition"
        )
    return str(condition)


def protocol_policies(protocol: str, condition: str | None, variant: str) -> dict[str, bool]:
    """The blackboard policies `protocol` sets for a run of `variant` under `condition`: under the paper's,
    no recovery (`FLSPegTransfer_single.py`, BerkeleyAutomation/FLSpegtransferHO, moves each block once)
    and, where the transfer is rest-to-rest cubics (its `use_optimization = False`), the look before
    lowering and, in a handover, the look at the block held out before the receiver takes it
    (`FLSPegTransfer_handover.py`); none under pegbt's, whose trees declare their own."""
    if protocol != "paper":
        return {}
    cubic = condition not in OPTIMIZED
    looks_at_handover = {HANDOVER_LOOK_POLICY: cubic} if variant == "handover" else {}
    return {RECOVER_POLICY: False, LOOK_POLICY: cubic} | looks_at_handover


def known_protocol(protocol: object) -> str:
    """`protocol` if it names a protocol, else a `PegbtError` on `--protocol`."""
    if protocol not in PROTOCOLS:
        raise PegbtError(f"unknown protocol {protocol!r}; known: {', '.join(PROTOCOLS)}", field="--protocol")
    return str(protocol)
