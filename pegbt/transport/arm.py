"""`ArmClient`: one PSM and its jaw as a behaviour sees them, over CRTK topics.

Reads (`measured_js`, `setpoint_js`, ...) return the latest sample and raise `EndpointSilent` once the
arm has not published `measured_js` for `liveness_timeout` seconds (a real arm streams at 100 Hz; a
simulator on a busy machine can fall behind, and a lockstep one sends nothing while it computes a step,
so it gets more slack). Commands are checked before they leave (NaN, size, joint and velocity
limits: `CommandRefused`) and are never sent into the void: the endpoint must be alive and listening.
`move_jp` returns at once with a `MotionHandle` that later ticks poll; the endpoint reports the fate of
each command (accepted, refused, done, aborted) tagged with its id.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from enum import Enum
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.clock import Clock, WallClock
from pegbt.errors import PegbtError
from pegbt.motion.limits import ArmSettings, arm_settings
from pegbt.psm import JOINT_LABELS
from pegbt.transport import codec, guards
from pegbt.transport.clock import SimClock
from pegbt.transport.codec import JointSample, OperatingState, TrajectoryLike
from pegbt.transport.keys import ArmKeys
from pegbt.transport.link import EndpointSilent, Link
from pegbt.transport.sequencing import Inlet, Outlet, Received, Tag

ARM_JOINT_NAMES = tuple(f"outer_{label}" for label in JOINT_LABELS)  # as the dVRK's joint states name them
JAW_JOINT_NAMES = ("jaw",)
STATE_COMMANDS = ("enable", "disable", "home", "unhome")
FIRST_SAMPLE_TIMEOUT = 1.0  # s to wait for the first sample of a topic subscribed on first use


class ArmFaulted(EndpointSilent):
    """The robot put an arm in FAULT (a tracking error, an amplifier fault) and holds it there: the dVRK leaves
    FAULT only when a person disables and enables it (`prmOperatingState.cpp`), so, as for a silent
    endpoint, no recovery in a tree applies and the run halts."""


class ArmLeftReady(EndpointSilent):
    """An arm the run had enabled and homed is no longer both (disabled or paused from the robot's console,
    unhomed, its tool removed, or disabled by the robot after an error): the robot drops every command until
    a person makes it ready again, so, as for a FAULT, no recovery in a tree applies and the run halts."""


def check_recent(
    arm: str, topic: str, received_at: float | None, timeout: float, who: str, now: float | None = None
) -> None:
    """Raise `EndpointSilent` unless `topic` (an arm's `measured_js`) arrived within `timeout` s of `now`
    (monotonic, default now; `received_at` None: never); `who` is what went silent (an endpoint, a robot)."""
    if received_at is None:
        raise EndpointSilent(f"{arm}: no {topic} received yet", field=topic)
    age = (time.monotonic() if now is None else now) - received_at
    if age > timeout:
        raise EndpointSilent(
            f"{arm}: {who} silent, no {topic} for {age:.3f} s (liveness timeout {timeout} s)", field=topic
        )


def is_recent(received_at: float | None, timeout: float, now: float | None = None) -> bool:
    """Whether a message received at monotonic `received_at` (None: never) is at most `timeout` s old at
    monotonic `now` (default now)."""
    return received_at is not None and (time.monotonic() if now is None else now) - received_at <= timeout


class MotionStatus(str, Enum):
    BUSY = "busy"
    DONE = "done"
    FAILED = "failed"


class StatusFlags:
    """`busy`, `done` and `failed` of a motion handle, read from the `status` it computes."""

    @property
    def status(self) -> MotionStatus:
        raise NotImplementedError

    @property
    def busy(self) -> bool:
        return self.status is MotionStatus.BUSY

    @property
    def done(self) -> bool:
        return self.status is MotionStatus.DONE

    @property
    def failed(self) -> bool:
        return self.status is MotionStatus.FAILED

    @property
    def paused(self) -> float:
        """Seconds the motion stood still on the way (its streamer not scheduled): it ends that much later."""
        return 0.0


class _Outcomes:
    """The fate of each command, as the endpoint reports it on operating_state and error (thread-safe)."""

    def __init__(self) -> None:
        self._outcomes: dict[str, tuple[str, str]] = {}
        self._lock = threading.Lock()

    def record(self, cause: str, outcome: str, text: str = "") -> None:
        if cause and outcome != "accepted":
            with self._lock:
                self._outcomes.setdefault(cause, (outcome, text))

    def of(self, cause: str) -> tuple[str, str] | None:
        with self._lock:
            return self._outcomes.get(cause)


class MotionHandle(StatusFlags):
    """A motion in progress: poll `status` (busy, done, failed) in later ticks, or `stop()` it."""

    def __init__(self, axis: _Axis, command_id: str, sent_at: float, what: str) -> None:
        self._axis = axis
        self.command_id = command_id
        self.sent_at = sent_at
        self.what = what
        self.error: str | None = None

    @property
    def status(self) -> MotionStatus:
        """Raises `EndpointSilent` while still undecided if the endpoint went quiet."""
        if self.error is not None:
            return MotionStatus.FAILED
        outcome = self._axis.outcomes.of(self.command_id)
        if outcome is not None:
            kind, text = outcome
            if kind == "done":
                return MotionStatus.DONE
            self.error = f"{self.what} {kind}" + (f": {text}" if text else "")
            return MotionStatus.FAILED
        state = self._axis.arm_state()
        if state.tag is None and state.value.stamp > self.sent_at and not state.value.is_busy:
            return MotionStatus.DONE  # an untagged endpoint (a real dVRK behind a bridge): CRTK's own rule
        return MotionStatus.BUSY

    def stop(self) -> None:
        """Hold at the current set-point (a servo command preempts the motion); the handle then fails."""
        if self.status is MotionStatus.BUSY:
            self._axis.hold(stopping=self.command_id)
            self.error = f"{self.what} stopped by the client"


class _Axis:
    """Joint-space reads and commands shared by the arm (6 joints) and its jaw (1 joint)."""

    def __init__(
        self,
        arm: ArmClient,
        measured_key: str,
        setpoint_key: str,
        servo_key: str,
        move_key: str,
        names: tuple[str, ...],
        problems: Callable[[NDArray[np.float64]], list[str]],
        step_problems: Callable[[NDArray[np.float64], NDArray[np.float64]], list[str]],
    ) -> None:
        link = arm.link
        self._arm = arm
        self.outcomes: _Outcomes = arm.outcomes
        self._names = names
        self._problems = problems
        self._step_problems = step_problems
        self._measured: Inlet[JointSample] = link.inlet(measured_key, codec.decode_joint_state)
        self._setpoint: Inlet[JointSample] = link.inlet(setpoint_key, codec.decode_joint_state)
        self._servo = link.outlet(servo_key)
        self._move = link.outlet(move_key)
        self._hold = link.outlet(servo_key.rsplit("/", 1)[0] + "/hold")
        self._last_servo: tuple[float, NDArray[np.float64]] | None = None

    @property
    def measured_js(self) -> JointSample:
        return self._arm.read(self._measured)

    @property
    def setpoint_js(self) -> JointSample:
        return self._arm.read(self._setpoint)

    def arm_state(self) -> Received[OperatingState]:
        return self._arm.state_received()

    def servo_jp(self, q: ArrayLike) -> None:
        """Stream one set-point for the next control period; it must be within velocity limits of the last."""
        q = np.asarray(q, dtype=float).reshape(-1)
        problems = self._problems(q) or self._step_problems(q, self._servo_reference())
        if problems:  # described only when refused: a 100 Hz stream should not format every set-point
            guards.refuse_if(problems, f"set-point {np.round(q, 5).tolist()}", self._servo.key)
        stamp = self._arm.clock.now()
        self._arm.send(self._servo, codec.encode_joint_state(stamp, q, names=self._names))
        self._last_servo = (stamp, q)

    def _servo_reference(self) -> NDArray[np.float64]:
        """Where the endpoint's set-point is: our last servo command, unless a later set-point was reported."""
        setpoint = self.setpoint_js
        if self._last_servo is not None and self._last_servo[0] > setpoint.stamp:
            return self._last_servo[1]
        return setpoint.position

    def move_goal(self, goal: ArrayLike) -> MotionHandle:
        goal = np.asarray(goal, dtype=float).reshape(-1)
        what = f"goal {np.round(goal, 5).tolist()}"
        guards.refuse_if(self._problems(goal), what, self._move.key)
        return self._start(
            self._move, codec.encode_joint_state(self._arm.clock.now(), goal, names=self._names), what
        )

    def _start(self, outlet: Outlet, payload: bytes, what: str) -> MotionHandle:
        sent_at = self._arm.clock.now()
        tag = self._arm.send(outlet, payload)
        return MotionHandle(self, tag.command_id(outlet.key), sent_at, what)

    def hold(self, stopping: str = "") -> None:
        """Stop where the endpoint's set-point is now. The endpoint's own `hold` when it has one: a servo
        at the last `setpoint_js` received is a step from where the set-point was a tick or two ago,
        which in a fast move the endpoint's velocity guard refuses, and the arm travels on.

        `stopping`: the id of the motion to stop, named in the hold's tag. Zenoh keeps no order across
        keys, so a hold may reach the endpoint after the next `move_jp` sent on its heels; an endpoint
        that reads the tag (the simulator) then leaves that later motion be. Untagged, it stops anything."""
        if self._hold.matched:
            self._arm.send(self._hold, codec.encode_empty(), cause=stopping)
        else:
            self.servo_jp(self.setpoint_js.position)


class JawClient(_Axis):
    """The jaw of a PSM: `measured_js`, `setpoint_js`, `servo_jp(angle)`, `move_jp(angle)`."""

    def move_jp(self, angle: float) -> MotionHandle:
        return self.move_goal([angle])


# s without `measured_js` before an arm counts as silent. A simulator that dies is caught at once by its
# clock (no step reply, no connection); for it this is a backstop as long as a slow step on a busy machine
# (a camera capture took over 1 s at load 6, and a trial failed on a 1 s timeout).
LIVENESS_S = {"simulator": 5.0, "robot": 0.2}


class ArmClient(_Axis):
    """One PSM over CRTK topics; `jaw` is its jaw with the same verbs."""

    def __init__(
        self,
        link: Link,
        arm: str,
        *,
        clock: Clock | None = None,
        liveness_timeout: float | None = None,
        settings: ArmSettings | None = None,
        cartesian: bool = False,
    ) -> None:
        """`liveness_timeout` defaults to the clock's kind of endpoint (`LIVENESS_S`); `cartesian=True` also
        subscribes to `measured_cp` (the endpoint computes it only for listeners)."""
        self.link = link
        self.name = arm
        self.keys = ArmKeys(arm, link.namespace)
        self.clock: Clock = clock or WallClock()
        if liveness_timeout is None:
            liveness_timeout = LIVENESS_S["simulator" if isinstance(self.clock, SimClock) else "robot"]
        self.liveness_timeout = liveness_timeout
        self.settings = settings or arm_settings(arm)
        self.outcomes = _Outcomes()
        period = self.settings.control_period
        self._state: Inlet[OperatingState] = link.inlet(
            self.keys.operating_state, codec.decode_operating_state, self._on_state
        )
        self._error: Inlet[str] = link.inlet(self.keys.error, codec.decode_string, self._on_error)
        self._fiducial: Inlet[JointSample] | None = None  # subscribed on first use: only calibration reads it
        self._cartesian = link.inlet(self.keys.measured_cp, codec.decode_pose_stamped) if cartesian else None
        self._trajectory = link.outlet(self.keys.follow_jt)
        self._state_command = link.outlet(self.keys.state_command)
        super().__init__(
            self,
            self.keys.measured_js,
            self.keys.setpoint_js,
            self.keys.servo_jp,
            self.keys.move_jp,
            ARM_JOINT_NAMES,
            lambda q: guards.joint_problems(q, self.settings),
            lambda q, reference: guards.step_problems(q, reference, self.settings, period),
        )
        self.jaw = JawClient(
            self,
            self.keys.jaw_measured_js,
            self.keys.jaw_setpoint_js,
            self.keys.jaw_servo_jp,
            self.keys.jaw_move_jp,
            JAW_JOINT_NAMES,
            lambda angle: guards.jaw_problems(angle, self.settings),
            lambda angle, reference: guards.jaw_step_problems(
                float(angle[0]), float(reference[0]), self.settings, period
            ),
        )

    # ------------------------------------------------------------------ event tracking
    def _on_state(self, received: Received[OperatingState]) -> None:
        if received.tag is not None:
            self.outcomes.record(received.tag.cause, received.tag.outcome)

    def _on_error(self, received: Received[str]) -> None:
        if received.tag is not None:
            self.outcomes.record(received.tag.cause, received.tag.outcome or "refused", received.value)

    # ------------------------------------------------------------------ liveness
    @property
    def is_alive(self) -> bool:
        latest = self._measured.latest()
        return is_recent(None if latest is None else latest.received_at, self.liveness_timeout, self._heard())

    def check_alive(self) -> None:
        """Raise `EndpointSilent` unless `measured_js` arrived within the liveness timeout."""
        latest = self._measured.latest()
        received_at = None if latest is None else latest.received_at
        check_recent(
            self.name, self.keys.measured_js, received_at, self.liveness_timeout, "endpoint", self._heard()
        )

    def _heard(self) -> float | None:
        """When a message's age is measured: now (None), or with a lockstep simulator, when its last step
        came back. The wall time this run has computed since is no silence of the simulator (a tick took
        2.8 s at load 14, as long as a fifth of a core gives), and a simulator that died fails the next step."""
        clock = self.clock
        return clock.stepped_at if isinstance(clock, SimClock) and clock.lockstep else None

    def wait_until_ready(self, timeout: float = 5.0) -> None:
        """Block until the arm has published its joints, set-points and operating state."""
        for inlet in (self._measured, self._setpoint, self._state, self.jaw._setpoint):
            if not inlet.wait_for_any(timeout):
                raise EndpointSilent(
                    f"{self.name}: nothing on {inlet.key} within {timeout} s", field=inlet.key
                )

    def read_received(self, inlet: Inlet) -> Received:
        self.check_alive()
        latest = inlet.latest()
        if latest is None:
            raise EndpointSilent(f"{self.name}: no {inlet.key} received yet", field=inlet.key)
        return latest

    def read(self, inlet: Inlet) -> Any:
        return self.read_received(inlet).value

    def send(self, outlet: Outlet, payload: bytes, cause: str = "") -> Tag:
        """Publish a command, only to a live endpoint that listens on its key; its tag (which names it and,
        as `cause`, the command it acts on)."""
        self.check_alive()
        if not outlet.matched:
            raise EndpointSilent(
                f"{self.name}: nobody subscribes to {outlet.key}; command not sent", field=outlet.key
            )
        return outlet.put(payload, cause)

    # ------------------------------------------------------------------ reads
    @property
    def fiducial_js(self) -> JointSample:
        """Physical joints as an external tracker measures them (simulator: through the cable physics).

        The first read subscribes and waits (up to the liveness timeout) for the endpoint to send its
        latest: the simulator publishes nothing nobody listens to, and re-sends its state to newcomers.
        """
        if self._fiducial is None:
            self._fiducial = self.link.inlet(self.keys.fiducial_js, codec.decode_joint_state)
            self._fiducial.wait_for_any(max(self.liveness_timeout, FIRST_SAMPLE_TIMEOUT))
        return self.read(self._fiducial)

    @property
    def measured_cp(self) -> NDArray[np.float64]:
        """Tool-tip pose (4×4) in the arm's base frame, from the measured joints."""
        if self._cartesian is None:
            raise PegbtError(
                f"{self.name}: measured_cp needs ArmClient(..., cartesian=True)", field=self.keys.measured_cp
            )
        return self.read(self._cartesian)[1]

    @property
    def operating_state(self) -> OperatingState:
        return self.read(self._state)

    def state_received(self) -> Received[OperatingState]:
        return self.read_received(self._state)

    # ------------------------------------------------------------------ commands
    def move_jp(self, target: ArrayLike | TrajectoryLike) -> MotionHandle:
        """Move to a joint goal (the endpoint plans within limits) or along a joint trajectory."""
        if not isinstance(target, TrajectoryLike):
            return self.move_goal(target)
        key = self.keys.follow_jt
        guards.refuse_if(guards.trajectory_problems(target, self.settings), "trajectory", key)
        start = np.asarray(target.q, dtype=float)[0]
        lead = max(float(np.asarray(target.t, dtype=float)[0]), self.settings.control_period)
        guards.refuse_if(
            guards.step_problems(start, self.setpoint_js.position, self.settings, lead),
            "trajectory start",
            key,
        )
        payload = codec.encode_trajectory(self.clock.now(), target, ARM_JOINT_NAMES)
        return self._start(self._trajectory, payload, "trajectory")

    def state_command(self, command: str) -> None:
        """CRTK state command: enable, disable, home or unhome."""
        if command not in STATE_COMMANDS:
            raise guards.CommandRefused(
                f"unknown state command {command!r}; expected one of {', '.join(STATE_COMMANDS)}",
                field=self.keys.state_command,
            )
        self.send(self._state_command, codec.encode_string_stamped(self.clock.now(), command))
