"""One transfer's phases simulated directly on the world: no zenoh, no tree, no camera.

An arm with the fitted cable physics (`dvrk-real`, `pegbt.sim.arm.SimArm`) plays the commands the
executive's `ArmMotion` would send under the condition (rest-to-rest cubics as planned, or pre-compensated
by the simulator's calibration models, or the optimised plan), and each control tick the world sees the tool
where the physical joints put it, as `pegbt.sim.scene.Scene.update` does: descend onto the grasp, close,
lift off the peg, carry, lower onto the goal peg, open. What perception would have seen is the block's
pose with its noise (`PERCEPTION_SD`; the paper's, `PAPER_PERCEPTION_SD`), displaced as the camera's world effects displace what it sees
(`seen_point`); the arms stand where the world's registration offset puts them (`World.arm_to_board`). The phase of a failure is read from the world's events here (this is
the simulator's side, where the truth is known).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cache, partial

import numpy as np
from numpy.typing import NDArray

from pegbt.behaviours.actions.grasping import SAME_BLOCK
from pegbt.behaviours.actions.handover import Meeting, handed, plan_meeting
from pegbt.behaviours.motion import above_pegs_first, planned_approach
from pegbt.behaviours.poses import from_handover, to_handover, tool_pose, transfer_for
from pegbt.behaviours.resources.arm_motion import ArmMotion, Prepared
from pegbt.behaviours.resources.skills import SIMULATOR_CALIBRATION, Skills
from pegbt.calibration.registration import registered_arm_to_board
from pegbt.errors import PegbtError
from pegbt.frames import yaw_of, yaw_pose
from pegbt.motion.ik import inverse_kinematics, solve_ik
from pegbt.motion.placing import paper_heights, segment_times, stopped_above
from pegbt.motion.settings import motion_settings
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.perception.blocks import BlockEstimate
from pegbt.perception.grasp import Grasp
from pegbt.perception.servo import correction
from pegbt.physics import ArmPhysics
from pegbt.sim.arm import DEFAULT_JOINTS, SimArm
from pegbt.sim.events import Event
from pegbt.sim.tools import Give, ToolState, wrist_give
from pegbt.sim.world import World
from pegbt.sim.world_effects import WorldEffects
from pegbt.sim2real.outcomes.cells import PHASES
from pegbt.sim2real.outcomes.placelook import visible_points
from pegbt.workcell import transfer_list, transfer_strays

PHYSICS = "dvrk-real"  # the arm as fitted on the real recordings: never refitted here
# m per axis: the error of a block's position as pegbt's perception fits it in a whole trial (its fit
# averages the camera's 0.3 mm depth noise over some 1,200 points): 0.04-0.08 mm rms in the concealed
# campaign's first looks (docs/guides/sim-to-real.md)
PERCEPTION_SD = 0.00005
# the paper's robot: its own perception on its Zivid's clouds, never measured here; its depth noise
PAPER_PERCEPTION_SD = 0.0003
START = np.array(
    DEFAULT_JOINTS
)  # each arm comes from where the simulator starts it, its cables at rest there
REGRASPS = 3  # recoveries before a transfer is given up (`trees/shared/one_transfer.yaml`)
# a handover's receiver's tries at taking the block held out, and the recoveries of its fetch of a block
# that slipped from it (`trees/shared/handover.yaml`'s `receive` and `fetch`)
TAKES = 5
FETCH_REGRASPS = 2
# the conditions under which the carry opens the jaw as it comes down (`trees/shared/lift.yaml`'s
# `let_go_early`); under the others it lets go at rest
LETS_GO_EARLY = ("calibrated", "optimized")
SETTLE_S = 0.1  # s at rest after each motion: the executive starts the next leaf a tick or two later


def transfers(variant: str) -> tuple[tuple[str, int, int], ...]:
    """(arm, start peg, goal peg) of each of `variant`'s transfers, out and back, from the lists the trees
    loop over (`trees/shared/orders.yaml`): the handover's giver is PSM2 for the first six, PSM1 after;
    bilateral's arms take their halves in turn."""
    reference = transfer_list("reference")
    if variant == "unilateral":
        return tuple(("PSM1", *pegs) for pegs in reference)
    if variant == "handover":
        half = len(reference) // 2
        return tuple(("PSM2" if i < half else "PSM1", *pegs) for i, pegs in enumerate(reference))
    psm2, psm1 = transfer_list("bilateral_PSM2"), transfer_list("bilateral_PSM1")
    half = len(psm2) // 2
    return tuple(
        [("PSM2", *p) for p in psm2[:half]]
        + [("PSM1", *p) for p in psm1[:half]]
        + [("PSM2", *p) for p in psm2[half:]]
        + [("PSM1", *p) for p in psm1[half:]]
    )


