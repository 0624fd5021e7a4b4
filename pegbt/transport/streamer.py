"""The servo streamer: plays whole joint trajectories to a CRTK robot as `servo_jp` set-points, one every
control period of wall-clock time, in a process of its own (`python -m pegbt.transport.streamer`).

Why a process: a thread of the executive would wait for the GIL behind ticking, registration and planning,
for up to Python's 5 ms switch interval at a time, and a 100 Hz stream cannot hold its period that way.

The executive (`pegbt.transport.streaming.Streamer`) talks to it over its standard input and output in
frames (a 4-byte little-endian length, then a pickle; both ends are pegbt):

- in: `("configure", {...})` first, then `("play", id, arm, axis, t, q)` (axis `arm` or `jaw`; `t` from 0,
  `q` one row per time), `("ramp", id, arm, start, goal)` (a jaw ramp, below), `("stop", id)`, `("quit",)`;
- out: `("ready", realtime)`, `("started", id)`, `("stalled", id, seconds)`, `("paused", id, reason)`,
  `("resumed", id, seconds)`, `("done", id)`, `("failed", id, reason)`.

A jaw ramp goes to its goal at the jaw's velocity from where the jaw's set-point is: the last one sent while
the jaw's stream is going (a ramp it supersedes, or one just ended), else `start` (the client's view of the
robot's). Only the streamer knows that last row: the robot's set-point echoes it a state message or more
later, and a ramp from the echo would first step the jaw back, which the check below refuses (the dVRK's
`servo_jp` takes each set-point as given, `mtsIntuitiveResearchKitArm.cpp`, so continuity is ours to keep).

Every set-point is checked before it leaves (`guards`: joint limits, and velocity from the last one sent, or
from the robot's `setpoint_js` for the first of a motion): one that fails is never sent; the motion fails,
and the arm is told to `hold`. A motion also fails if the arm leaves ENABLED. When the executive dies (its
end of the pipe closes), every arm is told to `hold` and the streamer exits.

The clutch: a person pressing an arm's clutch puts it in MANUAL, which a CRTK client sees as ENABLED, homed
and busy (sawIntuitiveResearchKit `core/components/code/mtsIntuitiveResearchKitPSM.cpp`, `EnterManual`);
the dVRK would still execute a `servo_jp` (`RunManual`), and the arm would work against the person. An arm
that turns busy while its motion streams (a state stamped after the motion began, on the robot's clock) is
in MANUAL: at once no set-point goes to any arm, and every running motion is paused (reported, not
failed). Once the arm is released (a newer state, not busy, and a set-point stamped no earlier: the dVRK
holds where the person left it, `LeaveManual`), each paused motion goes on from where its arm is: a
rest-to-rest cubic back to where it was paused (`pegbt.motion.cubic`), then the rest of its trajectory, as
one motion that ends that much later (reported as `resumed` with the seconds it waited).

A stall (the process not scheduled for more than `STALL_PERIODS` control periods) pauses each running
motion rather than skipping ahead: the first set-point after it is the one a period after the last one sent,
and the motion ends that much later (reported as `stalled`). Jumping to where the trajectory would be by
now would reach a dVRK as one `servo_jp` goal, which its arm hands to its PID as it comes
(jhu-dvrk/sawIntuitiveResearchKit `core/components/code/mtsIntuitiveResearchKitArm.cpp`, `servo_jp` and
`control_servo_jp`), and the PID disables the arm with a tracking error once the set-point is further from
the measured position than the joint's `p_measured_setpoint_tolerance` (jhu-saw/sawControllers
`core/components/code/mtsPID.cpp`; 0.05 m on a PSM's insertion in sawIntuitiveResearchKit
`share/pid/sawControllersPID-PSM.json`).

Timing (measured by `pegbt bench servo`): a motion that arrives while nothing streams starts at once, the
ticks' grid with it (`Streamer.next_tick_for`); the loop waits for commands with `epoll`, whose timeout Python
rounds up to whole milliseconds, so it wakes from it up to 1 ms early and sleeps the rest with
`time.sleep` (`clock_nanosleep`, about 0.1 ms late). Where the system permits it (root, or an `rtprio`
limit), the process, with zenoh's threads that send for it, runs under `SCHED_FIFO`, so that neither the
executive's computing nor another process on the machine delays a set-point; elsewhere it runs as before.
"""

from __future__ import annotations

import os
import pickle
import selectors
import struct
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.scheduling import STREAMER_PRIORITY, run_realtime

if TYPE_CHECKING:
    from pegbt.motion.limits import ArmSettings

