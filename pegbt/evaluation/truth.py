"""What the simulator's ground truth says about a trial: why each failed transfer failed, and which
injected faults the trial recovered from.

Failures are named by the step where the block was lost, in the same words the executive's leaves
use, so the two can be compared (`pegbt.evaluation.why`):

- `grasp`: a closing jaw gripped nothing (`grasp_miss`, geometric or injected);
- `carry`: the block left a closed jaw between grasp and release (a slip, a peg that caught or struck it);
- `place`: the block was released but did not come to rest on the goal peg;
- `handover`: the block never passed from the giver to the receiver (the receiver never gripped it from
  the giver, or the giver let go of it while nobody else held it);
- `sense`: the block was not there to be seen (an empty pick peg, one holding two blocks, a noise burst,
  a block lost off the workspace);
- `reach`: no arm went for the block, which sat alone on its pick peg (no camera fault in the way).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from pegbt.workcell import workcell

GRACE = 0.5  # s after a transfer's end in which its events still count (the block settles), as the judge's
CONFIRM_WINDOW = 5.0  # s before a leaf's failure in which the simulator's event must lie to confirm it
STEPS = (
    "grasp",
    "carry",
    "place",
    "handover",
    "sense",
    "reach",
    "none",
)  # a cause's step; none: nothing seen going wrong
INJECTED = (
    "grasp miss injected",
    "slip injected",
    "depth noise burst",
)  # world and camera faults, by detail prefix

Entry = Mapping[str, Any]
Transfer = Mapping[str, Any]


# The phase (`pegbt.executive.phases`) a step stands for; a carry's is where its block was (`_carry_phase`).
PHASE_OF_STEP = {
    "grasp": "grasp",
    "carry": "carry",
    "place": "release",
    "handover": "handover",
    "sense": "sense",
    "reach": "reach",
    "none": "",
}


@dataclass(frozen=True)
class Cause:
    """Why a transfer failed, by the simulator: the step and the event that ended it, and its phase ("" for
    none: by the step, or for a carry where the block was: on its start peg, its goal peg, or between)."""

    step: str  # grasp, carry, place, handover, sense, reach (none: the simulator saw nothing go wrong)
    event: str  # the deciding event, e.g. "collision: block-peg: caught on peg 1: hole 2.1 mm off its axis"
    time: float | None = None  # when it happened; None for a state (a peg that was empty)
    phase: str = ""

    def __post_init__(self) -> None:
        if not self.phase:
            object.__setattr__(self, "phase", PHASE_OF_STEP.get(self.step, ""))


@dataclass(frozen=True)
class InjectedFault:
    """A fault the simulator injected, the transfer it hit (None: between transfers) and whether the trial
    got over it (that transfer succeeded; between transfers, the next one did)."""

    time: float
    kind: str  # grasp miss, slip, depth noise burst
    transfer: int | None
    recovered: bool


def _window(transfer: Transfer, grace: float = GRACE) -> tuple[float, float]:
    """From a transfer's start to its end (plus the settling grace); to the trial's end if it never ended."""
    ended = transfer.get("ended")
    return transfer["started"], math.inf if ended is None else ended + grace


def _arms(transfer: Transfer) -> set[str]:
    return set(str(transfer["arms"]).replace("→", "+").split("+"))


def _roles(transfer: Transfer) -> tuple[str, str | None]:
    """(giver, receiver) of a handover ("PSM2→PSM1"); (the arms, None) for a transfer by one arm or two."""
    giver, _, receiver = str(transfer["arms"]).partition("→")
    return giver, receiver or None


def _involves(entry: Entry, arms: set[str]) -> bool:
    return bool(entry.get("arm")) and bool(set(str(entry["arm"]).split("+")) & arms)


def transfer_blocks(transfer: Transfer, entries: Sequence[Entry]) -> set[int]:
    """The block a transfer worked on (empty if none): the first its arms gripped, or tried to grip, on its
    pick peg in its window. Recoveries fetch that same block from wherever it fell."""
    start, stop = _window(transfer)
    arms = _arms(transfer)
    return next(
        (
            {e["block"]}
            for e in entries
            if e["kind"] in ("grasp", "grasp_miss")
            and e.get("peg") == transfer["pick"]
            and start <= e["time"] <= stop
            and _involves(e, arms)
        ),
        set(),
    )


def setbacks(transfer: Transfer, entries: Sequence[Entry], others: Sequence[Transfer] = ()) -> list[Cause]:
    """Everything the simulator saw go wrong for a transfer, in order: what befell its block (grasp misses,
    slips, knocks, a missed placement, a handover the giver let go of); its arms' grasps that gripped nothing
    near another block that no other transfer (of `others`) running then worked on (a receiver closing where
    no block is held out); for a handover, a receiver that never gripped the block from the giver; for a
    transfer that never touched a block on its pick peg, as `sense`, a pick peg empty or holding two blocks
    when it began, else (`reach`) that no arm went for the block on it; as `sense`, noise bursts while it ran
    and a block lost off the workspace."""
    start, stop = _window(transfer)
    blocks = transfer_blocks(transfer, entries)
    arms = _arms(transfer)
    during = [e for e in entries if start <= e["time"] <= stop and e["kind"] != "fault"]
    found = _adverse([e for e in during if e.get("block") in blocks], transfer)
    found += [
        Cause("grasp", _describe(e), e["time"])
        for e in during
        if e["kind"] == "grasp_miss"
        and _involves(e, arms)
        and e.get("block") not in blocks
        and not _claimed(e, others, entries)
    ]
    found += _not_handed_over(transfer, blocks, during)
    if not blocks:
        found += _pick_peg(transfer, entries, during)
    found += [
        Cause("sense", _describe(e), e["time"])
        for e in entries
        if start <= e["time"] <= stop
        and e["kind"] == "fault"
        and str(e.get("detail", "")).startswith("depth noise burst")
    ]
    found += [
        Cause("sense", _describe(e), e["time"])
        for e in entries
        if e["kind"] == "drop"
        and e["time"] <= stop
        and e.get("block") in blocks
        and "off the workspace" in str(e.get("detail", ""))
    ]
    return found


def _claimed(miss: Entry, others: Sequence[Transfer], entries: Sequence[Entry]) -> bool:
    """Whether another transfer running at the moment of `miss` worked on the block it missed."""
    return any(
        _window(other)[0] <= miss["time"] <= _window(other)[1]
        and miss.get("block") in transfer_blocks(other, entries)
        for other in others
    )


def _not_handed_over(transfer: Transfer, blocks: set[int], during: Sequence[Entry]) -> list[Cause]:
    """A handover whose giver gripped the block and whose receiver never gripped it from the giver (a state)."""
    giver, receiver = _roles(transfer)
    if receiver is None or not blocks:
        return []
    block = next(iter(blocks))
    taken = any(
        e["kind"] == "grasp"
        and e.get("block") == block
        and e.get("arm") == receiver
        and f"handover from {giver}" in str(e.get("detail", ""))
        for e in during
    )
    return [] if taken else [Cause("handover", f"{receiver} never gripped block {block} from {giver}")]


def _pick_peg(transfer: Transfer, entries: Sequence[Entry], during: Sequence[Entry]) -> list[Cause]:
    """For a transfer that never touched a block on its pick peg: what the peg held when it began."""
    peg = transfer["pick"]
    held = blocks_on_pegs(entries, transfer["started"]).get(peg, [])
    if not held:
        return [Cause("sense", f"no block was on peg {peg} when the transfer began")]
    if len(held) > 1:
        return [
            Cause(
                "sense",
                f"peg {peg} held blocks {' and '.join(map(str, sorted(held)))} when the transfer began",
            )
        ]
    if any(e.get("block") == held[0] for e in during):
        return []  # another arm moved it
    return [Cause("reach", f"no arm went for block {held[0]}, alone on peg {peg} while the transfer ran")]


def failure_cause(transfer: Transfer, entries: Sequence[Entry], others: Sequence[Transfer] = ()) -> Cause:
    """What ended a failed transfer: the last thing that befell its block; else, for a handover whose giver
    gripped it, that the receiver never did (perception had found it); else what kept the arms from it (the
    pick peg, a noise burst), else the last setback; `none` if the simulator saw nothing go wrong."""
    blocks = transfer_blocks(transfer, entries)
    start, stop = _window(transfer)
    own = _adverse(
        [
            e
            for e in entries
            if start <= e["time"] <= stop and e["kind"] != "fault" and e.get("block") in blocks
        ],
        transfer,
    )
    if own:
        return own[-1]
    others_seen = setbacks(transfer, entries, others)
    for step in ("handover", "sense"):
        found = [cause for cause in others_seen if cause.step == step]
        if found:
            return found[0] if found[0].time is None else found[-1]
    return (
        others_seen[-1] if others_seen else Cause("none", "the simulator saw nothing set this transfer back")
    )


def confirms(phase: str, time: float, causes: Sequence[Cause]) -> bool:
    """Whether the simulator saw a setback of `phase` shortly before `time` (or throughout, for a state)."""
    return any(
        cause.phase == phase and (cause.time is None or time - CONFIRM_WINDOW <= cause.time <= time + GRACE)
        for cause in causes
    )


def final_check_cause(pegs: Sequence[int], entries: Sequence[Entry], time: float) -> Cause:
    """Why the run failed at `time` at a leaf that checked that every peg of `pegs` holds a block: a peg was
    empty (`place`), or each held a block and the capture misled (`sense`, with the noise burst if there was
    one). At a leaf that checks no pegs (a look before any transfer, a motion the executive refused): `sense`
    if a noise burst came just before, else `none` (the simulator saw nothing go wrong)."""
    bursts = [
        e
        for e in entries
        if e["kind"] == "fault"
        and str(e.get("detail", "")).startswith("depth noise burst")
        and e["time"] <= time
    ]
    if not pegs:
        recent = [e for e in bursts if e["time"] >= time - CONFIRM_WINDOW]
        return (
            Cause("sense", _describe(recent[-1]), recent[-1]["time"])
            if recent
            else Cause("none", f"the simulator saw nothing go wrong before t={time:.2f} s")
        )
    occupied = blocks_on_pegs(entries, time)
    empty = [peg for peg in pegs if not occupied.get(peg)]
    if empty:
        return Cause("place", f"no block on peg {', '.join(map(str, empty))} at t={time:.2f} s")
    return Cause(
        "sense",
        _describe(bursts[-1]) if bursts else f"a block on each of pegs {', '.join(map(str, pegs))}",
        bursts[-1]["time"] if bursts else None,
    )


def blocks_on_pegs(entries: Sequence[Entry], until: float) -> dict[int, list[int]]:
    """Which blocks rest on (or are threaded on) each peg at time `until`, replaying the events from the
    world's start (block i on the i-th peg of the left group)."""
    where: dict[int, int | None] = dict(enumerate(workcell().pegs.left_group))
    for entry in entries:
        if entry["time"] > until or entry.get("block") is None:
            continue
        if entry["kind"] == "lift":
            where[entry["block"]] = None
        elif entry["kind"] in ("place", "drop"):
            where[entry["block"]] = entry.get("peg")
    pegs: dict[int, list[int]] = {}
    for block, peg in where.items():
        if peg is not None:
            pegs.setdefault(peg, []).append(block)
    return pegs