def arms_at_once(variant: str) -> int:
    """How many of `variant`'s transfers run at once: bilateral's two arms each carry a block together
    (the paper's `FLSPegTransfer_dual.py` moves an action pair, one block per arm, in parallel threads,
    `motion/dvrkPegTransferMotionDualArm.py`; pegbt's bilateral trees run each arm's list in parallel), so a
    trial's time per transfer is half of one arm's; the others move one block at a time."""
    return 2 if variant == "bilateral" else 1


RECEIVER = {"PSM1": "PSM2", "PSM2": "PSM1"}


@dataclass(frozen=True)
class Chosen:
    """Where an attempt saw its block (board frame) and the grasp candidate it chose there: a pick again
    of the same block tries another candidate (`select_grasp`'s `another`). `truth` and `error`: where the
    block truly lay and perception's error there, which a look at the block lying just so again repeats
    (a trial's perception fits the same cloud the same way: its looks at an unmoved block agree within
    0.02 mm)."""

    position: NDArray[np.float64]
    candidate: int
    truth: NDArray[np.float64]
    error: NDArray[np.float64]


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


@cache
def _skills(condition: str, variant: str = "") -> Skills:
    """The skills a trial of `variant` runs with (a lone arm's approach passes lower over the pegs)."""
    return Skills(condition, calibration=SIMULATOR_CALIBRATION, variant=variant)


class Replay:
    """What the arm did, kept across the worlds of one transfer: the physical joints reached after each
    history of encoder positions, and the compensated commands sent for each plan from each history.

    The cable model and the compensator see only the commands, never the world, so a world whose effects
    change no command (the contact physics, a registration offset) replays the arm of the world before it
    until the block's fate makes the commands differ (a carry stopped when the block falls); from there the
    arm is simulated again, its cable model first caught up on the positions it was replayed through."""

    def __init__(self) -> None:
        self.physical: dict[bytes, tuple[NDArray[np.float64], Give]] = {}
        self.prepared: dict[tuple[bytes, bytes], Prepared] = {}


