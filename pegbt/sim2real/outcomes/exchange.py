"""A handover's exchange: the receiver comes to the meeting point, takes the block the giver holds out
(again after a miss, where the trees recover), carries it to the goal peg and places it, or fetches it
from the board; and the seconds such a transfer takes in a trial, where the two arms' lists overlap.

The exchange is the handover's own part of a transfer (`trees/shared/handover.yaml`'s `give` and
`receive`); the giver's pick and carry before it are an attempt's (`attempt`), the recoveries around both
`trying`'s, which hands the exchange the `Giving` it needs.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from pegbt.behaviours.actions.handover_look import over_grasp
from pegbt.behaviours.motion import above_pegs_first
from pegbt.behaviours.paper_meeting import receiver_grasp
from pegbt.behaviours.poses import from_handover
from pegbt.behaviours.resources.skills import Skills
from pegbt.errors import PegbtError
from pegbt.motion.ik import inverse_kinematics
from pegbt.motion.placing import segment_times
from pegbt.motion.trajectory import Trajectory
from pegbt.perception.grasp import Grasp
from pegbt.sim.world import World
from pegbt.sim2real.outcomes.attempt import (
    failed_phase,
    look_sd,
    looks_before_lowering,
    paper_place,
    planned_park,
    previous_release,
    seen_point,
)
from pegbt.sim2real.outcomes.bench import START, Bench, Replay
from pegbt.sim2real.outcomes.paperhandover import GIVER_RISE, seen_held
from pegbt.sim2real.outcomes.paperplacing import paper_from_handover
from pegbt.sim2real.outcomes.transfer_order import RECEIVER
from pegbt.sim2real.outcomes.transfer_result import TransferResult

# a handover's receiver's tries at taking the block held out (`trees/shared/handover.yaml`'s `receive`)
TAKES = 5


class Giving(Protocol):
    """What the exchange needs of the attempts that brought the block to the meeting point (`trying.Trying`):
    the world and skills, the trial's perception noise and replayed arm, the failure and time the transfer
    has so far, how many attempts it may make, and the receiver's history; and the receiver's fetch of a
    block that slipped from it, which recovers as the giver's attempts do."""

    world: World
    skills: Skills
    rng: np.random.Generator
    replay: Replay
    registered: bool
    attempts: int
    first: str | None
    began: float
    receiver_from: int | None
    receiver_parks: bool

    def fetched(self, taker: Bench, goal_peg: int, first: str) -> tuple[TransferResult, Bench]: ...