def _adverse(events: Sequence[Entry], transfer: Transfer) -> list[Cause]:
    """The events that set a transfer back, each with its step. A drop is the consequence of what came just
    before it on its block: a release (the placement missed) or a slip or knock (already counted). In a
    handover, a block the giver let go of that fell had never passed to the receiver (`handover`), unless the
    receiver had gripped it and lost it (already counted) or the giver set it back on its start peg."""
    giver, receiver = _roles(transfer)
    causes: list[Cause] = []
    previous: dict[object, tuple[str, object]] = {}  # per block: the kind and arm of its last event
    taken: set[object] = set()
    for entry in events:
        kind, detail, block = entry["kind"], str(entry.get("detail", "")), entry.get("block")
        step, phase = None, ""
        if (
            kind == "grasp"
            and receiver is not None
            and entry.get("arm") == receiver
            and f"handover from {giver}" in detail
        ):
            taken.add(block)
        elif kind == "grasp_miss":
            step = "grasp"
        elif kind == "slip" or kind == "collision" and detail.startswith("block-peg"):
            step = "carry"
            phase = _carry_phase(entry, transfer)
        elif kind in ("drop", "place") and receiver is not None and previous.get(block) == ("release", giver):
            step = None if block in taken or _set_back(entry, transfer) else "handover"
        elif kind == "drop" and previous.get(block, ("",))[0] == "release":
            step = "place"
        elif kind == "place" and entry.get("peg") != transfer["place"]:
            step = "place"
        if step is not None:
            causes.append(Cause(step, _describe(entry), entry["time"], phase))
        previous[block] = (kind, entry.get("arm"))
    return causes