_LENGTH = struct.Struct("<I")
EPOLL_RESOLUTION = 0.001  # s: epoll's timeout is whole milliseconds
STALL_PERIODS = 2  # a longer gap since an axis's last set-point is a stall: its stream is no longer going
# s: a tick this close before a motion's last row sends it. The loop's ticks are a running sum of periods,
# which in binary falls short of the row's time by a few ulps; the last row then went a period late
ROW_TOLERANCE = 1e-6
Frame = tuple[Any, ...]


def encode_frame(message: Frame) -> bytes:
    body = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
    return _LENGTH.pack(len(body)) + body


class FrameReader:
    """Splits bytes read from a pipe into whole frames."""

    def __init__(self) -> None:
        self._buffer = bytearray()

    def feed(self, data: bytes) -> list[Frame]:
        self._buffer += data
        frames = []
        while len(self._buffer) >= _LENGTH.size:
            (size,) = _LENGTH.unpack_from(self._buffer)
            if len(self._buffer) < _LENGTH.size + size:
                break
            frames.append(pickle.loads(bytes(self._buffer[_LENGTH.size : _LENGTH.size + size])))
            del self._buffer[: _LENGTH.size + size]
        return frames


@dataclass
class _Motion:
    id: int
    t: NDArray[np.float64]
    q: NDArray[np.float64]
    start: float  # monotonic time of row 0
    robot_start: float  # the robot's time when it began: its latest set-point's stamp
    paused_at: float | None = None  # monotonic time it was paused (its arm in MANUAL)
    paused_for: float = 0.0  # s it has waited


class _Axis:
    """One commanded axis (an arm's 6 joints, or its jaw): its set-point topic, its checks, its motion."""

    def __init__(
        self,
        publish: Callable[[NDArray[np.float64]], None],
        problems: Callable[[NDArray[np.float64]], list[str]],
        step_problems: Callable[[NDArray[np.float64], NDArray[np.float64], float], list[str]],
        reference: Callable[[], NDArray[np.float64] | None],
    ) -> None:
        self.publish = publish
        self.problems = problems
        self.step_problems = step_problems
        self.reference = reference  # the robot's latest set-point, None before the first
        # rows of (t, q) from a position to another at the axis's limits: back after MANUAL, a jaw ramp
        self.leg: Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]] | None = None
        self.motion: _Motion | None = None
        self.last: tuple[float, NDArray[np.float64]] | None = None  # (monotonic time, set-point) last sent