def hand_over(trying: Giving, giver: Bench, block: int, goal_peg: int) -> TransferResult:
    """The giver holds `block` at the meeting point: the receiver waits open above its grasp, descends and
    closes; the giver opens and withdraws; the receiver carries the block over `goal_peg`, lowers it and
    opens (`pegbt.motion.handover`'s order); `trying.registered` (the paper's protocol, on rest-to-rest
    cubics) as the paper's robot did (`paperhandover`): the receiver waits above the grasp it planned, the
    camera looks at the held block and the receiver closes on the grasp of the block it sees, the giver
    opens and rises before the receiver carries it at the paper's heights, turning to the paper's placing
    angle (`paperplacing`) and looking before it lowers, with `trying.rng`'s perception noise
    (`paper_place`). The seconds are the trial's per transfer
    (`_overlapped`).

    Where the trial recovers (`trying.attempts` more than one), as `trees/shared/handover.yaml` does: a
    receiver whose jaw closed on nothing while the giver holds the block out (`try_to_take`'s `back off`)
    opens, rises back to wait above its grasp and descends again, up to `TAKES` times in all (`receive`'s
    `takes`), the tick log naming a miss `grasp` (the receiver's `grasp` leaf); after the last the giver
    lets go where it is (`give`'s `let go of it`: the block falls under the meeting point, `strays`); a
    block that slips from the receiver on its way to the goal peg is fetched (`carry it, or fetch it if it
    fell`, `trying.fetched`). The paper's robot took each block once.

    Where the receiver cannot go to wait above its grasp, it gives the handover up (`receive`'s `record
    the failure`: `refuse it`) and the giver lets go where it holds the block out (`give`'s `let go of
    it`). A receiver whose carry cannot be planned lets go where it is, then fetches the block from the
    board as after a slip, or, not recovering, parks (`receive`'s `let go`, `park`). A receiver that
    did not let go of the block over its goal peg is parked by the trees; its way back to the waiting
    pose (`_overlapped`'s `back`) is then its park."""
    world, skills, first, began = trying.world, trying.skills, trying.first, trying.began
    assert giver.meeting is not None  # only a held block at the meeting point is handed over
    meeting, receiver = giver.meeting, RECEIVER[giver.name]
    motion = skills.arm(receiver)
    recovers = trying.attempts > 1
    wait = meeting.receiver_grasp.pose.copy()
    wait[:3, 3] += skills.motion.handover.receiver_wait_above * world.cell.up_in(receiver)
    ik = inverse_kinematics(np.stack([wait, meeting.receiver_grasp.pose]), motion.settings)
    if not ik.ok.all():
        giver.jaw(skills.motion.transfer.jaw_open, "handover")
        return TransferResult(False, first or "handover", world.time - began)
    looks = looks_before_lowering(trying.registered, motion)
    if looks:  # the receiver last let go at the paper's placing angle too
        waypoints = paper_from_handover(
            world.cell, skills.motion, receiver, meeting.receiver_grasp, meeting.block_pose, goal_peg
        )
    else:
        waypoints = from_handover(
            world.cell, skills.motion, receiver, None, meeting.receiver_grasp, meeting.block_pose, goal_peg
        )
    q0 = _receiver_start(trying, receiver, waypoints.poses[3], goal_peg)
    taker = Bench(world, receiver, motion, q0, trying.replay, trying.registered)
    parked = 0.0
    if trying.receiver_parks:  # before the first handover of each half, or after one failed: from home
        park = planned_park(world, skills, receiver, q0)
        taker.play(park, [(0.0, "handover")])
        q0, parked = park.q[-1], float(park.t[-1] - park.t[0])
    stops = above_pegs_first(world.cell, skills.motion, receiver, q0, motion.settings)
    names = [f"stop {i}" for i in range(len(stops))] + ["waiting", "handover grasp"]
    approach = motion.through(q0, stops + list(ik.q[: 1 if looks else 2]), names)
    # The receiver gets ready while the giver picks and carries (the paper's `run_place` thread moves it
    # to `handover_ready` at once, FLSPegTransfer_handover.py; pegbt's trees run the arms in parallel):
    # its way to the waiting pose is simulated after the giver's, but its seconds are not the transfer's.
    waiting = segment_times(approach)[len(stops)]
    ahead = began + min(parked + waiting, world.time - began)
    met = world.time - began
    taker.play(approach, [(0.0, "handover")])
    if looks:  # the paper's receiver goes where the camera sees the held block (`paperhandover`)
        taken = _looked_at(trying, taker, giver, block)
        if taken is None:
            giver.jaw(skills.motion.transfer.jaw_open, "handover")
            return TransferResult(False, first or "handover", world.time - ahead)
        waypoints = paper_from_handover(world.cell, skills.motion, receiver, taken[0], taken[1], goal_peg)
        ik = inverse_kinematics(np.stack([over_grasp(world.cell, taken[0]), taken[0].pose]), motion.settings)
        if not ik.ok.all():
            giver.jaw(skills.motion.transfer.jaw_open, "handover")
            return TransferResult(False, first or "handover", world.time - ahead)
        taker.play(
            motion.through(taker.arm.joints.setpoint.copy(), list(ik.q), ["over the grasp", "grasp"]),
            [(0.0, "handover")],
        )
    taker.jaw(skills.motion.transfer.jaw_closed, "handover")
    for _ in range(TAKES - 1 if recovers else 0):
        if world.held_by(receiver) == block or world.held_by(giver.name) != block:
            break
        first = first or "grasp"
        taker.jaw(skills.motion.transfer.jaw_open, "handover")
        again = motion.through(taker.arm.joints.setpoint.copy(), list(ik.q), ["waiting", "handover grasp"])
        taker.play(again, [(0.0, "handover")])
        taker.jaw(skills.motion.transfer.jaw_closed, "handover")
    giver.jaw(skills.motion.transfer.jaw_open, "handover")
    if looks:
        _escape(giver)
    if world.held_by(receiver) != block:
        return TransferResult(False, first or "handover", world.time - ahead)
    let_go = world.time

    def result(placed: bool, phase: str | None, arm: Bench, over_goal: bool) -> TransferResult:
        back = _way_back(arm, ik.q[0]) if over_goal else _parking(world, skills, arm)
        seconds = _overlapped(let_go - ahead, met, world.time - let_go, back)
        return TransferResult(placed, phase, seconds, over_goal=over_goal)

    try:
        planned: Trajectory | None = motion.transfer(waypoints)
    except PegbtError:  # the receiver's carry fails to plan: it lets go where it is
        planned = None
        taker.jaw(skills.motion.transfer.jaw_open, "carry")
        phase = "carry"
    if planned is not None:
        _, lowering = segment_times(planned)
        if looks:
            paper_place(taker, planned, waypoints, block, goal_peg, trying.rng, [(0.0, "carry")])
        else:
            taker.play(planned, [(0.0, "carry"), (lowering, "lower")], holding=block)
        if world.held_by(receiver) == block:
            taker.jaw(skills.motion.transfer.jaw_open, "release")
            placed = world.blocks[block].peg == goal_peg and not world.blocks[block].grips
            return result(placed, first if placed else "release", taker, True)
        phase = failed_phase(taker.events, block)
    # the block handed over, the failures before were got over: a failure from here is the receiver's own
    if not recovers:
        return result(False, phase, taker, False)
    fetched, fetcher = trying.fetched(taker, goal_peg, phase)
    named = first or phase if fetched.succeeded else fetched.phase
    return result(fetched.succeeded, named, fetcher, fetched.over_goal)