class _Bench:
    """One arm acting in one world, ticked at the control period as the simulator's endpoint does."""

    def __init__(
        self,
        world: World,
        arm: str,
        motion: ArmMotion,
        q0: NDArray[np.float64],
        replay: Replay,
        registered: bool = False,
    ) -> None:
        self.world, self.name, self.motion, self.replay = world, arm, motion, replay
        self.arm = SimArm(
            arm,
            motion.settings,
            ArmPhysics.load(PHYSICS, arm),
            q0=q0,
            jaw0=motion_settings().transfer.jaw_open,
        )
        self.to_board = world.arm_to_board(
            arm
        )  # where the base truly stands (a registration offset moves it)
        if registered and motion.compensator is None:
            # the robot plans where the paper's registration with this arm put the base; a compensated arm
            # is not moved: its calibration corrects the whole error, the part a registration takes up too
            # (the paper's models learnt what its registration left: the same tip either way)
            self.to_board = registered_arm_to_board(arm, PHYSICS, self.to_board)
        self.events: list[tuple[str, Event]] = []
        self.clock = world.time
        self.segment = "reach"
        self.held = False  # holds the block lowered over its goal peg (or at the meeting point)
        self.let_go = False  # the last carry opened the jaw as it came down (`play`'s `let_go`)
        self.moved = True  # the arm set out: an attempt the robot made, not one its planning refused
        self.meeting: Meeting | None = None
        self.failed: str | None = None  # the phase in which this attempt lost the block
        self.chose: Chosen | None = None
        self.history = hashlib.sha1(arm.encode() + q0.tobytes())
        self.behind: list[NDArray[np.float64]] = []  # encoder positions replayed, not yet through the model
        motion.desired = q0.copy()
        motion.active = None
        if motion.compensator is not None:
            motion.compensator.reset(q0)
        self.tick(SETTLE_S)

    def again(self, jaw_open: float) -> _Bench:
        """This arm, its cables as the failed attempt left them, ready for the next attempt: the jaw opened
        where it stopped (`look_again` lets go first)."""
        self.events, self.segment, self.held, self.moved = [], "reach", False, True
        self.meeting, self.failed, self.chose = None, None, None
        self.motion.desired, self.motion.active = self.arm.joints.setpoint.copy(), None
        if self.world.held_by(self.name) is None:
            self.jaw(jaw_open, "reach")
        return self

    @classmethod
    def failed_before(cls, world: World, arm: str, motion: ArmMotion, phase: str) -> _Bench:
        """An attempt that could not start (no feasible grasp, out of reach)."""
        bench = cls.__new__(cls)
        bench.world, bench.name, bench.motion, bench.events = world, arm, motion, []
        bench.held, bench.failed, bench.meeting, bench.moved = False, phase, None, False
        bench.let_go = False
        bench.chose = None
        return bench

    def tick(self, seconds: float) -> None:
        """Advance the arm, and the world with it; an approach holding nothing (`reach`) shows the world
        only where it ends, since no contact on the way decides an outcome."""
        for _ in range(max(1, round(seconds / self.arm.period))):
            self._advance()
            self.clock = max(self.clock, self.world.time) + self.arm.period
            if self.segment == "reach" and self.arm.is_busy:
                continue
            tool = ToolState.from_joints(
                self.arm.physical, float(self.arm.jaw.encoder[0]), self.to_board, self.give
            )
            self.events += [(self.segment, e) for e in self.world.update(self.clock, {self.name: tool})]
            self.arm.jaw.stop_at(self.world.jaw_stop(self.name))

    def _advance(self) -> None:
        """`SimArm.advance`, with the cable model's answer (the physical joints and the wrist's play) replayed
        when this encoder history has one."""
        arm, period = self.arm, self.arm.period
        arm.joints.advance(period)
        arm.jaw.advance(period)
        self.history.update(arm.joints.encoder.tobytes())
        key = self.history.digest()
        known = self.replay.physical.get(key)
        if known is None:
            for encoder in self.behind:
                arm.physics.step(encoder, period)
            self.behind.clear()
            physical = arm.physics.step(arm.joints.encoder, period).copy()
            give = wrist_give(arm.physics, float(physical[5]), self.world.cell.tool)
            known = self.replay.physical[key] = (physical, give)
        else:
            self.behind.append(arm.joints.encoder.copy())
        arm.physical, self.give = known

    def _prepare(self, planned: Trajectory) -> Prepared:
        """`ArmMotion.prepare`, replayed when this history already sent this plan."""
        key = (self.history.digest(), planned.t.tobytes() + planned.q.tobytes())
        prepared = self.replay.prepared.get(key)
        if prepared is None:
            prepared = self.replay.prepared[key] = self.motion.prepare(planned)
        if prepared.compensator is not None:
            self.motion.compensator = prepared.compensator.fork()
        return prepared

    def play(
        self,
        planned: Trajectory,
        segments: list[tuple[float, str]],
        holding: int | None = None,
        let_go: tuple[float, float] | None = None,
    ) -> None:
        """Send `planned` as the condition sends it; `segments` names the phase from each planned time on.
        A carry of block `holding` stops the moment the block leaves the jaw, as the carry leaves do;
        `let_go` (seconds before the planned end, jaw angle) opens the jaw as the arm comes down, as
        `Transfer` does (`pegbt/behaviours/actions/moving.py`): from then on the carry no longer watches
        the jaw, and a block lost is lost at `release`, as the tick log's carry reads it."""
        prepared = self._prepare(planned)
        sent = prepared.sent
        self.arm.follow_jt(sent.t - sent.t[0] + self.arm.period, sent.q, sent.qd, "motion")
        self.motion.desired = planned.q[-1].copy()
        start, self.let_go = self.world.time, False
        due = None if let_go is None else float(planned.t[-1] - planned.t[0]) - let_go[0]
        while self.arm.is_busy:
            elapsed = self.world.time - start
            self.segment = next((name for at, name in reversed(segments) if elapsed >= at), segments[0][1])
            if let_go is not None and due is not None and elapsed >= due - 1e-9:
                if not self.let_go:
                    self.arm.jaw_move_jp([let_go[1]], "jaw")
                    self.let_go = True
                self.segment = "release"
            self.tick(self.arm.period)
            if holding is not None and not self.let_go and self.world.held_by(self.name) != holding:
                self.arm.hold(False, "lost")
                break
        self.tick(SETTLE_S)

    def jaw(self, angle: float, segment: str) -> None:
        self.segment = segment
        self.arm.jaw_move_jp([angle], "jaw")
        while self.arm.is_busy:
            self.tick(self.arm.period)
        self.tick(SETTLE_S)


