"""An in-memory robot for leaf tests: arms and a camera with the verbs of the transport's clients
(`pegbt.transport.arm.ArmClient` and its `JawClient`, `pegbt.transport.camera.CameraClient`), on a
`ManualClock`, so a leaf runs its real code in a tick or two without a simulator process.

What stays real: every command is checked by the transport's own guards (`pegbt.transport.guards`), as
`ArmClient.move_jp` checks it, and raises the same `CommandRefused`; motions return the transport's
`MotionHandle` and captures its `CaptureHandle`, which read their fate from this endpoint as they read it
from a real one (an outcome per command id: done, refused, aborted). What a test scripts is the endpoint's
side: a command it refuses (`refuse_next`), a motion whose end it never reports (`never_ends`) or that
stood still on the way (`stalled` from its start, `stall()` from now), a block
between the jaws (`block_in_jaw`) or slipping out of them (`drop_block()`, or `slips_at`: once the arm's
motion in progress is that far through), a camera that never answers.
A sent trajectory is followed row by row on the clock; the jaw moves at the arm's jaw velocity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pegbt.behaviours.poses import tool_pose
from pegbt.behaviours.resources.robot import Robot
from pegbt.clock import ManualClock
from pegbt.motion.ik import solve_ik
from pegbt.motion.limits import ArmSettings
from pegbt.psm import ARMS
from pegbt.transport import guards
from pegbt.transport.arm import EndpointSilent, MotionHandle
from pegbt.transport.camera import CaptureHandle
from pegbt.transport.codec import JointSample, OperatingState
from pegbt.transport.sequencing import Tag
from pegbt.workcell import Workcell

# a closing jaw stops on a block's wall at about +12° (`pegbt.behaviours.params.HELD_ABOVE`'s comment)
BLOCK_WALL_ANGLE = math.radians(12.0)


@dataclass(frozen=True)
class Sent:
    """A command as the endpoint received it: `trajectory` (its `target` a `Trajectory`), `jaw` (an
    angle) or `hold`, and the clock time it came."""

    kind: str
    target: Any
    at: float


class FakeAxis:
    """An arm's joints or its jaw as an endpoint serves them: the set-point at rest or along the motion
    in progress, and the outcome of each command."""

    def __init__(self, arm: FakeArm, key: str, start: NDArray[np.float64]) -> None:
        self.arm = arm
        self.key = key
        self.rest = np.asarray(start, dtype=float)
        self.sent: list[Sent] = []
        self._motion: tuple[str, NDArray[np.float64], NDArray[np.float64]] | None = None  # id, times, rows
        self._fates: dict[str, tuple[str, str]] = {}
        self._commands = 0
        self.holds_overtaken = False  # a hold reaches it after the next command (zenoh orders keys apart)
        self._late: list[str] = []  # the holds so overtaken, by the motion each names
        self.paused: dict[str, float] = {}  # s each motion stood still on the way, by its id

    # ------------------------------------------------------------------ what MotionHandle reads
    @property
    def outcomes(self) -> FakeAxis:
        return self

    def of(self, command_id: str) -> tuple[str, str] | None:
        """The endpoint's report on `command_id`: refused, aborted (preempted by a hold), done once the
        clock passed its last row (unless `never_ends`), or nothing yet."""
        if command_id in self._fates:
            return self._fates[command_id]
        if self._motion is not None and self._motion[0] == command_id and not self.arm.never_ends:
            if self.arm.clock.now() >= self._motion[1][-1]:
                self.rest = self._motion[2][-1].copy()
                self._motion = None
                self._fates[command_id] = ("done", "")
                return self._fates[command_id]
        return None

    def arm_state(self) -> SimpleNamespace:
        busy = self._motion is not None
        state = OperatingState(self.arm.clock.now(), "ENABLED", True, busy)
        return SimpleNamespace(tag=Tag("fake", self._commands), value=state)

    def hold(self, stopping: str = "") -> None:
        """Stop at the set-point of now: the motion in progress is aborted, unless the hold names another
        (`stopping`: a later command took over, as the simulator's `JointGroup.hold`). With
        `holds_overtaken`, the hold comes after the next command on this axis instead."""
        if self.holds_overtaken:
            self._late.append(stopping)
            return
        here = self.position()
        self.sent.append(Sent("hold", here, self.arm.clock.now()))
        if stopping and (self._motion is None or self._motion[0] != stopping):
            return
        if self._motion is not None:
            self._fates[self._motion[0]] = ("aborted", "held")
            self._motion = None
        self.rest = here

    def stall(self, seconds: float) -> None:
        """The motion in progress stands still `seconds` from now (its streamer not scheduled), ending that
        much later, its handle saying so."""
        assert self._motion is not None
        command_id, times, rows = self._motion
        now, here = self.arm.clock.now(), self.position()
        later = times > now
        times = np.r_[times[~later], now, now + seconds, times[later] + seconds]
        self._motion = (command_id, times, np.vstack([rows[~later], here, here, rows[later]]))
        self.paused[command_id] += seconds

    # ------------------------------------------------------------------ state
    def position(self, at: float | None = None) -> NDArray[np.float64]:
        """The set-point now (or at clock time `at`): along the motion in progress (rows at clock times),
        else at rest."""
        if self._motion is None:
            return self.rest.copy()
        _, times, rows = self._motion
        now = self.arm.clock.now() if at is None else at
        return np.array([np.interp(now, times, rows[:, joint]) for joint in range(rows.shape[1])])

    def progress(self) -> float:
        """How far (0 to 1) the motion in progress is through its time; at rest, 1 after a motion, else 0."""
        if self._motion is None:
            return 1.0 if any(fate == ("done", "") for fate in self._fates.values()) else 0.0
        times = self._motion[1]
        return float(np.clip((self.arm.clock.now() - times[0]) / (times[-1] - times[0]), 0.0, 1.0))

    def sample(self, position: NDArray[np.float64]) -> JointSample:
        if self.arm.silent:
            raise EndpointSilent(f"{self.arm.name}: nothing heard on {self.key}", field=self.key)
        zeros = np.zeros_like(position)
        return JointSample(self.arm.clock.now(), position, zeros, zeros)

    @property
    def setpoint_js(self) -> JointSample:
        return self.sample(self.position())

    # ------------------------------------------------------------------ commands
    def start(
        self, kind: str, target: Any, times: NDArray[np.float64], rows: NDArray[np.float64]
    ) -> MotionHandle:
        """Receive a motion along `rows` at clock `times` (refused if the test says so), and its handle."""
        now = self.arm.clock.now()
        self._commands += 1
        command_id = f"fake:{self.key}:{self._commands}"
        self.sent.append(Sent(kind, target, now))
        handle = StreamedHandle(self, command_id, now, kind)
        if self.arm.refuse_next is not None:
            self._fates[command_id] = ("refused", self.arm.refuse_next)
            self.arm.refuse_next = None
        else:
            if self._motion is not None:
                self._fates[self._motion[0]] = ("aborted", "preempted")
            self.rest = self.position()
            stalled = self.arm.stalled
            self._motion = (command_id, now + np.r_[times[:1], times[1:] + stalled], rows)
            self.paused[command_id] = stalled
        late, self._late, self.holds_overtaken = self._late, [], False
        for stopping in late:
            self.hold(stopping)
        return handle


class StreamedHandle(MotionHandle):
    """The handle of a motion that reports the seconds it stood still on the way, as a streamed one does."""

    def __init__(self, axis: FakeAxis, command_id: str, sent_at: float, what: str) -> None:
        super().__init__(axis, command_id, sent_at, what)  # type: ignore[arg-type]
        self._fake = axis

    @property
    def paused(self) -> float:
        return self._fake.paused.get(self.command_id, 0.0)


class FakeJaw(FakeAxis):
    """The jaw: a block between the jaws stops it closing at the block's wall."""

    @property
    def measured_js(self) -> JointSample:
        angle = self.position()
        arm = self.arm
        if arm.block_in_jaw and arm.slips_at is not None and arm.progress() >= arm.slips_at:
            arm.block_in_jaw = False
        if self.arm.block_in_jaw:
            angle = np.maximum(angle, BLOCK_WALL_ANGLE)
        return self.sample(angle)

    def move_jp(self, angle: float) -> MotionHandle:
        settings = self.arm.settings
        guards.refuse_if(guards.jaw_problems([angle], settings), f"jaw goal {angle}", self.key)
        start = float(self.position()[0])
        seconds = max(abs(angle - start) / settings.jaw_velocity, settings.control_period)
        return self.start("jaw", angle, np.array([0.0, seconds]), np.array([[start], [angle]]))


class FakeArm(FakeAxis):
    """One PSM with `ArmClient`'s verbs; `sent` lists what it received, `jaw.sent` what its jaw did."""

    def __init__(
        self, name: str, settings: ArmSettings, clock: ManualClock, start: NDArray[np.float64], jaw: float
    ) -> None:
        self.name = name
        self.settings = settings
        self.clock = clock
        self.refuse_next: str | None = None  # the endpoint refuses the next command, saying this
        self.never_ends = False  # the endpoint never reports a motion's end
        self.stalled = 0.0  # s each motion stands at its start (a streamer not scheduled), ending that late
        self.block_in_jaw = False
        self.slips_at: float | None = None  # the block slips out this far (0 to 1) through a motion
        self.silent = False  # every read raises EndpointSilent, as the client does for a quiet endpoint
        self.fiducial_offset = np.zeros(6)  # where the physical joints are, from the set-point
        self.lag = 0.0  # s the encoders trail the set-point (a servo loop's tracking lag)
        super().__init__(self, f"{name}/follow_jt", start)
        self.jaw = FakeJaw(self, f"{name}/jaw/move_jp", np.array([jaw]))

    @property
    def measured_js(self) -> JointSample:
        return self.sample(self.position(self.clock.now() - self.lag))

    @property
    def fiducial_js(self) -> JointSample:
        return self.sample(self.position() + self.fiducial_offset)

    def drop_block(self) -> None:
        """The block slips out: the jaw closes to its set-point."""
        self.block_in_jaw = False

    def move_jp(self, trajectory: Any) -> MotionHandle:
        """Follow `trajectory` (what `ArmClient.move_jp` checks first is checked here the same way)."""
        guards.refuse_if(guards.trajectory_problems(trajectory, self.settings), "trajectory", self.key)
        q = np.asarray(trajectory.q, dtype=float)
        t = np.asarray(trajectory.t, dtype=float)
        lead = max(float(t[0]), self.settings.control_period)
        guards.refuse_if(
            guards.step_problems(q[0], self.position(), self.settings, lead), "trajectory start", self.key
        )
        return self.start("trajectory", trajectory, t, q)

    @property
    def trajectories(self) -> list[Any]:
        return [sent.target for sent in self.sent if sent.kind == "trajectory"]


class FakeCamera:
    """A depth camera that answers each capture with `cloud` at once (None: never answers; `listening`
    False: no camera listens, so no trigger goes out)."""

    def __init__(self, clock: ManualClock, cloud: NDArray[np.float32] | None, timeout: float = 0.05) -> None:
        self.clock = clock
        self.cloud = cloud
        self.timeout = timeout  # s of wall time, as `CameraClient.timeout`
        self.listening = True
        self.keys = SimpleNamespace(trigger="camera/trigger")
        self.triggers = 0

    def capture_async(self) -> CaptureHandle:
        handle = CaptureHandle(self, self.clock.now())
        self.send_trigger(handle)
        return handle

    def send_trigger(self, handle: CaptureHandle) -> bool:
        if handle.sent or not self.listening:
            return handle.sent
        self.triggers += 1
        handle.request_id = f"fake:camera:{self.triggers}"
        if self.cloud is not None:
            handle.fulfil(self.clock.now(), self.cloud)
        return True


def home_joints(cell: Workcell, arm: str, settings: ArmSettings) -> NDArray[np.float64]:
    """The arm's joints at its home pose, tool down, as `park` leaves it."""
    return solve_ik(tool_pose(settings.home_tip, 0.0, cell.up_in(arm)), settings, what=f"{arm} home")


def fake_robot(
    clock: ManualClock,
    settings: dict[str, ArmSettings],
    cell: Workcell,
    cloud: NDArray[np.float32] | None = None,
) -> Robot:
    """Both PSMs at home with the jaw closed, and a camera answering with `cloud`."""
    arms = {
        arm: FakeArm(
            arm, settings[arm], clock, home_joints(cell, arm, settings[arm]), settings[arm].jaw_lower
        )
        for arm in ARMS
    }
    return Robot(arms, FakeCamera(clock, cloud), clock)