def _looked_at(
    trying: Giving, taker: Bench, giver: Bench, block: int
) -> tuple[Grasp, NDArray[np.float64]] | None:
    """The paper's look at the block `giver` holds out, once both arms are at rest: the receiver's grasp of
    the block as seen (`handover_look.receiver_grasp`), and the seen pose; None if it has none."""
    world = trying.world
    truth = world.blocks[block].pose
    noise = trying.rng.normal(0.0, look_sd(world), 2)
    seen = seen_held(seen_point(world, truth[:3, 3]), truth, noise)
    if giver.chose is None:  # a giver holds a block it chose a grasp of
        return None
    taken = receiver_grasp(
        trying.skills, taker.name, giver.name, giver.chose.candidate, seen, giver.arm.joints.setpoint.copy()
    )
    return None if taken is None else (taken, seen)


def _escape(giver: Bench) -> None:
    """The giver, opened, rises `GIVER_RISE` (`move_upright` to `height_handover + offset_handover`)."""
    assert giver.meeting is not None  # only a giver at the meeting point escapes from it
    here = giver.meeting.tip.copy()
    here[:3, 3] += GIVER_RISE * giver.world.cell.up_in(giver.name)
    ik = inverse_kinematics(here[None], giver.motion.settings)
    if ik.ok.all():
        giver.play(
            giver.motion.through(giver.arm.joints.setpoint.copy(), [ik.q[0]], ["escape"]), [(0.0, "handover")]
        )


def _receiver_start(
    trying: Giving, receiver: str, dropped: NDArray[np.float64], goal_peg: int
) -> NDArray[np.float64]:
    """Where the receiver comes from to the meeting: lowered over the goal peg of its last handover
    (`receiver_from`), where it let go (as `previous_release`, its cables at rest there; `receive` goes to
    the meeting from where it is), or home, parked from the simulator's start joints, before the first of
    each half and, in a trial played in order, after a handover that failed (`receive` parks it). A
    transfer simulated alone takes its last handover as placed. The wrist's play at the receiver's grasp
    depends on that way (`dvrk-real`'s q5 and q6 hysteresis, up to 0.35 rad wide): straight from the start
    joints, its tip closes some 1.4 mm (board x) and 0.7 mm (height) off where the trees' does on the same
    command (docs/guides/sim-to-real.md)."""
    if trying.receiver_from is None:
        return START
    start = previous_release(trying.world, receiver, dropped, goal_peg, trying.receiver_from)
    ik = inverse_kinematics(start[None], trying.skills.arm(receiver).settings)
    return ik.q[0] if ik.ok.all() else START


def _parking(world: World, skills: Skills, arm: Bench) -> float:
    """Planned seconds of `arm`'s park from where it stopped (`Park`), or 0 when it cannot be planned."""
    try:
        park = planned_park(world, skills, arm.name, arm.arm.joints.setpoint.copy())
    except PegbtError:
        return 0.0
    return float(park.t[-1] - park.t[0])


def _way_back(taker: Bench, waiting: NDArray[np.float64]) -> float:
    """Planned seconds of the receiver's way from where it stopped back to the waiting pose
    (`handover_ready`), or 0 when it cannot be planned."""
    try:
        back = taker.motion.through(taker.arm.joints.setpoint.copy(), [waiting], ["waiting"])
    except PegbtError:
        return 0.0
    return float(back.t[-1] - back.t[0])


def _overlapped(exchanged: float, picked: float, placing: float, back: float) -> float:
    """A handover's seconds in a trial: until the giver has let go (`exchanged`), plus whatever of the
    receiver's `placing` and its way `back` to the waiting pose outlasts the giver's next pick, taken as
    long as this one (`picked`, the giver's start to the meeting point). The paper's two threads
    (`FLSPegTransfer_handover.py`, BerkeleyAutomation/FLSpegtransferHO) overlap them: `run_pick` moves on
    to the next order once the giver has escaped, while `run_place` goes on to `go_place`,
    `servoing_block` and `handover_ready`; pegbt's trees run the two arms' lists in parallel too."""
    return exchanged + max(0.0, placing + back - picked)