def simulate_transfer(
    effects: WorldEffects,
    variant: str,
    condition: str,
    seed: int,
    replay: Replay | None = None,
    index: int | None = None,
    attempts: int = 1 + REGRASPS,
    registered: bool = False,
) -> TransferResult:
    """Transfer number `index` of `variant`'s transfers (by default `seed`, cycling), on a world of layout
    `seed` (a trial's transfers, one for one, with the same `seed` and each `index`), `attempts` in all;
    `registered`: each uncalibrated arm registered to the camera as the paper's were, with itself
    (`registration`).
    A transfer on the way back first simulates the outward transfer of its block: if that one was not
    placed, the way back finds its start peg empty and fails at `sense`, as a trial's tick log says (the
    recovery fetches strays only for a block the transfer itself lost). `replay`: the arm's motion in
    other worlds of this same transfer (variant, condition, seed), to reuse where it is the same."""
    replay = Replay() if replay is None else replay
    order = transfers(variant)
    index = seed % len(order) if index is None else index
    if index >= len(order) // 2:
        start_peg = order[index][1]
        outward = next(i for i, (_, _, goal) in enumerate(order[: len(order) // 2]) if goal == start_peg)
        there = _transfer(effects, variant, condition, seed, outward, replay, attempts, registered)
        if not there.succeeded:
            return TransferResult(False, "sense", there.seconds, skipped=True)
    return _transfer(effects, variant, condition, seed, index, replay, attempts, registered)


def _transfer(
    effects: WorldEffects,
    variant: str,
    condition: str,
    seed: int,
    index: int,
    replay: Replay,
    attempts: int,
    registered: bool = False,
) -> TransferResult:
    """Transfer `index` of `variant`'s transfers alone on a world of layout `seed` (on the way back every
    block starts where its outward transfer placed it), its recoveries going after its own block."""
    world = World(seed, effects=effects)
    if index >= len(transfers(variant)) // 2:
        _moved_out(world, transfers(variant))
    rng = np.random.default_rng([seed, 7])
    return carry_out(world, variant, condition, index, replay, attempts, registered, rng)


# which block an attempt goes after: (world, pick peg, whether the transfer lost its block already, the
# pegs a lost block may have fallen onto alone) -> the block's index, or None when it finds none
Pick = Callable[[World, int, bool, tuple[int, ...]], int | None]


def carry_out(
    world: World,
    variant: str,
    condition: str,
    index: int,
    replay: Replay,
    attempts: int,
    registered: bool,
    rng: np.random.Generator,
    pick: Pick | None = None,
    receiver_parked: bool = False,
) -> TransferResult:
    """Transfer `index` of `variant`'s transfers on `world` as it lies: the grasp the executive would
    choose for the block perception would see, and the motions it would send, picked and carried again
    after a failure, `attempts` in all (`trees/shared/one_transfer.yaml` recovers `REGRASPS` times, from
    wherever the block fell); a grasp the planning refuses before the arm moves is sensed and planned again
    without counting. Each attempt goes after the block `pick` names (none found: a failure at `sense`,
    and the next attempt looks again); without `pick`, after the block on the pick peg wherever it falls.
    The arm's cables carry the history the tree gives them: the arm's first transfer of each half starts
    from the home pose the trees park it at before each half (the very first, parked from the simulator's
    start joints), the others from where the arm let go of its previous block, and an attempt after a failure
    from home, parked from where the failed attempt stopped the arm, its cables as they were there
    (`trees/shared/recover.yaml`'s `look_again`: let go, `park`, sense). A handover's exchange and its
    receiver's carry are `_hand_over`'s, retried and fetched again as the trees do when `attempts` allow a
    recovery (pegbt's trees; the paper's robot tried each block once). A transfer whose goal peg held a
    block as it began is not placed, whatever it put there (`pegbt.executive.phases.transfer_outcomes`: the
    robot's look before it began saw the peg taken; a fetch picks the block on its goal peg first).
    `receiver_parked`: the trial's handover before this one failed, so its receiver was parked at home."""
    order = transfers(variant)
    arm, start_peg, goal_peg = order[index]
    previous_peg = next(goal for other, _, goal in reversed(order + order[:index]) if other == arm)
    strays = transfer_strays("reference")[index] if variant == "handover" else ()
    own = next((b.index for b in world.blocks if b.peg == start_peg), None)
    half = len(order) // 2
    mine = [i for i, (other, _, _) in enumerate(order) if other == arm]
    in_trial = pick is not None and variant == "handover"  # the receiver's history in its trial
    from_home = index in (0, half) or receiver_parked  # else from over its last goal peg
    trying = _Trying(
        world,
        _skills(condition, variant),
        variant,
        arm,
        replay,
        rng,
        registered,
        attempts,
        came_from=None if index == mine[0] else previous_peg,
        parks=index in (mine[0], next((i for i in mine if i >= half), None)),  # parked before each half
        choose=(lambda again: pick(world, start_peg, again, strays)) if pick else (lambda again: own),
        looks_again=pick is not None,
        fetch=pick or (lambda *_: own),
        strays=strays,
        receiver_from=None if not in_trial or from_home else order[index - 1][2],
        receiver_parks=in_trial and from_home,
    )
    taken = any(b.peg == goal_peg and not b.lost for b in world.blocks)
    result = trying.run(goal_peg, 1 + REGRASPS)
    if result.succeeded and taken:  # as a tick log is read: a block put on a peg seen taken is no placing
        return replace(result, succeeded=False, phase=result.phase or "release")
    return result


class _Trying:
    """One arm's picks and carries of a transfer's block, each after the last failed (`carry_out`): what
    they share across attempts."""

    def __init__(
        self,
        world: World,
        skills: Skills,
        variant: str,
        arm: str,
        replay: Replay,
        rng: np.random.Generator,
        registered: bool,
        attempts: int,
        *,
        choose: Callable[[bool], int | None],
        came_from: int | None = None,
        parks: bool = True,
        looks_again: bool = True,
        fetch: Pick = lambda *_: None,
        strays: tuple[int, ...] = (),
        receiver_from: int | None = None,
        receiver_parks: bool = False,
        failed: _Bench | None = None,
        first: str | None = None,
        began: float | None = None,
    ) -> None:
        """`choose`: the block an attempt goes after (given whether it is a recovery); `came_from`: the peg
        the arm let go over last (None: home); `parks`: it parks before its first attempt; `looks_again`: a
        pick that finds no block recovers; `fetch`, `strays`: a handover receiver's fetch of a slipped block
        (`fetched`); `receiver_from`, `receiver_parks`: where a handover's receiver let go last, and whether
        it parks before it goes to the meeting; `failed`, `first`, `began`: the attempt, failure and time
        an earlier loop left (a fetch goes on from the receiver's carry)."""
        self.world, self.skills, self.variant, self.arm = world, skills, variant, arm
        self.replay, self.rng, self.registered, self.attempts = replay, rng, registered, attempts
        self.choose, self.came_from, self.parks, self.looks_again = choose, came_from, parks, looks_again
        self.fetch, self.strays = fetch, strays
        self.receiver_from, self.receiver_parks = receiver_from, receiver_parks
        self.failed = failed  # the last attempt the arm set out on
        self.first = first
        self.began = world.time if began is None else began

    def run(self, goal_peg: int, tries: int) -> TransferResult:
        """Up to `tries` picks (`self.attempts` of them set out) of the block `choose` names, each carried
        to `goal_peg`; the first held at a handover's meeting point is handed over."""
        world, skills, arm = self.world, self.skills, self.arm
        made = 0  # attempts the arm set out on (a grasp or meeting refused before moving is planned again)
        chose: Chosen | None = None
        for attempt in range(tries):
            if made == self.attempts:
                break
            block = self.choose(attempt > 0)
            if block is None or world.blocks[block].lost:
                if not self.looks_again:
                    break
                self.first, self.parks = self.first or "sense", True  # the recovery parks before it looks
                continue
            bench = _attempt(
                world,
                skills,
                arm,
                block,
                goal_peg,
                self.rng,
                self.came_from,
                self.replay,
                self.variant,
                chose,
                self.registered,
                self.parks,
                self.failed,
            )
            made += bench.moved
            chose = bench.chose or chose
            self.failed = bench if bench.moved else self.failed
            if bench.held and bench.meeting is not None:
                return _hand_over(self, bench, block, goal_peg)
            if bench.held:
                bench.jaw(skills.motion.transfer.jaw_open, "release")
                placed = world.blocks[block]
                if placed.peg == goal_peg and not placed.grips:
                    return TransferResult(True, self.first, world.time - self.began, over_goal=True)
                phase = self.first or _failed_phase(bench.events, block)
                return TransferResult(False, phase, world.time - self.began, over_goal=True)
            self.first = self.first or bench.failed
            if world.held_by(arm) is not None:
                bench.jaw(skills.motion.transfer.jaw_open, "grasp")
        return TransferResult(False, self.first or "grasp", world.time - self.began)

    def fetched(self, taker: _Bench, goal_peg: int, first: str) -> tuple[TransferResult, _Bench]:
        """The receiver lost its block on its way to `goal_peg` (its first failure `first`): it looks again,
        picks the block on that peg, else the loose one nearest it, and carries it there, recovering
        `FETCH_REGRASPS` times (`trees/shared/handover.yaml`'s `fetch`, its `pick` and `lift` as a one-arm
        transfer's); with the receiver's arm as the fetch left it."""
        fetching = _Trying(
            self.world,
            self.skills,
            "unilateral",  # one arm's pick and carry: no meeting
            taker.name,
            self.replay,
            self.rng,
            self.registered,
            1 + FETCH_REGRASPS,
            choose=lambda again: self.fetch(self.world, goal_peg, True, self.strays),
            failed=taker,
            first=first,
            began=self.began,
        )
        return fetching.run(goal_peg, 1 + FETCH_REGRASPS), fetching.failed or taker


def _moved_out(world: World, order: tuple[tuple[str, int, int], ...]) -> None:
    """Seat every block on the peg its outward transfer places it on, as a trial's way back finds them
    (each at its layout's yaw: where a placement leaves it turned is the lowering's business)."""
    goal_of = {start: goal for _, start, goal in order[: len(order) // 2]}
    for block in world.blocks:
        assert block.peg is not None  # a new world's blocks all rest on their pegs
        x, y = world.cell.pegs.positions[goal_of[block.peg]]
        block.pose = yaw_pose([x, y, world.cell.board.surface_z], yaw_of(block.pose))
        block.peg = goal_of[block.peg]


def seen_point(world: World, point: NDArray[np.float64]) -> NDArray[np.float64]:
    """Where perception finds a block's point (board frame): `depth_bias` farther along the camera's ray
    (`pegbt.sim.camera` lengthens the rays meeting blocks; the board and its pegs are measured true)."""
    bias = world.effects.values("depth_bias")["bias"]
    ray = point - world.cell.camera.board_from_camera[:3, 3]
    return point + bias * ray / np.linalg.norm(ray)


def _previous_release(
    world: World, arm: str, dropped: NDArray[np.float64], goal_peg: int, previous_peg: int
) -> NDArray[np.float64]:
    """Where `arm` let go of a block lowered over `previous_peg` (its tip pose in its frame, as `dropped`
    over `goal_peg` but over `previous_peg`): an attempt starts there, its cables at rest."""
    to_arm = world.cell.board_to_arm(arm)
    shift = to_arm[:3, :3] @ (world.cell.pegs.tops[previous_peg] - world.cell.pegs.tops[goal_peg])
    start = dropped.copy()
    start[:3, 3] += shift
    return start


def _attempt(
    world: World,
    skills: Skills,
    arm: str,
    block: int,
    goal_peg: int,
    rng: np.random.Generator,
    came_from: int | None,
    replay: Replay,
    variant: str = "unilateral",
    chose: Chosen | None = None,
    registered: bool = False,
    parks: bool = False,
    after: _Bench | None = None,
) -> _Bench:
    """One pick and carry of `block` as it lies, seen with perception's noise (as at the last look, `chose`,
    if it has not moved since): the bench afterwards says
    whether the arm holds it lowered over `goal_peg`, or at the meeting point for a `handover` (`held`,
    with `meeting`), or in which phase it was lost (`failed`). A pick again of the block seen where the
    last attempt `chose` its grasp avoids that candidate, as `SelectGrasp` does
    (`pegbt/behaviours/actions/grasping.py`, `trees/shared/grasp.yaml`'s `another`). The arm starts lowered
    over peg `came_from` (None: at the simulator's start joints) and, when it `parks`, first goes home as
    `Park` does (`pegbt/behaviours/actions/moving.py`); it approaches as `Approach` does. An attempt `after`
    one that failed goes on with that attempt's arm from where it stopped, and parks. A `registered` arm
    (the paper's protocol) on rest-to-rest cubics carries at the paper's heights and looks before it
    lowers (`_looks`, `_paper_place`)."""
    handover = variant == "handover"
    truth = world.blocks[block]
    if chose is not None and np.array_equal(chose.truth, truth.pose):
        noise = chose.error  # the block lies as it did at the last look: perception sees it as then
    else:
        noise = rng.normal(0.0, PAPER_PERCEPTION_SD if registered else PERCEPTION_SD, 2)
    position = seen_point(world, truth.pose[:3, 3]) + [noise[0], noise[1], 0.0]
    seen = BlockEstimate(position, yaw_of(truth.pose), truth.peg, 1.0, 0.0, 0, True, "")
    motion = skills.arm(arm)
    looks = _looks(registered, motion)
    same = chose is not None and np.linalg.norm(chose.position[:2] - position[:2]) <= SAME_BLOCK
    # a giver chooses among the grasps its receiver can take the block from (`select_grasp`'s `handover_to`)
    acceptable = partial(_handed, skills, arm, seen) if handover else None
    grasp = skills.selectors[arm].pick(
        seen, avoid=(chose.candidate,) if same and chose else (), acceptable=acceptable
    )
    meeting = None
    if grasp is None:
        return _Bench.failed_before(world, arm, motion, "sense")
    if handover:
        meeting = plan_meeting(skills, arm, RECEIVER[arm], grasp, seen)
        assert meeting is not None  # the grasp was chosen among those `_handed` accepts
    if meeting is None:
        heights = paper_heights(skills.motion, variant) if looks else skills.motion
        waypoints = transfer_for(world.cell, heights, arm, None, seen, grasp, goal_peg)
    else:
        waypoints = to_handover(world.cell, skills.motion, arm, None, seen, grasp, meeting.tip)
    if waypoints.approach is None:
        return _Bench.failed_before(world, arm, motion, "reach")
    if after is not None:
        bench = after.again(skills.motion.transfer.jaw_open)
        q0, parks = bench.arm.joints.setpoint.copy(), True
    elif came_from is None:
        q0 = START
    else:
        start = _previous_release(world, arm, waypoints.poses[3], goal_peg, came_from)
        ik = inverse_kinematics(start[None], motion.settings)
        if not ik.ok.all():
            return _Bench.failed_before(world, arm, motion, "reach")
        q0 = ik.q[0]
    if after is None:
        bench = _Bench(world, arm, motion, q0, replay, registered)
    bench.chose = Chosen(position, grasp.candidate, truth.pose.copy(), noise)
    try:
        if parks:
            park = _park(world, skills, arm, q0)
            bench.play(park, [(0.0, "reach")])
            q0 = park.q[-1]
        reach = planned_approach(skills, arm, q0, None, seen, grasp)
    except PegbtError:  # the approach leaf fails to plan: nothing moves
        bench.failed, bench.moved = "reach", False
        return bench
    bench.play(reach, [(0.0, "reach")])
    bench.jaw(skills.motion.transfer.jaw_closed, "grasp")
    if world.held_by(arm) != block:
        bench.failed = "grasp"
        return bench
    try:
        planned = motion.transfer(waypoints)
    except PegbtError:  # the carrying leaf fails to plan (a goal out of reach): the tick log says carry
        bench.failed = "carry"
        return bench
    lifted, lowering = segment_times(planned)
    let_go = None
    if skills.condition in LETS_GO_EARLY and not registered and meeting is None:
        let_go = _letting_go(skills, motion)  # the paper's robot, and a giver, let go at rest
    if looks and meeting is None:
        _paper_place(bench, planned, waypoints, block, goal_peg, rng, [(0.0, "lift"), (lifted, "carry")])
    else:
        segments = [(0.0, "lift"), (lifted, "carry"), (lowering, "lower")]
        bench.play(planned, segments, holding=block, let_go=let_go)
    bench.held = (world.held_by(arm) == block or bench.let_go) and bench.failed is None
    bench.meeting = meeting
    if not bench.held:
        bench.failed = _failed_phase(bench.events, block)
    return bench


def _handed(skills: Skills, arm: str, seen: BlockEstimate, option: Grasp) -> bool:
    """Whether `arm`'s receiver can take the block `seen` from it holding it by `option` (`handed`); a
    meeting the giver cannot reach is none."""
    try:
        return handed(skills, arm, RECEIVER[arm], seen, option)
    except PegbtError:
        return False


def _looks(registered: bool, motion: ArmMotion) -> bool:
    """Whether a transfer is placed as the paper's robot placed it (`_paper_place`): under its protocol,
    with the rest-to-rest cubics of its `transfer_block_traj` (`use_optimization = False`), which stop
    over the goal peg. Its optimised trajectory went on down to `height_drop` and looked there, then rose
    again; that is not played here: an optimised paper-protocol transfer lowers without looking."""
    return registered and motion.planner is None


def _paper_place(
    bench: _Bench,
    planned: Trajectory,
    waypoints: TransferWaypoints,
    block: int,
    goal_peg: int,
    rng: np.random.Generator,
    segments: list[tuple[float, str]],
) -> None:
    """The paper's placing (`placelook`): `planned` played up to its stop above `goal_peg` (`segments`
    name its phases), the held block seen there as perception sees a block (`seen_point`, `PAPER_PERCEPTION_SD`
    in board x, y), the arm moved by `servoing_block`'s correction over the peg (a rest-to-rest move of
    the arm as it is, so imperfect too) and down to the drop height, where `_transfer` opens the jaw."""
    bench.play(stopped_above(planned), segments, holding=block)
    world = bench.world
    if world.held_by(bench.name) != block:
        return
    noise = rng.normal(0.0, PAPER_PERCEPTION_SD, 2)
    bottom = seen_point(world, world.blocks[block].pose[:3, 3]) + [noise[0], noise[1], 0.0]
    points = visible_points(world, goal_peg)
    move = correction(
        world.cell.board_to_arm(bench.name), world.cell.pegs.positions[goal_peg], bottom, points
    )
    above, dropped = waypoints.poses[2].copy(), waypoints.poses[3].copy()
    above[:3, 3] += move
    dropped[:3, 3] += move
    settings = bench.motion.settings
    try:
        joints = [solve_ik(pose, settings, what=f"{bench.name} place") for pose in (above, dropped)]
        servo = bench.motion.through(bench.arm.joints.setpoint.copy(), joints, ["servo", "drop"])
    except PegbtError:  # the corrected place is out of reach: the robot's command fails there
        bench.failed = "lower"
        return
    moved, _ = segment_times(servo)
    bench.play(servo, [(0.0, "carry"), (moved, "lower")], holding=block)


def _park(world: World, skills: Skills, arm: str, start: NDArray[np.float64]) -> Trajectory:
    """`arm` from joints `start` to its home pose out of the camera's view, straight up first if low
    among the pegs (`Park`, `pegbt/behaviours/actions/moving.py`)."""
    motion, cell = skills.arm(arm), world.cell
    home = tool_pose(motion.settings.home_tip, 0.0, cell.up_in(arm))
    joints = above_pegs_first(cell, skills.motion, arm, start, motion.settings)
    joints.append(solve_ik(home, motion.settings, what=f"{arm} home pose"))
    names = [f"stop {i}" for i in range(len(joints) - 1)] + ["home"]
    return motion.through(start, joints, names)


def _hand_over(trying: _Trying, giver: _Bench, block: int, goal_peg: int) -> TransferResult:
    """The giver holds `block` at the meeting point: the receiver waits open above its grasp, descends and
    closes; the giver opens and withdraws; the receiver carries the block over `goal_peg`, lowers it and
    opens (`pegbt.motion.handover`'s order); `trying.registered` (the paper's protocol), at the paper's
    heights and looking before it lowers, with `trying.rng`'s perception noise (`_paper_place`). The seconds
    are the trial's per transfer (`_overlapped`).

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
    looks = _looks(trying.registered, motion)
    heights = paper_heights(skills.motion, "handover") if looks else skills.motion
    waypoints = from_handover(
        world.cell, heights, receiver, None, meeting.receiver_grasp, meeting.block_pose, goal_peg
    )
    q0 = _receiver_start(trying, receiver, waypoints.poses[3], goal_peg)
    taker = _Bench(world, receiver, motion, q0, trying.replay, trying.registered)
    parked = 0.0
    if trying.receiver_parks:  # before the first handover of each half, or after one failed: from home
        park = _park(world, skills, receiver, q0)
        taker.play(park, [(0.0, "handover")])
        q0, parked = park.q[-1], float(park.t[-1] - park.t[0])
    stops = above_pegs_first(world.cell, skills.motion, receiver, q0, motion.settings)
    names = [f"stop {i}" for i in range(len(stops))] + ["waiting", "handover grasp"]
    approach = motion.through(q0, stops + list(ik.q), names)
    # The receiver gets ready while the giver picks and carries (the paper's `run_place` thread moves it
    # to `handover_ready` at once, FLSPegTransfer_handover.py; pegbt's trees run the arms in parallel):
    # its way to the waiting pose is simulated after the giver's, but its seconds are not the transfer's.
    waiting = segment_times(approach)[len(stops)]
    ahead = began + min(parked + waiting, world.time - began)
    met = world.time - began
    taker.play(approach, [(0.0, "handover")])
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
    if world.held_by(receiver) != block:
        return TransferResult(False, first or "handover", world.time - ahead)
    let_go = world.time

    def result(placed: bool, phase: str | None, arm: _Bench, over_goal: bool) -> TransferResult:
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
            _paper_place(taker, planned, waypoints, block, goal_peg, trying.rng, [(0.0, "carry")])
        else:
            taker.play(planned, [(0.0, "carry"), (lowering, "lower")], holding=block)
        if world.held_by(receiver) == block:
            taker.jaw(skills.motion.transfer.jaw_open, "release")
            placed = world.blocks[block].peg == goal_peg and not world.blocks[block].grips
            return result(placed, first if placed else "release", taker, True)
        phase = _failed_phase(taker.events, block)
    # the block handed over, the failures before were got over: a failure from here is the receiver's own
    if not recovers:
        return result(False, phase, taker, False)
    fetched, fetcher = trying.fetched(taker, goal_peg, phase)
    named = first or phase if fetched.succeeded else fetched.phase
    return result(fetched.succeeded, named, fetcher, fetched.over_goal)


def _receiver_start(
    trying: _Trying, receiver: str, dropped: NDArray[np.float64], goal_peg: int
) -> NDArray[np.float64]:
    """Where the receiver comes from to the meeting: in a trial played in order, lowered over the goal peg of
    its last handover (`receiver_from`), where it let go (as `_previous_release`, its cables at rest there;
    `receive` goes to the meeting from where it is), or home, parked from the simulator's start joints,
    before the first of each half and after a handover that failed (`receive` parks it); alone, from the
    simulator's start joints."""
    if trying.receiver_from is None:
        return START
    start = _previous_release(trying.world, receiver, dropped, goal_peg, trying.receiver_from)
    ik = inverse_kinematics(start[None], trying.skills.arm(receiver).settings)
    return ik.q[0] if ik.ok.all() else START


def _parking(world: World, skills: Skills, arm: _Bench) -> float:
    """Planned seconds of `arm`'s park from where it stopped (`Park`), or 0 when it cannot be planned."""
    try:
        park = _park(world, skills, arm.name, arm.arm.joints.setpoint.copy())
    except PegbtError:
        return 0.0
    return float(park.t[-1] - park.t[0])


def _way_back(taker: _Bench, waiting: NDArray[np.float64]) -> float:
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


def _letting_go(skills: Skills, motion: ArmMotion) -> tuple[float, float]:
    """When (s before a carry's planned end) and how far the trees' carry opens the jaw as it comes down:
    reaching `jaw_release` as the arm stops (`Transfer.begin`)."""
    transfer = skills.motion.transfer
    return (transfer.jaw_release - transfer.jaw_closed) / motion.settings.jaw_velocity, transfer.jaw_release


def _failed_phase(events: list[tuple[str, Event]], block: int) -> str:
    """The segment in which the block was first lost: knocked loose, slipped, dropped or misplaced."""
    for segment, event in events:
        if (
            event.block == block
            and event.kind in ("collision", "slip", "drop")
            and (event.kind != "collision" or "block-peg" in event.detail)
        ):
            return segment if segment in PHASES else "carry"
    return "release"