def _set_back(entry: Entry, transfer: Transfer) -> bool:
    """Whether the giver's block came to rest on the handover's start peg: set back there to be picked again
    (`trees/shared/set_back.yaml`), no handover lost."""
    return entry["kind"] == "place" and entry.get("peg") == transfer["pick"]


def _carry_phase(entry: Entry, transfer: Transfer) -> str:
    """Where a block left its jaw: on (or striking) the transfer's start peg (`lift`) or goal peg (`lower`),
    else between them (`carry`). A slip or a catch names the peg the block was threaded on, a strike the
    peg it struck."""
    peg = entry.get("peg")
    return "lift" if peg == transfer["pick"] else "lower" if peg == transfer["place"] else "carry"


def _describe(entry: Entry) -> str:
    detail = entry.get("detail") or (
        f"on peg {entry['peg']}" if entry.get("peg") is not None and entry["kind"] == "place" else ""
    )
    return f"{entry['kind']}: {detail}" if detail else str(entry["kind"])


def injected_faults(
    transfers: Sequence[Transfer], entries: Sequence[Entry], tree_ok: bool
) -> list[InjectedFault]:
    """Every world or camera fault the simulator injected with an effect, with the transfer it hit and whether
    it was got over (`tree_ok`: the tree succeeded, for a fault after the last transfer)."""
    faults = []
    for entry in entries:
        detail = str(entry.get("detail", ""))
        if entry["kind"] != "fault" or not detail.startswith(INJECTED):
            continue
        kind = next(prefix for prefix in INJECTED if detail.startswith(prefix)).replace(" injected", "")
        hit = _hit_transfer(entry, transfers, entries)
        if hit is not None:
            faults.append(InjectedFault(entry["time"], kind, hit["index"], bool(hit["succeeded"])))
            continue
        # between transfers (a capture while looking): the next transfer shows whether it was got over
        following = min(
            (t for t in transfers if t["started"] >= entry["time"]), key=lambda t: t["started"], default=None
        )
        faults.append(
            InjectedFault(
                entry["time"], kind, None, tree_ok if following is None else bool(following["succeeded"])
            )
        )
    return faults


