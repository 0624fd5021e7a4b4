"""One simulated arm acting in one world, and its clock: the `dvrk-real` cables ticked at the control
period as the simulator's endpoint ticks them, the world updated where the physical joints put the tool.

Every pick, carry and handover of the phase simulator plays its motions through a bench, which keeps what
they share: the arm's cables, the world's events by the phase playing, whether the block is held, and
what its attempt chose (`Chosen`), which the next attempt reads. A bench also replays the arm's answer
for a history of commands it has seen in another world (`Replay`), which is what makes the fit's many
worlds per transfer cheap.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from functools import cache

import numpy as np
from numpy.typing import NDArray

from pegbt.behaviours.meeting import Meeting
from pegbt.behaviours.resources.arm_motion import ArmMotion, Prepared
from pegbt.calibration.registration import registered_arm_to_board
from pegbt.motion.settings import motion_settings
from pegbt.motion.trajectory import Trajectory
from pegbt.perception.grasp import Grasp
from pegbt.physics import ArmPhysics, Effect
from pegbt.sim.arm import DEFAULT_JOINTS, SimArm
from pegbt.sim.events import Event
from pegbt.sim.tools import Give, ToolState, wrist_give
from pegbt.sim.world import World

PHYSICS = "dvrk-real"  # the arm as fitted on the real recordings: never refitted here
START = np.array(
    DEFAULT_JOINTS
)  # each arm comes from where the simulator starts it, its cables at rest there
SETTLE_S = 0.1  # s at rest after each motion: the executive starts the next leaf a tick or two later


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


class Replay:
    """What the arm did, kept across the worlds of one transfer: the physical joints reached after each
    history of encoder positions, the compensated commands sent for each plan from each history, and the
    grasp (and a handover's meeting) chosen for each block as seen (`attempt.chosen_grasp`).

    The cable model and the compensator see only the commands, never the world, so a world whose effects
    change no command (the contact physics, a registration offset) replays the arm of the world before it
    until the block's fate makes the commands differ (a carry stopped when the block falls); from there the
    arm is simulated again, its cable model first caught up on the positions it was replayed through."""

    def __init__(self) -> None:
        self.physical: dict[bytes, tuple[NDArray[np.float64], Give]] = {}
        self.prepared: dict[tuple[bytes, bytes], Prepared] = {}
        self.choices: dict[tuple[object, ...], tuple[Grasp | None, Meeting | None]] = {}


@cache
def _cables(arm: str) -> tuple[Effect, ...]:
    """`PHYSICS`'s effects on `arm`, read once: each bench builds its arm's cables afresh from them."""
    return ArmPhysics.load(PHYSICS, arm).effects


class Bench:
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
            ArmPhysics(_cables(arm)),
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

    def again(self, jaw_open: float) -> Bench:
        """This arm, its cables as the failed attempt left them, ready for the next attempt: the jaw opened
        where it stopped (`look_again` lets go first)."""
        self.events, self.segment, self.held, self.moved = [], "reach", False, True
        self.meeting, self.failed, self.chose = None, None, None
        self.motion.desired, self.motion.active = self.arm.joints.setpoint.copy(), None
        if self.world.held_by(self.name) is None:
            self.jaw(jaw_open, "reach")
        return self

    @classmethod
    def failed_before(cls, world: World, arm: str, motion: ArmMotion, phase: str) -> Bench:
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
        arm, world, period = self.arm, self.world, self.arm.period
        for _ in range(max(1, round(seconds / period))):
            self._advance()
            self.clock = max(self.clock, world.time) + period
            if self.segment == "reach" and arm.is_busy:
                continue
            tool = ToolState.from_joints(arm.physical, float(arm.jaw.encoder[0]), self.to_board, self.give)
            events = world.update(self.clock, {self.name: tool})
            if events:
                self.events += [(self.segment, e) for e in events]
            arm.jaw.stop_at(world.jaw_stop(self.name))

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
