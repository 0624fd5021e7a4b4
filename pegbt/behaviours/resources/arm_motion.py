"""`ArmMotion`: one arm's motions under the run's condition: plan, pre-compensate every row, send, and
remember where the arm is meant to be.

Plans are made in *desired* joints (where the tool should physically be). With a calibration model every
row of a planned trajectory is pre-compensated (the paper's Alg. 1, one 10 ms step at a time) before the
trajectory is sent, so the arm receives the commands that land it on the plan; without one the plan is
sent as it is. The next plan starts where the last one was meant to end (`desired`), not at the encoders,
which read the compensated command.

Planning and pre-compensation are the heavy part of a motion (tens of milliseconds); `prepare` does them
off the tick (`MotionLeaf` runs it on a worker thread) on a fork of the compensator, touching nothing
shared, and `dispatch`, on the tick, sends the result and makes it this arm's state. Planning holds the
arm's lock: the SQP refiner is one OSQP problem per arm.

A motion may also be planned early, while the one before it plays (`plan_early`: the transfer's carry
once its grasp is chosen), from where that one will end. Every plan, early or not, is checked against the
arm as it is when it is sent (`stale`): made from the arm's state of now (`epoch`: no motion sent,
stopped or aborted since), with the arm's set-point where the last command left it (within one control
period's step at the velocity limits, what the robot itself accepts as a trajectory's start). A plan that
fails the check is made again from the arm's measured state, never sent. A motion that failed (refused,
aborted by a late hold) leaves no trace: the next plan starts from where the arm is, not from the end
that motion never reached.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.calibration.compensation import Compensator
from pegbt.errors import PegbtError
from pegbt.executive.work import Job, WorkPool
from pegbt.motion.cubic import rest_to_rest_path
from pegbt.motion.kinematics import tip_position
from pegbt.motion.limits import ArmSettings
from pegbt.motion.quickest import quickest_through
from pegbt.motion.trajectory import Trajectory
from pegbt.motion.transfer import TransferPlanner, cubic_transfer
from pegbt.motion.waypoints import TransferWaypoints
from pegbt.transport import ArmClient, MotionHandle, guards

log = logging.getLogger("pegbt.behaviours")


@dataclass(frozen=True)
class SentMotion:
    """A trajectory on its way: what was planned, what was sent, its handle, and when it was sent."""

    planned: Trajectory
    sent: Trajectory
    handle: MotionHandle
    sent_at: float

    def joints_at(self, times: NDArray[np.float64]) -> NDArray[np.float64]:
        """Planned joints (len(times), 6) at clock `times`; before the start and after the end, its ends."""
        rows = np.rint((times - self.sent_at) / self.planned.period).astype(int)
        return self.planned.q[np.clip(rows, 0, len(self.planned) - 1)]


@dataclass(frozen=True)
class Prepared:
    """A trajectory ready to send: as planned, as it will be commanded (pre-compensated), and the arm's
    compensator as it will be once those commands are issued (None without calibration)."""

    planned: Trajectory
    sent: Trajectory
    compensator: Compensator | None
    epoch: int = -1  # the arm's state it was made from (`ArmMotion.epoch`)


@dataclass(frozen=True)
class EarlyResult:
    """A computation started before the leaf that needs it asks for it (a handover's meeting, while the
    giver approaches its block), with the inputs it was started from (compared by identity: a block seen
    again is another object; poses by value)."""

    inputs: tuple[object, ...]
    job: Job[Any]

    def matches(self, inputs: tuple[object, ...]) -> bool:
        return same_inputs(inputs, self.inputs)


@dataclass(frozen=True)
class EarlyPlan(EarlyResult):
    """A motion being prepared before its leaf asks for it: the inputs it was planned from, the job
    preparing it, and the arm's state it was planned from (`ArmMotion.epoch`)."""

    job: Job[list[Prepared | None]]
    epoch: int


def same_inputs(a: tuple[object, ...], b: tuple[object, ...]) -> bool:
    """Whether two plans were made from the same inputs (`_same`, one by one)."""
    return len(a) == len(b) and all(map(_same, a, b))


