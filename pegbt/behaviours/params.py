"""The parameters many leaves declare alike (an arm, a peg, a blackboard key, a handover's number), and the
bounds they carry. Light on purpose: the declaration table (`pegbt.behaviours.leaves`) builds on them, and
`pegbt tree check` reads that table without importing what the leaves run with.
"""

from __future__ import annotations

from typing import Literal

from pegbt.executive.params import MAX_COUNT, MAX_SECONDS, Param
from pegbt.handover_protocol import key
from pegbt.pegboard import N_PEGS
from pegbt.psm import ARMS
from pegbt.runconditions import COMPENSATED, CONDITIONS

RESOURCES = ("robot", "skills")
MAX_KEEP_APART = 0.1  # m between the tools' axes: farther apart than the two arms' shared workspace allows
HELD_ABOVE = 0.0  # rad: closed is -15°; a block stops a closing jaw at about +12°


def arm_param(doc: str = "which arm", *, blackboard: bool = False) -> Param:
    return Param("arm", str, doc, choices=ARMS, blackboard=blackboard)


def peg_param(name: str, doc: str) -> Param:
    return Param(name, int, doc, choices=tuple(range(N_PEGS)), blackboard=True)


def keep_apart_param(default: float | None = None) -> Param:
    """`keep_apart`, by default skills/motion.yaml's `two_arms.keep_apart` (read when the leaf runs)."""
    from_skills = " (None: two_arms.keep_apart of skills/motion.yaml)" if default is None else ""
    return Param(
        "keep_apart",
        float,
        f"m: an arm motion waits until it keeps the tools this far apart{from_skills}; 0: "
        "no check, for the handover, where the tools meet on purpose",
        default=default,
        minimum=0.0,
        maximum=MAX_KEEP_APART,
    )


def key_param(name: str, access: Literal["read", "write"], doc: str) -> Param:
    """A parameter naming the blackboard key where a leaf reads or writes `name` (default: `name` itself,
    in the leaf's namespace; shared subtrees use per-arm keys such as `/PSM1/grasp`)."""
    return Param(
        name, str, f"key {'read' if access == 'read' else 'written'}: {doc}", default=name, key=access
    )


def held_param() -> Param:
    return Param(
        "held_above",
        float,
        "a closed jaw stopped above this angle (rad) holds a block; one closing past it has lost its block",
        default=HELD_ABOVE,
        minimum=-0.3491,  # the jaw's range, skills/psm.yaml
        maximum=1.3963,
    )


def carry_params(*extra: Param, keep_apart: Param = keep_apart_param()) -> tuple[Param, ...]:
    return (
        arm_param(),
        *extra,
        held_param(),
        key_param("plan_s", "write", "the planned motion's duration, s"),
        keep_apart,
    )


def handover_number(access: Literal["read", "write"]) -> Param:
    """The parameter `n`: the handover's number, naming the one record the leaf reads or writes."""
    return Param(
        "n",
        int,
        "the handover's number in the trial",
        minimum=1,
        maximum=MAX_COUNT,
        key=access,
        names_key=key,
    )


PATIENCE = Param(
    "patience",
    float,
    "seconds to wait before failing (none: until halted)",
    default=None,
    minimum=0.0,
    maximum=MAX_SECONDS,
)


def stop_above_param() -> Param:
    """`stop_above`: the carry stops at rest over its goal peg, for the look before lowering."""
    return Param(
        "stop_above",
        bool,
        "stop at rest over the goal peg instead of lowering (the paper's `place_servoing`: the look at the "
        "held block, `find_held_block` and `servo_over_peg`, lowers it); a tree passes its policy, "
        "`$/policy/look_before_lowering`",
        default=False,
        blackboard=True,
    )


def let_go_early_param() -> Param:
    """`let_go_early`: the conditions under which a carry lets go as the block lands on its goal peg."""
    return Param(
        "let_go_early",
        list[str],
        "the conditions under which the jaw opens as the block comes down onto the peg, reaching "
        "`jaw_release` as the arm stops (their commands put the tip within a millimetre of the plan); "
        "under the others the jaw stays closed until the arm is at rest and `release` opens it",
        default=list(COMPENSATED),
        choices=CONDITIONS,
    )