class Streamer:
    """The child's loop: commands from `stdin`, reports to `stdout`, set-points to the robot on a wire."""

    def __init__(self, config: dict[str, Any], report: Callable[[Frame], None]) -> None:
        from pegbt.transport import codec, guards
        from pegbt.transport.arm import ARM_JOINT_NAMES, JAW_JOINT_NAMES
        from pegbt.transport.dvrk_topics import PsmTopics
        from pegbt.transport.session import open_session
        from pegbt.transport.wires import make_wire, wire_session_settings

        self.period: float = config["period"]
        self._report = report
        ros2 = config.get("ros2", "bridge")
        self._session = open_session(wire_session_settings(ros2, config["connect"]))
        wire = make_wire(ros2, self._session, config["namespace"], node_name="pegbt_streamer")
        self._codec = codec
        self.axes: dict[tuple[str, str], _Axis] = {}
        self._holds: dict[str, Any] = {}
        self._states: dict[str, Any] = {}
        self._latest: dict[Any, bytes] = {}
        self._setpoints: dict[str, Any] = {}
        self._manual: tuple[str, float] | None = None  # the arm in MANUAL and its state's stamp

        def add_arm(arm: str, settings: ArmSettings) -> None:
            topics = PsmTopics(arm)
            self._holds[arm] = wire.publisher(topics.hold)
            for topic in (topics.setpoint_js, topics.jaw_setpoint_js, topics.operating_state):
                wire.subscriber(topic, partial(self._latest.__setitem__, topic))
            self._states[arm] = topics.operating_state
            self._setpoints[arm] = topics.setpoint_js
            arm_servo, jaw_servo = wire.publisher(topics.servo_jp), wire.publisher(topics.jaw_servo_jp)
            self.axes[(arm, "arm")] = _Axis(
                lambda q: arm_servo.put(codec.encode_joint_state(time.time(), q, names=ARM_JOINT_NAMES)),
                lambda q: guards.joint_problems(q, settings),
                lambda q, ref, dt: guards.step_problems(q, ref, settings, dt),
                lambda: self._position(topics.setpoint_js),
            )
            self.axes[(arm, "jaw")] = _Axis(
                lambda q: jaw_servo.put(codec.encode_joint_state(time.time(), q, names=JAW_JOINT_NAMES)),
                lambda q: guards.jaw_problems(q, settings),
                lambda q, ref, dt: guards.jaw_step_problems(float(q[0]), float(ref[0]), settings, dt),
                lambda: self._position(topics.jaw_setpoint_js),
            )
            self.axes[(arm, "arm")].leg = partial(_arm_return, settings)
            self.axes[(arm, "jaw")].leg = partial(jaw_ramp, settings)

        for arm, settings in config["arms"].items():
            add_arm(arm, settings)

        # rosbags builds each type's (de)serialiser on first use, in ~0.1 s: not in the middle of a motion
        warm = codec.encode_joint_state(0.0, np.zeros(6))
        codec.decode_joint_state(warm)
        codec.decode_operating_state(
            codec.encode_operating_state(codec.OperatingState(0.0, "", False, False))
        )
        codec.encode_empty()

    def _position(self, topic: Any) -> NDArray[np.float64] | None:
        payload = self._latest.get(topic)
        return None if payload is None else self._codec.decode_joint_state(payload).position

    def _state(self, arm: str) -> str | None:
        state = self._operating_state(arm)
        return None if state is None else state.state

    def _operating_state(self, arm: str) -> Any:
        payload = self._latest.get(self._states[arm])
        return None if payload is None else self._codec.decode_operating_state(payload)

    def _setpoint_stamp(self, arm: str) -> float:
        payload = self._latest.get(self._setpoints[arm])
        return 0.0 if payload is None else float(self._codec.decode_joint_state(payload).stamp)

    # ------------------------------------------------------------------ commands
    def next_tick_for(self, message: Frame, next_tick: float, now: float) -> float:
        """When the tick after `message` comes: `now` for a motion that arrives while nothing streams (the
        grid of ticks starts with it, its first set-point at once), else the grid's `next_tick`. A motion
        began at the next tick of a grid no other motion kept, so up to a period after it was sent: each
        motion of a transfer ended that much later, half a period on average."""
        if message[0] in ("play", "ramp") and all(axis.motion is None for axis in self.axes.values()):
            return min(now, next_tick)
        return next_tick

    def handle(self, message: Frame, next_tick: float) -> bool:
        """Act on one command; False when told to quit."""
        kind = message[0]
        if kind == "play":
            _, motion_id, arm, axis_name, t, q = message
            self._play(
                motion_id, arm, axis_name, np.asarray(t, dtype=float), np.asarray(q, dtype=float), next_tick
            )
        elif kind == "ramp":
            _, motion_id, arm, start, goal = message
            self._ramp(motion_id, arm, float(start), float(goal), next_tick)
        elif kind == "stop":
            for (arm, axis_name), axis in self.axes.items():
                if axis.motion is not None and axis.motion.id == message[1]:
                    axis.motion = None
                    if axis_name == "arm":
                        self.hold(arm)
                    self._report(("failed", message[1], "stopped by the client"))
        elif kind == "quit":
            for (arm, _), axis in self.axes.items():
                if axis.motion is not None:
                    self.hold(arm)
            return False
        return True

    def _play(self, motion_id: int, arm: str, axis_name: str, t: NDArray, q: NDArray, start: float) -> None:
        axis = self.axes[(arm, axis_name)]
        if axis.motion is not None:
            self._report(("failed", axis.motion.id, "replaced by a newer motion"))
        axis.motion = None
        q = q.reshape(len(t), -1)
        reference = self._reference(axis, start)
        if reference is None:
            self._report(("failed", motion_id, f"no {arm} {axis_name} set-point from the robot yet"))
            return
        problems = axis.problems(q[0]) + axis.step_problems(q[0], reference, self.period)
        if problems:
            self._report(("failed", motion_id, f"{arm} {axis_name} start refused: {'; '.join(problems)}"))
            return
        # a tick more than a period past would skip rows (the loop skips ahead, never bursts); a later one
        # keeps the motion on the grid of ticks: its last row is sent on a tick, not a period after it
        start = max(start, time.monotonic() - self.period)
        axis.motion = _Motion(motion_id, t, q, start, self._setpoint_stamp(arm))
        axis.last = (start - self.period, reference)
        self._report(("started", motion_id))
        if self._manual is not None:  # it waits with the others
            axis.motion.paused_at = start
            self._report(("paused", motion_id, f"{arm} {axis_name}: {self._manual[0]} is in MANUAL"))

    def _ramp(self, motion_id: int, arm: str, start: float, goal: float, tick: float) -> None:
        """A jaw ramp to `goal` from the last set-point sent while the jaw's stream is going, else `start`."""
        axis = self.axes[(arm, "jaw")]
        if self._going(axis, tick):
            assert axis.last is not None
            start = float(axis.last[1][0])
        assert axis.leg is not None
        rows = axis.leg(np.array([start]), np.array([goal]))
        self._play(motion_id, arm, "jaw", rows[:, 0], rows[:, 1:], tick)

    def _going(self, axis: _Axis, now: float) -> bool:
        """Whether the axis's stream is still going: a set-point sent within a stall's periods of `now`."""
        return axis.last is not None and now - axis.last[0] <= STALL_PERIODS * self.period

    def _reference(self, axis: _Axis, now: float) -> NDArray[np.float64] | None:
        """Where the axis's set-point is: the last one sent if the stream is still going, else the robot's."""
        if self._going(axis, now):
            assert axis.last is not None
            return axis.last[1]
        return axis.reference()

    def hold(self, arm: str) -> None:
        self._holds[arm].put(self._codec.encode_empty())

    # ------------------------------------------------------------------ set-points
    def tick(self, now: float) -> None:
        """Send each running motion's set-point for time `now` (monotonic); after a stall, each motion's
        next row instead; nothing while an arm is in MANUAL (see the module docstring)."""
        self._watch_clutch(now)
        for (arm, axis_name), axis in self.axes.items():
            motion = axis.motion
            if motion is None:
                continue
            if self._state(arm) not in (None, "ENABLED"):
                axis.motion = None
                self._report(("failed", motion.id, f"{arm} is {self._state(arm)}, no longer ENABLED"))
                continue
            if motion.paused_at is not None:
                continue
            assert axis.last is not None
            since = now - axis.last[0]
            if since > STALL_PERIODS * self.period:  # resume a period after the last set-point sent
                stall = since - self.period
                motion.start += stall
                since = self.period
                self._report(("stalled", motion.id, stall))
            elapsed = now - motion.start
            last_row = elapsed >= motion.t[-1] - ROW_TOLERANCE
            q = motion.q[-1] if last_row else _sample(motion.t, motion.q, elapsed)
            problems = axis.problems(q) + axis.step_problems(q, axis.last[1], since)
            if problems:
                axis.motion = None
                self.hold(arm)
                self._report(
                    ("failed", motion.id, f"{arm} {axis_name} set-point refused: {'; '.join(problems)}")
                )
                continue
            axis.publish(q)
            axis.last = (now, q)
            if last_row:
                axis.motion = None
                self._report(("done", motion.id))

    def _watch_clutch(self, now: float) -> None:
        """Pause every motion when an arm whose motion streams turns busy (MANUAL); resume them once it is
        released."""
        if self._manual is None:
            for (arm, _), axis in self.axes.items():
                state = self._operating_state(arm)
                motion = axis.motion
                if motion is None or state is None or not (state.state == "ENABLED" and state.is_busy):
                    continue
                if state.stamp > motion.robot_start:
                    self._pause_all(arm, state.stamp, now)
                    return
            return
        arm, since = self._manual
        state = self._operating_state(arm)
        if state is None or state.stamp <= since or state.is_busy or state.state != "ENABLED":
            return
        if self._setpoint_stamp(arm) < state.stamp:  # the set-point where it was released is yet to come
            return
        self._manual = None
        for key, axis in self.axes.items():
            if axis.motion is not None and axis.motion.paused_at is not None:
                self._resume(key, axis, now)

    def _pause_all(self, arm: str, stamp: float, now: float) -> None:
        self._manual = (arm, stamp)
        for (other, axis_name), axis in self.axes.items():
            motion = axis.motion
            if motion is not None and motion.paused_at is None:
                motion.paused_at = now
                why = "its clutch is pressed" if other == arm else f"{arm}'s clutch is pressed"
                self._report(("paused", motion.id, f"{other} {axis_name}: {arm} is in MANUAL ({why})"))

    def _resume(self, key: tuple[str, str], axis: _Axis, now: float) -> None:
        """The paused motion on from where its arm is: back to where it stopped, then the rest."""
        motion = axis.motion
        assert motion is not None and motion.paused_at is not None and axis.last is not None
        arm, axis_name = key
        waited = now - motion.paused_at
        elapsed = axis.last[0] - motion.start  # the trajectory's time of the last set-point sent
        where = axis.reference()
        assert axis.leg is not None
        try:
            leg = axis.leg(where if where is not None else axis.last[1], axis.last[1])
        except PegbtError as error:
            axis.motion = None
            self._report(("failed", motion.id, f"{arm} {axis_name}: cannot return after MANUAL: {error}"))
            return
        rest = motion.t > elapsed
        duration = float(leg[-1, 0])
        t = np.concatenate([leg[:, 0], duration + motion.t[rest] - elapsed])
        q = np.concatenate([leg[:, 1:], motion.q[rest]])
        axis.motion = _Motion(motion.id, t, q, now, self._setpoint_stamp(arm), paused_for=motion.paused_for)
        axis.motion.paused_for += waited + duration
        axis.last = (now - self.period, leg[0, 1:])
        self._report(("resumed", motion.id, waited + duration))

    def close(self) -> None:
        self._session.close()