def _same(a: object, b: object) -> bool:
    """The same input: the same object, equal numbers and names (a peg, an arm), or equal poses (a
    meeting tip computed again from the same settings)."""
    if a is b:
        return True
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
        return a.shape == b.shape and bool(np.array_equal(a, b))
    return isinstance(a, int | float | str) and type(a) is type(b) and a == b


def prepare_all(preparations: list[Callable[[], Prepared] | None]) -> list[Prepared | None]:
    """On a worker: each arm trajectory planned and pre-compensated (None for a jaw motion)."""
    return [None if prepare is None else prepare() for prepare in preparations]


class ArmMotion:
    """Plans and sends one arm's motions; `planner` (SQP) and `compensator` are None when the condition has none."""

    def __init__(
        self,
        settings: ArmSettings,
        *,
        planner: TransferPlanner | None = None,
        compensator: Compensator | None = None,
    ) -> None:
        self.settings = settings
        self.planner = planner
        self.compensator = compensator
        self.desired: NDArray[np.float64] | None = None
        self.active: SentMotion | None = None
        self.fallbacks = 0  # optimised plans that fell back to cubics
        self.plans = 0  # trajectories sent
        self.tip_path = 0.0  # m: length of the planned tool-tip paths sent
        self.epoch = 0  # changes whenever a plan's start changes: a motion sent, stopped or aborted
        self.commanded: NDArray[np.float64] | None = None  # the set-point the last command leaves
        self.early: EarlyPlan | None = None
        # the motion under way sent ahead of the leaf it belongs to, and that leaf's inputs (`send_ahead`)
        self.ahead: tuple[tuple[object, ...], SentMotion] | None = None
        # the next handover's meeting, this arm receiving, computed early
        self.meeting: EarlyResult | None = None
        self._planning = threading.Lock()

    def start_from(self, arm: ArmClient) -> NDArray[np.float64]:
        """Where the next plan starts: where the last one ended, or (first use) where the arm is now: its
        set-point, or with a calibration model, where the model says that set-point puts the tool (so the
        first compensated command continues from the set-point instead of jumping). After a motion that
        failed, where the arm is now, as on first use."""
        if self.active is not None and self.active.handle.failed:
            self.forget()
        if self.desired is None:
            setpoint = np.array(arm.setpoint_js.position, dtype=float)
            self.desired, self.commanded = setpoint, setpoint.copy()
            self.epoch += 1
            if self.compensator is not None:
                self.compensator.reset(setpoint)
                self.desired = self.settings.require_within(
                    self.compensator.model.forward(setpoint, self.compensator.state),
                    f"{arm.name} as the model sees it",
                )
        return self.desired.copy()

    # ------------------------------------------------------------------ planning
    def transfer(self, waypoints: TransferWaypoints, *, above_clear: float | None = None) -> Trajectory:
        """The transfer through `waypoints`: with a planner, its checked plan (the SQP-refined spline, or
        the first of spline and cubics that passes the checks); rest-to-rest cubics without one, or, with
        a warning, when no plan passes the checks. Each plan that is not the SQP's is logged with the
        reason, and counted in `fallbacks` if it is the cubics."""
        if self.planner is not None:
            try:
                with self._planning:
                    plan = self.planner.plan(waypoints, above_clear=above_clear)
            except PegbtError as error:
                self.fallbacks += 1
                log.warning(
                    "%s: no optimised plan (%s); using rest-to-rest cubics", self.settings.name, error
                )
            else:
                if plan.method == "cubic":
                    self.fallbacks += 1
                if not plan.refined:
                    log.warning(
                        "%s: transfer planned by the %s (%s)", self.settings.name, plan.method, plan.reason
                    )
                return plan.trajectory
        return cubic_transfer(waypoints, self.settings)

    def through(self, start: ArrayLike, joints: list[NDArray[np.float64]], names: list[str]) -> Trajectory:
        """Rest-to-rest cubics from `start` through joint `joints` (each stop named for errors)."""
        path = rest_to_rest_path([np.asarray(start, dtype=float), *joints], self.settings, ["start", *names])
        return path.sample(self.settings.control_period)

    def quickest(self, start: ArrayLike, joints: list[NDArray[np.float64]], names: list[str]) -> Trajectory:
        """Time-optimal rest-to-rest moves on the same joint lines as `through` (a handover's short moves)."""
        return quickest_through([np.asarray(start, dtype=float), *joints], self.settings, ["start", *names])

    # ------------------------------------------------------------------ execution
    def commands(self, planned: Trajectory, compensator: Compensator | None) -> Trajectory:
        """The trajectory to send for `planned`: every row pre-compensated by `compensator` (which it
        advances), or `planned` itself without one."""
        if compensator is None:
            return planned
        q = compensator.trajectory(planned.q)
        qd = np.gradient(q, planned.t, axis=0)
        qd[[0, -1]] = 0.0
        return Trajectory(planned.t, q, qd, np.gradient(qd, planned.t, axis=0))

    def joints_at(self, times: NDArray[np.float64], resting: NDArray[np.float64]) -> NDArray[np.float64]:
        """Where this arm is meant to be at clock `times`: along its motion, or at rest where the last one
        ended (`resting`, the arm's set-point, if it has not moved in this run)."""
        if self.active is not None:
            return self.active.joints_at(times)
        at = resting if self.desired is None else self.desired
        return np.repeat(np.asarray(at, dtype=float)[None], len(times), axis=0)

    def preparation(self, planned: Trajectory | Callable[[], Trajectory]) -> Callable[[], Prepared]:
        """The preparation of `planned` (see `prepare`) from the arm's state of now, to run on a worker:
        the compensator is forked here, on the tick, so that the worker shares nothing that changes."""
        compensator = None if self.compensator is None else self.compensator.fork()
        return partial(self._prepare, planned, compensator, self.epoch)

    def prepare(self, planned: Trajectory | Callable[[], Trajectory]) -> Prepared:
        """`planned` (or the trajectory it plans, when it is the planning still to do), pre-compensated on a
        fork of the compensator: nothing shared changes until `dispatch`."""
        return self.preparation(planned)()

    def _prepare(
        self, planned: Trajectory | Callable[[], Trajectory], compensator: Compensator | None, epoch: int
    ) -> Prepared:
        trajectory = planned() if callable(planned) else planned
        return Prepared(trajectory, self.commands(trajectory, compensator), compensator, epoch)

    def plan_early(
        self, pool: WorkPool, inputs: tuple[object, ...], planned: Callable[[], Trajectory]
    ) -> None:
        """Start preparing the motion that follows the one just sent, from where that one ends, while it
        plays; its leaf takes it with `take_early(inputs)`. One already under way from the same inputs
        and the same state of the arm is kept. Not in lockstep (`pool.inline`), where computing takes no
        time and there is nothing to hide."""
        if self.early is not None and self.early.epoch == self.epoch and self.early.matches(inputs):
            return
        self.discard_early()
        if not pool.inline:
            job = pool.submit_ahead(prepare_all, [self.preparation(planned)])
            self.early = EarlyPlan(inputs, job, self.epoch)

    def take_early(self, inputs: tuple[object, ...]) -> Job[list[Prepared | None]] | None:
        """The job preparing the motion planned early from `inputs`, if it was (else None; a plan early
        from other inputs is discarded)."""
        early, self.early = self.early, None
        if early is None or not early.matches(inputs):
            if early is not None:
                early.job.discard()
            return None
        return early.job

    def adopt_early(self, inputs: tuple[object, ...], job: Job[list[Prepared | None]]) -> None:
        """Make `job` (its plan made early under other inputs, now known to be for `inputs`) the plan made
        early for `inputs`, from the arm's state it was made from (its `stale` check stands)."""
        self.discard_early()
        self.early = EarlyPlan(inputs, job, self.epoch)

    def send_ahead(self, inputs: tuple[object, ...]) -> None:
        """The motion just sent is also the motion of a leaf still to come, made from `inputs` (a giver's
        way out of the block it handed over, on into the approach of its next pick): that leaf takes it
        (`take_sent`) instead of planning another."""
        assert self.active is not None  # called as a motion is sent
        self.ahead = (inputs, self.active)

    def take_sent(self, inputs: tuple[object, ...]) -> SentMotion | None:
        """The motion sent ahead from `inputs`, if it is still this arm's motion (else None; one sent ahead
        from other inputs stays known as such while it plays, `sent_ahead`)."""
        playing = self.sent_ahead()
        ahead, self.ahead = self.ahead, None
        if ahead is None or ahead[1] is not self.active or ahead[1].handle.failed:
            return None
        if not same_inputs(ahead[0], inputs):
            self.ahead = ahead if playing else None
            return None
        return ahead[1]

    def sent_ahead(self) -> bool:
        """Whether the arm's motion under way was sent ahead as the motion of a leaf still to come."""
        return self.ahead is not None and self.ahead[1] is self.active and self.ahead[1].handle.busy

    def discard_early(self) -> None:
        if self.early is not None:
            self.early.job.discard()
            self.early = None

    def stale(self, prepared: Prepared, arm: ArmClient) -> str | None:
        """Why `prepared` may not be sent as it is (None: it may): the arm's state changed since it was
        made, or the arm's set-point is not where the last command left it (then the next plan starts
        from where it is)."""
        self.start_from(arm)  # forgets a failed motion
        if prepared.epoch != self.epoch:
            return "the arm's last motion changed while this one was planned"
        if self.active is not None and self.active.handle.busy:
            return None  # it replaces the motion under way, from the end planned for it
        assert self.commanded is not None  # set with `desired` by `start_from`
        setpoint = np.asarray(arm.setpoint_js.position, dtype=float)
        problems = guards.step_problems(setpoint, self.commanded, self.settings, self.settings.control_period)
        if problems:
            self.forget()
            return f"the arm is not where its last command left it ({'; '.join(problems)})"
        return None

    def forget(self) -> None:
        """The arm is not where the last plan ended: the next plan starts from where it is."""
        self.active = self.desired = self.commanded = None
        self.epoch += 1
        self.discard_early()

    def send(self, arm: ArmClient, planned: Trajectory) -> MotionHandle:
        """Prepare and send `planned` at once (a short motion, on the tick)."""
        return self.dispatch(arm, self.prepare(planned))

    def dispatch(self, arm: ArmClient, prepared: Prepared) -> MotionHandle:
        """Send `prepared` to `arm`; afterwards the arm is meant to be at its last row."""
        planned = prepared.planned
        start = self.start_from(arm)
        if np.max(np.abs(planned.q[0] - start)) > 1e-6:
            raise PegbtError(
                f"{arm.name}: the plan starts {np.round(planned.q[0] - start, 4).tolist()} away from "
                "where the last motion ended",
                field="trajectory",
            )
        try:
            handle = arm.move_jp(prepared.sent)
        except PegbtError:
            self.forget()
            raise
        if prepared.compensator is not None:
            self.compensator = prepared.compensator
        self.active = SentMotion(planned, prepared.sent, handle, arm.clock.now())
        self.desired, self.commanded = planned.q[-1].copy(), prepared.sent.q[-1].copy()
        self.epoch += 1
        self.discard_early()
        self.plans += 1
        self.tip_path += float(np.linalg.norm(np.diff(tip_position(planned.q), axis=0), axis=1).sum())
        return handle

    def stop(self, arm: ArmClient) -> None:
        """Stop the active motion where it is. No plan ended there, and the set-point read now may be a
        step behind the one the arm holds, so the next plan starts where the arm is then, as on first use."""
        self.discard_early()
        active, self.active = self.active, None
        if active is None or not active.handle.busy:
            return
        active.handle.stop()
        self.forget()
