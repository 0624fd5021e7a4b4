"""Base classes of the peg-transfer leaves: resources, failures with reasons, and non-blocking motions.

A `RobotLeaf` fetches the `robot` and `skills` resources in `setup()`. Anything the world or a user
can cause (an unreachable pose, a refused command, a poor fit) arrives as a `PegbtError`; the leaf
then fails with the error's text as its feedback message, so the tick log and `pegbt log why` say why.
An endpoint that went silent is different: no recovery in a tree can bring it back, so `EndpointSilent`
propagates, and the runner halts the tree (every motion told to stop), logs the cause and ends the
run. Other exceptions are bugs and crash the run the same way.

A `MotionLeaf` plans its motions in `initialise` (`begin()`: one per arm or jaw), computes the heavy part
(SQP planning, pre-compensating every row) on a worker thread, sends them all on the tick that finds that
done, polls them in `update` and, when halted, stops whatever still moves in `terminate` (and discards
a plan still computing). It never blocks a tick. A plan made early (`ArmMotion.plan_early`) for the inputs
a leaf's motion is made from (`move(..., inputs=)`) is taken instead of planning again, and every plan is
checked as it is sent (`ArmMotion.stale`): one made from a state the arm is no longer in is made again
from where the arm is (at most `REPLANS` times in a row), never sent. A `ComputeLeaf` is one computation off the tick
(perception, a handover's meeting), picked up by a later tick.
Before an arm motion is sent, it is checked against where the other arm is meant to be at the same
times (moving or at rest): if the tools would come closer than `keep_apart`, nothing is sent and the
leaf waits, planning again a little later, until the way is clear (or fails after `BLOCKED_PATIENCE`).
Tools already closer than that (a handover's) may only part: a motion that never brings them closer than
they start and ends `keep_apart` apart is sent (`parts`).
Two arms can block each other, each resting in the other's way; then the one that is not carrying a
block and started waiting last steps back: it withdraws its tool along its own shaft (insertion only,
which takes the tool away from everything), and plans again from there. One blocked by an arm that waits
for nothing steps back after `LONE_PATIENCE`.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import NDArray
from py_trees.common import Status

from pegbt.behaviours.resources.arm_motion import ArmMotion, Prepared, prepare_all
from pegbt.behaviours.resources.robot import Robot
from pegbt.behaviours.resources.skills import Skills
from pegbt.clock import Clock, is_realtime
from pegbt.errors import PegbtError
from pegbt.executive.leaf import Leaf
from pegbt.executive.work import Job
from pegbt.motion.trajectory import Trajectory
from pegbt.transport import ArmClient, EndpointSilent, MotionHandle

log = logging.getLogger("pegbt.behaviours")
BLOCKED_RETRY = 0.1  # s between attempts of a motion that would come too close to the other arm
BLOCKED_PATIENCE = 15.0  # s a motion waits for the other arm to clear its way before the leaf fails
PARTING_SLACK = 1e-6  # m: rounding, in whether a motion brings the tools closer than they start (`parts`)
STEP_BACK = 0.03  # m of insertion an arm gives up to let the other arm past
# s an arm waits for one that waits for nothing before it steps back: longer than the other's motions take
# to pass (2.1 s at most in bilateral trials, 2026-11-29)
LONE_PATIENCE = 5.0
REPLANS = 3  # plans in a row found stale as they were sent before the leaf fails
# control periods more a timed jaw motion is sent ahead in real time: one for the robot's word that the jaw
# reached its goal (a state message after the last row), a quarter for the jaw motion's own dispatch
JAW_AHEAD = 1.25
# s a motion may run past its planned end before the leaf gives up on it: in real time an endpoint's
# report of the end can be lost (a busy machine), and every motion is bounded in time
MOTION_OVERTIME = 3.0


class Blocked(Exception):
    """A motion not sent because it would bring the arms too close; the leaf waits and tries again."""


class RobotLeaf(Leaf):
    """A leaf using the robot and the skills; `PegbtError`s from `act()` fail it with their reason."""

    def setup(self, **kwargs: object) -> None:
        self.robot = self.context.resource("robot", Robot)
        self.skills = self.context.resource("skills", Skills)

    def client(self, arm: str | None = None) -> ArmClient:
        return self.robot.arm(arm or self.param("arm"))

    def motion(self, arm: str | None = None) -> ArmMotion:
        return self.skills.arm(arm or self.param("arm"))

    def get(self, name: str) -> Any:
        """The value of the blackboard key named by key parameter `name` (untyped, as `Leaf.read`'s)."""
        return self.read(self.params[name])

    def put(self, name: str, value: object) -> None:
        """Write the blackboard key named by key parameter `name`."""
        self.write(self.params[name], value)

    def fail(self, reason: str) -> Status:
        self.feedback_message = reason
        return Status.FAILURE

    def update(self) -> Status:
        try:
            return self.act()
        except EndpointSilent:
            raise
        except PegbtError as error:
            return self.fail(str(error))

    def act(self) -> Status:
        """One tick's work (instant leaves do everything here)."""
        raise NotImplementedError


class ComputeLeaf(RobotLeaf):
    """A leaf whose work is one computation off the tick: `inputs()` read on the tick, `compute(*inputs)` run
    on a worker thread (from its arguments alone), `finish(result)` on the tick that finds it done."""

    def initialise(self) -> None:
        self.job: Job | None = None
        self.feedback_message = ""

    def act(self) -> Status:
        if self.job is None:
            self.job = self.offload(self.compute, *self.inputs())
        if not self.job.done:
            self.feedback_message = "computing"
            return Status.RUNNING
        return self.finish(self.job.result())

    def inputs(self) -> tuple[Any, ...]:
        raise NotImplementedError

    def compute(self, *inputs: Any) -> Any:
        raise NotImplementedError

    def finish(self, result: Any) -> Status:
        raise NotImplementedError


@dataclass
class Outgoing:
    """A motion `begin()` asked for, to send once planned: an arm's trajectory (or the planning that makes
    it) or a jaw's target angle."""

    what: str
    arm: str
    trajectory: Trajectory | Callable[[], Trajectory] | None = None
    jaw_angle: float | None = None
    inputs: tuple[object, ...] | None = None  # what the trajectory is planned from, to take a plan made early
    before_end: float | None = None  # a jaw motion sent this long before the arm motion's planned end


@dataclass
class Running:
    """A motion this leaf started: what it is, its handle, how to stop it."""

    what: str
    handle: MotionHandle
    stop: Callable[[], None]
    jaw: str = ""  # the arm whose jaw this motion moves ("": an arm motion)


class MotionLeaf(RobotLeaf):
    """A leaf whose work is motions: `begin()` starts them with `move`/`move_jaw`; `done()` judges the result."""

    may_step_back = True  # False for motions that carry a block: withdrawing would drag it off its peg

    def initialise(self) -> None:
        self.running: list[Running] = []
        self.problem: str | None = None
        self.feedback_message = ""
        self.expected_end: float | None = None
        self.wake_at: float | None = None
        self.wake_when: Callable[[], bool] | None = None
        self.blocked_since: float | None = None
        self.blocked_plans: list[Prepared | None] | None = None  # what was not sent for the other arm
        self.stepping_back: Running | None = None
        self.stepped_back = False
        self.job: Job | None = None
        self.replans = 0
        self.early_at: int | None = None  # where a plan made early stands among the motions
        self.arm_end: float | None = None  # when the arm motion sent last is planned to end
        self.pending_jaws: list[Outgoing] = []  # jaw motions due before that end (`move_jaw(before_end=)`)
        self._start()

    def _start(self) -> None:
        """Plan (`begin`) on the tick and leave the heavy part to a worker (`_send` picks it up); a leaf with
        only jaw motions sends them at once."""
        self.outgoing: list[Outgoing] = []
        try:
            self.begin()
        except EndpointSilent:
            raise
        except PegbtError as error:
            self.problem = str(error)
            self.halt_motions()
            return
        self.pending_jaws = [outgoing for outgoing in self.outgoing if outgoing.before_end is not None]
        self.outgoing = [outgoing for outgoing in self.outgoing if outgoing.before_end is None]
        arms = [outgoing for outgoing in self.outgoing if outgoing.trajectory is not None]
        if not arms:
            self._send([None] * len(self.outgoing))
            return
        for outgoing in arms:
            self.motion(outgoing.arm).start_from(self.client(outgoing.arm))  # after a failure: from here
        if self._take_sent(arms):
            return
        if self._stop_sent_ahead(arms):
            self._start()
            return
        early = self._early()
        if early is not None:
            self.job = self.adopt(early)
        else:
            self.job = self.offload(
                prepare_all,
                [
                    None if o.trajectory is None else self.motion(o.arm).preparation(o.trajectory)
                    for o in self.outgoing
                ],
            )
        if self.job.done:  # computed in this tick (lockstep): send now, as a later tick would
            self._pick_up()

    def _take_sent(self, arms: list[Outgoing]) -> bool:
        """Whether this leaf's one arm motion is already under way, sent ahead from its inputs by a leaf
        before it (`ArmMotion.send_ahead`): then it watches that motion as its own and sends its jaw
        motions, planning nothing."""
        outgoing = arms[0]
        if len(arms) != 1 or outgoing.inputs is None:
            return False
        client, motion = self.client(outgoing.arm), self.motion(outgoing.arm)
        sent = motion.take_sent(outgoing.inputs)
        if sent is None:
            return False
        self.running.append(Running(outgoing.what, sent.handle, lambda: motion.stop(client)))
        self.arm_end = sent.sent_at + sent.planned.duration
        self._expect(max(self.arm_end - self.context.clock.now(), 0.0))
        for jaw in self.outgoing:
            if jaw.trajectory is None:
                self._send_jaw(jaw)
        self.started([sent.planned])
        return True

    def _stop_sent_ahead(self, arms: list[Outgoing]) -> bool:
        """Whether it stopped an arm's motion under way that was sent ahead as another leaf's (a giver's way
        out into the approach of a grasp other than this approach's, a look after it): this leaf's plan
        starts where that motion ends, which the arm has not reached, and the arm refuses a plan that would
        make it jump there. Stopped, the arm is planned for again from where it stops."""
        stopped = False
        for outgoing in arms:
            motion = self.motion(outgoing.arm)
            if motion.sent_ahead():
                log.info("%s: stopping %s's motion sent ahead for another leaf", self.name, outgoing.arm)
                motion.stop(self.client(outgoing.arm))
                stopped = True
        return stopped

    def _early(self) -> Job | None:
        """The job of the plan made early for this leaf's one arm motion (beside jaw motions), if one was
        made from its inputs; its result, one plan, stands at that motion's place (`_pick_up`)."""
        self.early_at = None
        arms = [i for i, outgoing in enumerate(self.outgoing) if outgoing.trajectory is not None]
        inputs = self.outgoing[arms[0]].inputs if len(arms) == 1 else None
        job = None if inputs is None else self.motion(self.outgoing[arms[0]].arm).take_early(inputs)
        if job is not None:
            self.early_at = arms[0]
        return job

    def _stale(self, prepared: list[Prepared | None]) -> str | None:
        """Why a plan may not be sent as it is (made from a state the arm has left), or None."""
        for outgoing, ready in zip(self.outgoing, prepared):
            if ready is not None:
                why = self.motion(outgoing.arm).stale(ready, self.client(outgoing.arm))
                if why is not None:
                    return f"{outgoing.what}: {why}"
        return None

    def _send(self, prepared: list[Prepared | None]) -> None:
        """Send what `begin()` asked for, unless a plan is stale (then it is made again) or an arm motion
        would come too close to the other arm (then nothing is sent and the leaf waits)."""
        arm = self.param("arm")
        stale = self._stale(prepared)
        if stale is not None:
            self.replans += 1
            if self.replans > REPLANS:
                self.problem = f"{stale}, {REPLANS} plans in a row"
                return
            log.info("%s: planning again: %s", self.name, stale)
            self.feedback_message = f"planning again: {stale}"
            self._start()
            return
        self.replans = 0
        try:
            for outgoing, ready in zip(self.outgoing, prepared):
                if ready is not None:
                    self._check_clearance(outgoing, ready.planned)
            for outgoing, ready in zip(self.outgoing, prepared):
                if ready is None:
                    self._send_jaw(outgoing)
                else:
                    self._send_arm(outgoing, ready)
            self.blocked_since = self.skills.waiting[arm] = None
            self.started([ready.planned for ready in prepared if ready is not None])
        except Blocked as blocked:
            now = self.context.clock.now()
            if self.blocked_since is None:
                self.blocked_since = self.skills.waiting[arm] = now
            self.feedback_message = f"waiting: {blocked}"
            self.wake_at = now + BLOCKED_RETRY
            self.blocked_plans = prepared
        except EndpointSilent:
            raise
        except PegbtError as error:
            self.problem = str(error)
            self.halt_motions()

    def _pick_up(self) -> None:
        """The tick that finds the worker's plan done sends it (a planning error fails the leaf)."""
        job, self.job = self.job, None
        assert job is not None  # called when act() found it done
        try:
            prepared = job.result()
        except PegbtError as error:
            self.problem = str(error)
            self.halt_motions()
            return
        if self.early_at is not None:
            (plan,) = prepared
            prepared = [plan if i == self.early_at else None for i in range(len(self.outgoing))]
        self._send(prepared)

    def _wait_for_the_way(self) -> Status:
        """A tick while blocked by the other arm: step back (`_should_step_back`), try again, give up."""
        assert self.blocked_since is not None and self.wake_at is not None  # both set by `Blocked` in `_send`
        now = self.context.clock.now()
        if self.stepping_back is not None:
            if self.stepping_back.handle.failed:
                return self.fail(f"{self.stepping_back.what}: {self.stepping_back.handle.error}")
            if self.stepping_back.handle.busy:
                return Status.RUNNING
            self.stepping_back = None
        elif self._should_step_back():
            self._step_back()
            return Status.RUNNING
        if now - self.blocked_since > BLOCKED_PATIENCE:
            return self.fail(f"gave up after {BLOCKED_PATIENCE:g} s {self.feedback_message}")
        if now >= self.wake_at - 1e-9:
            self._try_again()
        return Status.RUNNING if self.problem is None else self.fail(self.problem)

    def _try_again(self) -> None:
        """Send the motions the other arm blocked: the same plans while this arm has not moved since
        (`_send` checks them as any plan, and plans anew if they are stale), not planned again each try."""
        plans, self.blocked_plans = self.blocked_plans, None
        if plans is None:
            self._start()
        else:
            self._send(plans)

    def _should_step_back(self) -> bool:
        """This arm gives way when the other arm waits too, and waited first (or as long), or when it has
        waited `LONE_PATIENCE` for an arm that waits for nothing: resting in its way, that arm may never move
        (a giver after its last handover, above the block the receiver lost)."""
        if not self.may_step_back or self.stepped_back:
            return False
        assert self.blocked_since is not None  # asked only while blocked
        others = [
            since
            for arm, since in self.skills.waiting.items()
            if arm != self.param("arm") and since is not None
        ]
        if others:
            return min(others) <= self.blocked_since
        return self.context.clock.now() - self.blocked_since >= LONE_PATIENCE

    def _step_back(self) -> None:
        """Withdraw the tool along its shaft by `STEP_BACK` (insertion only: away from everything around it),
        unless that brings it closer to the other arm's tool than it is (then it goes on waiting)."""
        arm = self.param("arm")
        client, motion = self.client(arm), self.motion(arm)
        start = motion.start_from(client)
        target = start.copy()
        target[2] = max(motion.settings.lower[2], start[2] - STEP_BACK)
        back = motion.through(start, [target], ["stepped back"])
        self.stepped_back = True
        gaps = self.skills.clearances(arm, back, self.context.clock.now(), self._other_setpoints(arm))
        if gaps.min() < gaps[0] - PARTING_SLACK:
            return
        waited = "both arms were waiting for each other"
        if not any(since is not None for name, since in self.skills.waiting.items() if name != arm):
            waited = f"the other arm has stayed in its way for {LONE_PATIENCE:g} s"
        handle = motion.send(client, back)
        self.stepping_back = Running(
            f"{arm} stepping back for the other arm", handle, lambda: motion.stop(client)
        )
        self.running.append(self.stepping_back)
        self.feedback_message = f"{arm} steps back along its shaft: {waited}"

    def begin(self) -> None:
        """Ask for this leaf's motions with `move` and `move_jaw` (runs on the tick: keep heavy planning in a
        function given to `move`)."""
        raise NotImplementedError

    def started(self, trajectories: list[Trajectory]) -> None:
        """Called once the arm trajectories (as planned, in `move` order) were sent; a subclass may report them."""

    def move(
        self,
        arm: str,
        trajectory: Trajectory | Callable[[], Trajectory],
        what: str,
        inputs: tuple[object, ...] | None = None,
    ) -> None:
        """Send a trajectory for `arm` (or the one a function plans, called on a worker thread: it must use
        its own inputs alone), pre-compensated by the condition's skills, unless it would bring the tools
        closer than `keep_apart` (then nothing is sent and the leaf waits). `inputs`: what it is planned
        from, so that a plan made early from the same inputs is taken instead (`ArmMotion.plan_early`)."""
        self.outgoing.append(Outgoing(what, arm, trajectory=trajectory, inputs=inputs))

    def move_jaw(self, arm: str, angle: float, what: str, before_end: float | None = None) -> None:
        """Move `arm`'s jaw to `angle`: at once, or `before_end` seconds before the arm motion of this leaf
        is planned to end (stalls included; in real time a little more, `_jaw_lead`), so that a jaw action
        overlaps the end of the arm's motion."""
        self.outgoing.append(Outgoing(what, arm, jaw_angle=angle, before_end=before_end))

    def _check_clearance(self, outgoing: Outgoing, trajectory: Trajectory) -> None:
        """`Blocked` if `trajectory`, starting now, would bring the tools closer than `keep_apart`, unless it
        only takes apart tools that already are (`parts`)."""
        arm = outgoing.arm
        keep_apart = self.params.get("keep_apart", 0.0)
        if keep_apart is None:
            keep_apart = self.default_keep_apart()
        if keep_apart > 0:
            gaps = self.skills.clearances(
                arm, trajectory, self.context.clock.now(), self._other_setpoints(arm)
            )
            if gaps.min() < keep_apart and not parts(gaps, keep_apart):
                start = f", {gaps[0] * 1000:.1f} mm at its start" if gaps[0] < keep_apart else ""
                raise Blocked(
                    f"{outgoing.what} would bring the tools within {gaps.min() * 1000:.1f} mm of each other "
                    f"(keep apart {keep_apart * 1000:.0f} mm{start})"
                )

    def _other_setpoints(self, arm: str) -> dict[str, Any]:
        """The joint set-points of every arm but `arm`: where the clearance checks take them to be."""
        return {name: other.setpoint_js.position for name, other in self.robot.arms.items() if name != arm}

    def default_keep_apart(self) -> float:
        """The `keep_apart` of a leaf given none: `two_arms.keep_apart` (skills/motion.yaml)."""
        return self.skills.motion.two_arms.keep_apart

    def _send_arm(self, outgoing: Outgoing, prepared: Prepared) -> None:
        client, motion = self.client(outgoing.arm), self.motion(outgoing.arm)
        handle = motion.dispatch(client, prepared)
        self.running.append(Running(outgoing.what, handle, lambda: motion.stop(client)))
        self._expect(prepared.planned.duration)
        self.arm_end = self.context.clock.now() + prepared.planned.duration

    def _send_jaw(self, outgoing: Outgoing) -> None:
        """Send a jaw motion; it takes over from this leaf's earlier one on that jaw, which stops tracking."""
        self.running = [motion for motion in self.running if motion.jaw != outgoing.arm]
        jaw = self.client(outgoing.arm).jaw
        angle = outgoing.jaw_angle
        assert angle is not None
        seconds = (
            abs(angle - float(jaw.setpoint_js.position[0])) / self.motion(outgoing.arm).settings.jaw_velocity
        )
        handle = jaw.move_jp(angle)
        self.running.append(Running(outgoing.what, handle, handle.stop, jaw=outgoing.arm))
        self._expect(seconds)

    def _expect(self, seconds: float) -> None:
        """Note that a motion of `seconds` started: the runner need not tick this leaf before it ends."""
        end = self.context.clock.now() + seconds
        self.expected_end = end if self.expected_end is None else max(self.expected_end, end)

    def act(self) -> Status:
        self.wake_when = None
        if self.job is not None:
            if not self.job.done:
                self.wake_at = None
                return Status.RUNNING
            self._pick_up()
            if self.job is not None:  # the plan was stale: planning again
                self.wake_at = None
                return Status.RUNNING
        if self.problem is not None:
            return self.fail(self.problem)
        if self.blocked_since is not None:
            return self._wait_for_the_way()
        for motion in self.running:
            if motion.handle.failed:
                self.halt_motions()
                return self.fail(f"{motion.what}: {motion.handle.error}")
        if any(motion.handle.busy for motion in self.running):
            now = self.context.clock.now()
            paused = max(motion.handle.paused for motion in self.running)
            if self.expected_end is not None and now > self.expected_end + paused + MOTION_OVERTIME:
                late = next(motion for motion in self.running if motion.handle.busy)
                self.halt_motions()
                stalls = f" and {paused:.1f} s of stalls" if paused else ""
                return self.fail(
                    f"{late.what}: no end reported {MOTION_OVERTIME:g} s after its planned end{stalls}"
                )
            ahead = self.expected_end is not None and now < self.expected_end
            self.wake_at = self.expected_end if ahead else None
            self.wake_when = None if ahead else self._motions_over
            self._send_timed_jaws(now, paused)
            return self.watch()
        self.wake_at = self.wake_when = None
        if self.arm_end is not None and self.pending_jaws:  # the arm ended before they were due
            for outgoing in self.pending_jaws:
                self._send_jaw(outgoing)
            self.pending_jaws = []
            return Status.RUNNING
        return self.done()

    def _send_timed_jaws(self, now: float, paused: float) -> None:
        """Send the jaw motions due before the arm motion's end; ask to be ticked when the next one is due
        (in real time also as soon as it is, not on the tree's next period)."""
        if self.arm_end is None or not self.pending_jaws:
            return
        for outgoing in list(self.pending_jaws):
            at = self.arm_end + paused - self._jaw_lead(outgoing)
            if now >= at - 1e-9:
                self.pending_jaws.remove(outgoing)
                self.jaw_due(outgoing)
                self._send_jaw(outgoing)
                continue
            if self.wake_at is not None:
                self.wake_at = min(self.wake_at, at)
            if is_realtime(self.context.clock):
                self.wake_when = partial(_reached, self.context.clock, at, self.wake_when)

    def _jaw_lead(self, outgoing: Outgoing) -> float:
        """How long before the arm motion's end a jaw motion given `before_end` is sent. In real time, for
        a jaw meant to end as the arm does (`before_end` its ramp's length): a robot plays the ramp on the
        control period's ticks, the arm's last row on one of them, the jaw's last row on the first tick at
        or after `before_end`, and the jaw is done once the robot says its set-point is there, a state
        message later (the arm once it is within a step of its end, at once). So it is sent that many
        whole periods and `JAW_AHEAD` more ahead, and is done by the time the arm is: sent `before_end`
        ahead, it ended up to a period after the arm, and the leaf waited 20-30 ms for it. A jaw timed to
        pass an angle on its way as the arm arrives (a close meeting a wall) keeps `before_end`."""
        assert outgoing.before_end is not None and outgoing.jaw_angle is not None  # a timed jaw motion
        if not is_realtime(self.context.clock):
            return outgoing.before_end
        settings = self.motion(outgoing.arm).settings
        angle = float(self.client(outgoing.arm).jaw.setpoint_js.position[0])
        ramp = abs(outgoing.jaw_angle - angle) / settings.jaw_velocity
        period = settings.control_period
        if abs(ramp - outgoing.before_end) > period / 2:
            return outgoing.before_end
        return period * (math.ceil(outgoing.before_end / period - 1e-9) + JAW_AHEAD)

    def jaw_due(self, outgoing: Outgoing) -> None:
        """Called as a jaw motion given `before_end` is about to be sent; a subclass may read the jaw first."""

    def _motions_over(self) -> bool:
        """Whether a tick would find no motion of this leaf busy any more (the runner ticks at once then,
        not a period later); a motion whose state cannot be read is the tick's to report."""
        try:
            return bool(self.running) and not any(motion.handle.busy for motion in self.running)
        except PegbtError:
            return True

    def watch(self) -> Status:
        """Called on ticks while motions run; a subclass may fail early (a slipping block) and may ask to be
        ticked sooner by lowering `wake_at`."""
        return Status.RUNNING

    def done(self) -> Status:
        """Called once every motion finished; SUCCESS unless a subclass checks otherwise."""
        return Status.SUCCESS

    def update(self) -> Status:
        status = super().update()
        if status == Status.FAILURE:
            self.halt_motions()
        return status

    def terminate(self, new_status: Status) -> None:
        if getattr(self, "blocked_since", None) is not None:
            self.skills.waiting[self.param("arm")] = None
        if new_status == Status.INVALID:
            self.halt_motions()

    def halt_motions(self) -> None:
        """Stop every motion still running; an unreachable endpoint is logged (there is nothing left to stop)."""
        for motion in getattr(self, "running", []):
            try:
                if motion.handle.busy:
                    motion.stop()
            except PegbtError as error:
                log.warning("%s: could not stop %s: %s", self.name, motion.what, error)
        self.running = []


def parts(gaps: NDArray[np.float64], keep_apart: float) -> bool:
    """Whether a motion along which the tools are `gaps` apart (m, from its start to its end) only takes
    them apart: it starts closer than `keep_apart`, never brings them closer than they start, and ends
    `keep_apart` apart. Two tools that met (a handover) or stopped close (a step of either cut short) are
    let out that way; held to `keep_apart` from their start, neither could be sent anything, even away, and
    each would wait `BLOCKED_PATIENCE` in turn."""
    return bool(gaps[0] < keep_apart and gaps.min() >= gaps[0] - PARTING_SLACK and gaps[-1] >= keep_apart)


def _reached(clock: Clock, at: float, then: Callable[[], bool] | None) -> bool:
    """Whether `clock` reached `at` (a timed jaw motion is due) or `then` holds."""
    return clock.now() >= at or (then is not None and then())