def _arm_return(settings: ArmSettings, start: NDArray[np.float64], goal: NDArray[np.float64]) -> NDArray:
    """Rows of (t, q) of a rest-to-rest cubic from `start` to `goal` at the planner's limits."""
    from pegbt.motion.cubic import rest_to_rest_path

    path = rest_to_rest_path([start, goal], settings, ["where MANUAL left the arm", "where it was paused"])
    trajectory = path.sample(settings.control_period)
    return np.column_stack([trajectory.t - trajectory.t[0], trajectory.q])


def jaw_ramp(settings: ArmSettings, start: NDArray[np.float64], goal: NDArray[np.float64]) -> NDArray:
    """Rows of (t, angle) of a ramp from `start` to `goal` at the jaw's velocity, a row a control period:
    the constant-speed ramp pegbt's simulator plays for a jaw `move_jp` (`pegbt.sim.playback.ramp_playback`),
    so that a jaw takes as long on either interface; it ends on `goal` exactly."""
    distance = abs(float(goal[0]) - float(start[0]))
    duration = max(distance / settings.jaw_velocity, settings.control_period)
    t = np.append(np.arange(0.0, duration, settings.control_period), duration)
    q = float(start[0]) + (float(goal[0]) - float(start[0])) * t / duration
    q[-1] = float(goal[0])
    return np.column_stack([t, q])