def _hit_transfer(fault: Entry, transfers: Sequence[Transfer], entries: Sequence[Entry]) -> Transfer | None:
    """The transfer a fault hit: the one working on its block then (a slip, a miss), else the latest one running
    at that moment on the same arm (or, for a camera burst, any arm). The settling grace is for blocks: a
    capture just after a transfer ended is the next look's, not that transfer's."""
    grace = GRACE if fault.get("block") is not None else 0.0
    running = [t for t in transfers if _window(t, grace)[0] <= fault["time"] <= _window(t, grace)[1]]
    if fault.get("block") is not None:
        for transfer in running:
            if fault["block"] in transfer_blocks(transfer, entries):
                return transfer
    if fault.get("arm"):
        running = [t for t in running if _involves(fault, _arms(t))]
    return max(running, key=lambda t: t["started"], default=None)


def count_safety(entries: Sequence[Entry]) -> tuple[int, int]:
    """Commands the simulator clipped to the dVRK's limits (`safety` entries of event `clip`) and times an
    arm entered FAULT (`arm_state` entries, written when an arm's state changes), in its log."""
    clipped = sum(entry["kind"] == "safety" and entry.get("event") == "clip" for entry in entries)
    faults = 0
    state: dict[str, str] = {}
    for entry in entries:
        if entry["kind"] == "arm_state":
            faults += entry["state"] == "FAULT" and state.get(entry["arm"]) != "FAULT"
            state[entry["arm"]] = entry["state"]
    return clipped, faults