def _sample(t: NDArray[np.float64], q: NDArray[np.float64], at: float) -> NDArray[np.float64]:
    """`q` linearly interpolated at time `at` (within the trajectory)."""
    index = int(np.searchsorted(t, at, side="right"))
    if index <= 0:
        return q[0]
    before, after = t[index - 1], t[index]
    share = (at - before) / (after - before)
    return q[index - 1] + share * (q[index] - q[index - 1])


def main() -> int:
    """Run until the executive says quit or its end of the pipe closes."""
    reader, stdin, stdout = FrameReader(), sys.stdin.fileno(), sys.stdout.fileno()

    def report(message: Frame) -> None:
        os.write(stdout, encode_frame(message))

    frames: list[Frame] = []
    while not frames:
        data = os.read(stdin, 65536)
        if not data:
            return 0
        frames = reader.feed(data)
    is_realtime = run_realtime(
        STREAMER_PRIORITY
    )  # before the session opens, so that zenoh's threads inherit it
    streamer = Streamer(frames.pop(0)[1], report)
    report(("ready", is_realtime))
    selector = selectors.DefaultSelector()
    selector.register(stdin, selectors.EVENT_READ)
    period = streamer.period
    next_tick = time.monotonic()
    running = True
    try:
        while running:
            for message in frames:
                next_tick = streamer.next_tick_for(message, next_tick, time.monotonic())
                running = running and streamer.handle(message, next_tick)
            frames = []
            if not running:
                break
            if selector.select(max(0.0, next_tick - time.monotonic() - EPOLL_RESOLUTION)):
                data = os.read(stdin, 1 << 20)
                if not data:  # the executive is gone: hold every arm, then leave
                    for arm in {arm for arm, _ in streamer.axes}:
                        streamer.hold(arm)
                    break
                frames = reader.feed(data)
                continue
            now = time.monotonic()
            if now < next_tick - EPOLL_RESOLUTION:
                continue
            if now < next_tick:
                time.sleep(next_tick - now)
                now = time.monotonic()
            streamer.tick(next_tick)
            next_tick += period
            if next_tick < now:  # fell more than a period behind: skip, never burst
                next_tick += period * np.ceil((now - next_tick) / period)
    finally:
        time.sleep(0.05)  # let the last messages (a hold) leave before the session closes
        streamer.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
