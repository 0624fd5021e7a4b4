"""`CrtkArm`: one PSM of any CRTK robot (a dVRK 2.x behind zenoh-bridge-ros2dds), with the verbs behaviours
use on `ArmClient`, and no pegbt extension: no trajectory topic, no attachment, no simulator key.

- State: `operating_state` is latched on the robot (published on change only), so it is read through the
  wire's latched subscriber, which gets the last one from the robot's cache however late it joins.
- `make_ready()`: enables the arm, and homes it only if it is not homed, each bounded in time; as
  crtk_python_client's `enable`/`home` do (`src/crtk/utils.py`: wait for ENABLED; for homed and not busy).
- `move_jp(goal)`: the robot's own `move_jp`; done by CRTK's rule (`src/crtk/utils.py` `is_busy(start_time)`,
  `wait_move_handle.py`): an `operating_state` stamped after the command, not busy; failed if not done in
  a bound computed from the dVRK's own trajectory limits. "After" is on the robot's clock (`robot_now`):
  the dVRK stamps what it publishes with its own computer's clock, which need not agree with this one's.
- `move_jp(trajectory)` and the jaw's `move_jp(angle)`: played by the servo streamer as `servo_jp`/
  `jaw/servo_jp` set-points (a jaw `move_jp` would take a dVRK PSM out of position mode mid-stream:
  `mtsIntuitiveResearchKitPSM::jaw_move_jp`).
- `slow_down(F)` (`--speed`): the robot's own `move_jp` and homing run at F of its velocity and F² of its
  acceleration limits (`trajectory_j/set_ratio_v`, `set_ratio_a`: dVRK 2.3 and later,
  `mtsIntuitiveResearchKitArm.cpp`), as pegbt's streamed trajectories do (`ArmSettings.at_speed`); the
  robot confirms each ratio on `trajectory_j/ratio_v`, `ratio_a`, and a robot that does not is an error
  rather than a first run at full speed.
- `stop`: the robot's `hold` (`mtsIntuitiveResearchKitArm::hold`: servo to the current set-point).
- The robot's `error`, `warning` and `status` messages are kept for the tick log (`drain_messages`). The
  three topics are latched with a depth of 100 (cisst-ros `cisst_ros_bridge/include/cisst_ros_bridge/
  mtsROSBridge.h`), so a client joining gets up to 100 old messages of each, unstamped: what comes before
  `begin_run` (the joining history) is history, logged with `before_run` and never a stop's cause.
- Time: the robot stamps on its own computer's clock, and a datum it marks invalid (joints before the
  encoders are biased) with 0 (cisst-ros `cisst_ros_bridge/include/cisst_ros_bridge/mtsCISSTToROS.h`,
  `cisst_header_to_ros_header`); no robot stamp is ever compared with this computer's clock (`robot_now`),
  and the current operating state is the newest by its stamp, whatever order the history replays in.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from functools import partial
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.clock import Clock, WallClock
from pegbt.errors import PegbtError
from pegbt.motion.limits import ArmSettings
from pegbt.transport import codec, guards
from pegbt.transport.arm import (
    ArmFaulted,
    ArmLeftReady,
    EndpointSilent,
    MotionStatus,
    StatusFlags,
    check_recent,
    is_recent,
)
from pegbt.transport.codec import JointSample, OperatingState, TrajectoryLike
from pegbt.transport.dvrk_topics import PsmTopics
from pegbt.transport.ros2 import Ros2Wire
from pegbt.transport.sequencing import Received
from pegbt.transport.streaming import MOTION_MARGIN, StreamedMotion, Streamer

T = TypeVar("T")

MESSAGE_LEVELS = ("error", "warning", "status")  # the dVRK's human-readable events, most severe first

LIVENESS_S = 1.0  # s without measured_js before the robot counts as silent
ENABLE_TIMEOUT = (
    10.0  # s for an arm to power up (the dVRK allows 2 × TimeToPower, mtsIntuitiveResearchKitArm.cpp)
)
HOME_TIMEOUT = 60.0  # s for a homing motion (seconds on a dVRK; more when it first calibrates on pots)
HISTORY_QUIET = 0.2  # s without a message that ends the joining history of the latched message topics
HISTORY_WAIT = 2.0  # s at most to wait for it
# The dVRK PSM's move_jp trajectory limits (mtsIntuitiveResearchKitPSM.cpp, m_trajectory_j.v_max/a_max): 90°/s and
# 90°/s² for yaw and pitch, 0.2 m/s and 0.2 m/s² for insertion, 1080°/s and 720°/s² for roll and the wrist
DVRK_MOVE_VELOCITY = np.array([np.pi / 2, np.pi / 2, 0.2, 6 * np.pi, 6 * np.pi, 6 * np.pi])
DVRK_MOVE_ACCELERATION = np.array([np.pi / 2, np.pi / 2, 0.2, 4 * np.pi, 4 * np.pi, 4 * np.pi])
MOVE_MARGIN = 2.0  # s beyond twice the rest-to-rest time a robot's move_jp may take before it fails
STATE_CONFIRM_S = 0.5  # s to wait for the operating state the streamer saw, once it stops a motion
RATIO_CONFIRM_S = 2.0  # s for the robot to confirm a trajectory ratio


def rest_to_rest_bound(start: ArrayLike, goal: ArrayLike, speed: float = 1.0) -> float:
    """Seconds the dVRK's own rest-to-rest profile needs from `start` to `goal` (the slowest joint), its
    velocity limits × `speed` and acceleration limits × `speed`²."""
    distance = np.abs(np.asarray(goal, dtype=float) - np.asarray(start, dtype=float))
    v, a = DVRK_MOVE_VELOCITY * speed, DVRK_MOVE_ACCELERATION * speed**2
    seconds = np.where(distance <= v * v / a, 2 * np.sqrt(distance / a), distance / v + v / a)
    return float(seconds.max())


class Latest(Generic[T]):
    """The latest message of one topic (decoded on first read) and when it came; with `stamp`, the newest by
    that stamp (a latched topic's history may replay after a newer message)."""

    def __init__(
        self, topic: str, decode: Callable[[bytes], T], stamp: Callable[[T], float] | None = None
    ) -> None:
        self.topic = topic
        self._decode = decode
        self._stamp = stamp
        self._latest: Received[T] | None = None
        self._changed = threading.Condition()

    def take(self, payload: bytes) -> None:
        received = Received(payload, self._decode, None, time.monotonic())
        with self._changed:
            latest = self._latest
            if self._stamp is not None and latest is not None:
                if self._stamp(received.value) < self._stamp(latest.value):
                    return
            self._latest = received
            self._changed.notify_all()

    def latest(self) -> Received[T] | None:
        return self._latest

    def wait_until(self, condition: Callable[[T], bool], timeout: float) -> bool:
        """Block until the latest message satisfies `condition`; False on timeout."""
        with self._changed:
            return self._changed.wait_for(
                lambda: self._latest is not None and condition(self._latest.value), timeout
            )


class RobotMove(StatusFlags):
    """The robot's own `move_jp` to a goal: done by CRTK's rule once the set-point the next motion plans from
    has come too (a `setpoint_js` stamped no earlier than the not-busy state: the two are topics of their own,
    and the state may come first); failed past its time bound."""

    def __init__(self, arm: CrtkArm, sent_at: float, what: str, bound: float) -> None:
        self._arm = arm
        self.sent_at = sent_at
        self.what = what
        self.bound = bound
        self._deadline = time.monotonic() + bound
        self.error: str | None = None
        self._done = False

    @property
    def status(self) -> MotionStatus:
        if self.error is not None:
            return MotionStatus.FAILED
        if self._done:
            return MotionStatus.DONE
        state = self._arm.operating_state
        if state.stamp > self.sent_at and not state.is_busy:
            if state.state != "ENABLED":
                self.error = f"{self.what}: {self._arm.name} is {state.state}"
                return MotionStatus.FAILED
            if self._arm.setpoint_js.stamp >= state.stamp:
                self._done = True
                return MotionStatus.DONE
        if time.monotonic() > self._deadline:
            self._arm.hold()
            self.error = f"{self.what} not done within {self.bound:.1f} s; held"
            return MotionStatus.FAILED
        return MotionStatus.BUSY

    def stop(self) -> None:
        if self.status is MotionStatus.BUSY:
            self._arm.hold()
            self.error = f"{self.what} stopped by the client"


class CrtkJaw:
    """The jaw of a CRTK PSM: `measured_js`, `setpoint_js`, `move_jp(angle)` (streamed)."""

    def __init__(self, arm: CrtkArm, measured: Latest[JointSample], setpoint: Latest[JointSample]) -> None:
        self._arm = arm
        self._measured = measured
        self._setpoint = setpoint
        self._last: tuple[StreamedMotion, float] | None = None  # the last ramp streamed, and its goal

    @property
    def measured_js(self) -> JointSample:
        return self._arm.read(self._measured)

    @property
    def setpoint_js(self) -> JointSample:
        return self._arm.read(self._setpoint)

    def move_jp(self, angle: float) -> StreamedMotion:
        """Open or close to `angle` at the jaw's velocity limit, the streamer's ramp (`streamer.jaw_ramp`):
        each set-point moves at most the limit's step (0.06 rad at 6 rad/s and 100 Hz), a tenth of the jaw
        actuator's tracking tolerance (`pegbt.sim.dvrk_config.ACTUATOR_TOLERANCE`). A ramp to `angle` still
        under way is that motion (a handover's receiver closes as its tip arrives and `grasp` then asks for
        the same close); a ramp to another goal takes over from the row the running one last sent, which
        only the streamer knows: the robot's set-point lags it, and a ramp from there would step the jaw
        back by more than the limit allows (refused, a handover's grasp failed and retried)."""
        settings = self._arm.settings
        guards.refuse_if(
            guards.jaw_problems(angle, settings), f"jaw goal {angle}", self._arm.topics.jaw_servo_jp.name
        )
        if self._last is not None and self._last[1] == angle and self._last[0].busy:
            return self._last[0]
        start = self._start()
        # the jaw is between the robot's set-point and the last ramp's goal: the ramp is at most the longer
        distance = max(abs(angle - start), 0.0 if self._last is None else abs(angle - self._last[1]))
        duration = max(distance / settings.jaw_velocity, settings.control_period)
        motion = self._arm.ramp_jaw(start, angle, f"{self._arm.name} jaw to {angle:.3f} rad", duration)
        self._last = (motion, angle)
        return motion

    def _start(self) -> float:
        """Where the next ramp starts unless the streamer still streams the jaw: the robot's set-point, or the
        goal of the last ramp once that is done and the set-point within a step of its goal (`taken_up`: the
        echo of the last row yet to come); a ramp from the row before would first step the jaw back."""
        setpoint = float(self.setpoint_js.position[0])
        if self._last is not None:
            motion, goal = self._last
            if motion.done and jaw_taken_up(setpoint, goal, self._arm.settings):
                return goal
        return setpoint


class CrtkArm:
    """One PSM of a CRTK robot on `wire`; trajectories go through `streamer`. Same verbs as `ArmClient`."""

    def __init__(
        self,
        wire: Ros2Wire,
        arm: str,
        *,
        settings: ArmSettings,
        streamer: Streamer,
        clock: Clock | None = None,
        liveness_timeout: float = LIVENESS_S,
    ) -> None:
        self.name = arm
        self.topics = PsmTopics(arm)
        self.settings = settings
        self.clock: Clock = clock or WallClock()
        self.liveness_timeout = liveness_timeout
        self._streamer = streamer
        self._messages: list[dict[str, Any]] = []
        self._last_error: str | None = None
        self._running = False  # `begin_run` was called: messages from then on are this run's
        self._last_message = time.monotonic()
        self._messages_lock = threading.Lock()
        self._kept_ready = False  # set once enabled and homed: from then on it must stay so
        self.speed = (
            1.0  # the fraction of its own trajectory limits the robot's move_jp runs at (`slow_down`)
        )
        topics = self.topics
        self._measured = self._latest(wire, topics.measured_js, codec.decode_joint_state)
        self._setpoint = self._latest(wire, topics.setpoint_js, codec.decode_joint_state)
        self._state = self._latest(
            wire, topics.operating_state, codec.decode_operating_state, lambda state: state.stamp
        )
        jaw_measured = self._latest(wire, topics.jaw_measured_js, codec.decode_joint_state)
        jaw_setpoint = self._latest(wire, topics.jaw_setpoint_js, codec.decode_joint_state)
        self.jaw = CrtkJaw(self, jaw_measured, jaw_setpoint)
        for level in MESSAGE_LEVELS:
            wire.subscriber(getattr(topics, level), partial(self._on_message, level))
        self._ratios = {
            kind: self._latest(wire, getattr(topics, f"trajectory_j_ratio_{kind}"), codec.decode_float64)
            for kind in ("v", "a")
        }
        self._set_ratio = {
            kind: wire.publisher(getattr(topics, f"trajectory_j_set_ratio_{kind}")) for kind in ("v", "a")
        }
        self._move = wire.publisher(topics.move_jp)
        self._hold = wire.publisher(topics.hold)
        self._state_command = wire.publisher(topics.state_command)

    @staticmethod
    def _latest(
        wire: Ros2Wire, topic: Any, decode: Callable[[bytes], T], stamp: Callable[[T], float] | None = None
    ) -> Latest[T]:
        latest = Latest(topic.name, decode, stamp)
        wire.subscriber(topic, latest.take)
        return latest

    def _on_message(self, level: str, payload: bytes) -> None:
        try:
            text = codec.decode_string(payload)
        except PegbtError as error:
            text = str(error)
        with self._messages_lock:
            self._last_message = time.monotonic()
            message = {"source": self.name, "level": level, "text": text, "stamp": self.clock.now()}
            if not self._running:
                message["before_run"] = True
            elif level == "error":
                self._last_error = text
            self._messages.append(message)

    def begin_run(self) -> None:
        """From now on the robot's messages are this run's. What its latched `error`, `warning` and `status`
        topics replayed on joining (up to 100 each, unstamped) is history: this waits until the replay is
        over (no message for `HISTORY_QUIET`, at most `HISTORY_WAIT`)."""
        deadline = time.monotonic() + HISTORY_WAIT
        while time.monotonic() < deadline:
            with self._messages_lock:
                quiet = time.monotonic() - self._last_message
                if quiet >= HISTORY_QUIET:
                    self._running = True
                    return
            time.sleep(HISTORY_QUIET - quiet)
        with self._messages_lock:
            self._running = True

    def drain_messages(self) -> list[dict[str, Any]]:
        """The robot's error, warning and status messages since the last call, oldest first."""
        with self._messages_lock:
            messages, self._messages = self._messages, []
        return messages

    # ------------------------------------------------------------------ liveness and reads
    @property
    def is_alive(self) -> bool:
        latest = self._measured.latest()
        return is_recent(None if latest is None else latest.received_at, self.liveness_timeout)

    def check_alive(self) -> None:
        """Raise `EndpointSilent` unless `measured_js` arrived within the liveness timeout, `ArmFaulted` if the
        robot put the arm in FAULT, and `ArmLeftReady` if, once `keep_ready()` was called, it is no longer
        ENABLED and homed."""
        latest = self._measured.latest()
        received_at = None if latest is None else latest.received_at
        check_recent(self.name, self.topics.measured_js.name, received_at, self.liveness_timeout, "robot")
        received = self._state.latest()
        if received is None:
            return
        state = received.value
        said = f" (the robot said: {self._last_error})" if self._last_error else ""
        if state.state == "FAULT":
            raise ArmFaulted(
                f"{self.name} is in FAULT{said}: the robot holds it there until a person disables and "
                "enables it; the run stops",
                field=self.topics.operating_state.name,
            )
        if self._kept_ready and (state.state != "ENABLED" or not state.is_homed):
            raise ArmLeftReady(
                f"{self.name} is {state.state}, {'homed' if state.is_homed else 'not homed'}{said}: the robot "
                "drops every command until it is enabled and homed again; the run stops",
                field=self.topics.operating_state.name,
            )

    def keep_ready(self) -> None:
        """From now on the arm must stay ENABLED and homed (`check_alive`): the dVRK drops the commands of an
        arm that is not (`mtsIntuitiveResearchKitArm.cpp` `ArmIsReady`), and leaves it so on its console's
        `disable` or `pause`, or on its own after an error (`Run`: an exception disables the arm)."""
        self._kept_ready = True

    def read(self, latest: Latest[T]) -> T:
        self.check_alive()
        received = latest.latest()
        if received is None:
            raise EndpointSilent(f"{self.name}: no {latest.topic} received yet", field=latest.topic)
        return received.value

    @property
    def measured_js(self) -> JointSample:
        return self.read(self._measured)

    def robot_now(self) -> float:
        """Now on the robot's clock, as far as the robot has said: the newest of its valid stamps (`measured_js`,
        `setpoint_js`, `operating_state`) plus the time since that message came. The dVRK stamps what it
        publishes with its own computer's ROS clock (cisst-ros `cisst_ros_bridge/include/cisst_ros_bridge/
        mtsCISSTToROS.h`, `cisst_header_to_ros_header`: now minus the data's age), so an `operating_state` is
        compared with a command's time on that clock, never on this computer's. A zero stamp (data the robot
        marks invalid: joints before the encoders are biased) says nothing of its clock and is skipped; the
        latched `operating_state`, stamped when it last changed, is then the newest: every state after it
        is newer. -inf if nothing stamped has come."""
        self.check_alive()
        now = time.monotonic()
        stamps = [
            received.value.stamp + (now - received.received_at)
            for received in (self._measured.latest(), self._setpoint.latest(), self._state.latest())
            if received is not None and received.value.stamp > 0
        ]
        return max(stamps, default=-np.inf)

    @property
    def setpoint_js(self) -> JointSample:
        return self.read(self._setpoint)

    @property
    def operating_state(self) -> OperatingState:
        return self.read(self._state)

    @property
    def fiducial_js(self) -> JointSample:
        raise PegbtError(
            f"{self.name}: a robot has no fiducial_js (an external tracker's joints)", field="fiducial_js"
        )

    def wait_until_ready(self, timeout: float) -> None:
        """Block until the robot has published this arm's joints, set-points and (latched) operating state."""
        for latest in (self._measured, self._setpoint, self._state, self.jaw._setpoint):
            if not latest.wait_until(lambda _: True, timeout):
                raise EndpointSilent(
                    f"{self.name}: nothing on {latest.topic} within {timeout:g} s", field=latest.topic
                )

    # ------------------------------------------------------------------ state commands
    def state_command(self, command: str) -> float:
        """CRTK state command (enable, disable, home, unhome, pause, resume); when it was sent, on the robot's
        clock (`robot_now`)."""
        sent_at = self.robot_now()
        self._state_command.put(codec.encode_string_stamped(self.clock.now(), command))
        return sent_at

    def await_state(self, condition: Callable[[OperatingState], bool], what: str, timeout: float) -> None:
        """Block until `operating_state` satisfies `condition`; else a `PegbtError` naming the arm, its state
        and the robot's last error or warning."""
        if self._state.wait_until(condition, timeout):
            return
        state = self.operating_state
        said = next(
            (
                f"; the robot said: {m['text']}"
                for m in reversed(self._messages)
                if m["level"] in ("error", "warning") and not m.get("before_run")
            ),
            "",
        )
        raise PegbtError(
            f"did not {what} within {timeout:g} s: it is {state.state}, "
            f"{'homed' if state.is_homed else 'not homed'}{', busy' if state.is_busy else ''}{said}",
            field=self.name,
        )

    def await_valid_joints(self, timeout: float) -> None:
        """Block until the joints and the jaw are valid: stamped no earlier than the homed state (the dVRK
        sends zeros stamped 0 before its encoders are biased, and the PID's seven joints until the tool
        engages: `mtsIntuitiveResearchKitArm.cpp` `get_robot_data`), six joints, one jaw angle."""
        homed = self.operating_state.stamp
        for latest, size in ((self._measured, 6), (self._setpoint, 6), (self.jaw._setpoint, 1)):
            if not latest.wait_until(lambda js: js.stamp >= homed and js.position.size == size, timeout):
                raise PegbtError(
                    f"homed, but no valid {latest.topic} within {timeout:g} s (stamped after the homed state, "
                    f"{size} joint{'s' if size > 1 else ''})",
                    field=self.name,
                )

    # ------------------------------------------------------------------ commands
    def slow_down(self, speed: float) -> None:
        """The robot's own `move_jp` and homing at `speed` (0, 1] of its velocity limits and `speed`² of its
        acceleration limits, so each takes 1 / `speed` as long. At 1 the ratios are only sent (a previous
        run may have left the robot slow; a dVRK before 2.3 has no such setting and ignores them); below 1,
        `PegbtError` if the robot does not confirm both within `RATIO_CONFIRM_S`."""
        wanted = {"v": speed, "a": speed**2}
        for kind, ratio in wanted.items():
            self._set_ratio[kind].put(codec.encode_float64(ratio))
        for kind, ratio in wanted.items() if speed < 1.0 else ():
            latest = self._ratios[kind]
            if not latest.wait_until(partial(_is_ratio, ratio), RATIO_CONFIRM_S):
                raise PegbtError(
                    f"the robot did not confirm its move_jp and homing at {ratio:g} of its "
                    f"{'velocity' if kind == 'v' else 'acceleration'} limits within {RATIO_CONFIRM_S:g} s on "
                    f"{latest.topic}: --speed below 1 needs a dVRK 2.3 or later (its own moves would run "
                    "at full speed)",
                    field="--speed",
                )
        self.speed = speed

    def hold(self) -> None:
        """The robot's `hold`: stay at the current set-point."""
        self._hold.put(codec.encode_empty())

    def move_jp(self, target: ArrayLike | TrajectoryLike) -> RobotMove | StreamedMotion:
        """To a joint goal (the robot's own `move_jp`), or along a planned trajectory (streamed)."""
        if not isinstance(target, TrajectoryLike):
            return self._move_goal(np.asarray(target, dtype=float).reshape(-1))
        topic = self.topics.servo_jp.name
        guards.refuse_if(guards.trajectory_problems(target, self.settings), "trajectory", topic)
        t, q = np.asarray(target.t, dtype=float), np.asarray(target.q, dtype=float)
        lead = max(float(t[0]), self.settings.control_period)
        guards.refuse_if(
            guards.step_problems(q[0], self.setpoint_js.position, self.settings, lead),
            "trajectory start",
            topic,
        )
        return self.stream("arm", t - t[0], q, f"{self.name} trajectory", float(t[-1] - t[0]))

    def _move_goal(self, goal: NDArray[np.float64]) -> RobotMove:
        what = f"{self.name} move_jp to {np.round(goal, 4).tolist()}"
        guards.refuse_if(guards.joint_problems(goal, self.settings), what, self.topics.move_jp.name)
        bound = 2 * rest_to_rest_bound(self.setpoint_js.position, goal, self.speed) + MOVE_MARGIN
        sent_at = self.robot_now()
        self._move.put(codec.encode_joint_state(self.clock.now(), goal))
        return RobotMove(self, sent_at, what, bound)

    def stream(
        self, axis: str, t: NDArray[np.float64], q: NDArray[np.float64], what: str, duration: float
    ) -> StreamedMotion:
        """Hand a checked trajectory of `axis` (`arm` or `jaw`) to the streamer."""
        self.check_alive()
        motion_id = self._streamer.play(self.name, axis, t, q)
        return self._follow(axis, motion_id, np.asarray(q, dtype=float)[-1], what, duration)

    def ramp_jaw(self, start: float, goal: float, what: str, duration: float) -> StreamedMotion:
        """Hand a checked jaw goal to the streamer's ramp (`Streamer.ramp`), from `start` unless the jaw's
        stream is still going; it takes at most `duration`."""
        self.check_alive()
        motion_id = self._streamer.ramp(self.name, start, goal)
        return self._follow("jaw", motion_id, np.array([goal]), what, duration)

    def _follow(
        self, axis: str, motion_id: int, end: NDArray[np.float64], what: str, duration: float
    ) -> StreamedMotion:
        """The handle of a streamed motion of `axis` ending at `end`."""

        def arrived() -> bool:
            if axis == "arm":
                return taken_up(self.read(self._setpoint).position, end, self.settings)
            return jaw_taken_up(
                float(self.read(self.jaw._setpoint).position[0]), float(end[0]), self.settings
            )

        # a robot allowed to fall silent for the liveness timeout may report its set-point that much later
        margin = max(MOTION_MARGIN, 2 * self.liveness_timeout)
        return StreamedMotion(
            self._streamer, motion_id, what, duration, self.check_alive, arrived, margin, self._check_fault
        )

    def _check_fault(self) -> None:
        """The streamer stops a motion when it sees the arm leave ENABLED; this client's own copy of that
        state arrives on its own subscription about then: wait for it (bounded), so a FAULT, or an arm
        disabled or paused, stops the run."""
        self._state.wait_until(lambda state: state.state != "ENABLED", STATE_CONFIRM_S)
        self.check_alive()


def taken_up(setpoint: ArrayLike, end: ArrayLike, settings: ArmSettings) -> bool:
    """Whether a streamed arm trajectory whose last set-point has been sent may count as done with the robot's
    `setpoint_js` at `setpoint`: within one control period's step of the `end` at the velocity limits,
    what the robot accepts as the next trajectory's start (`move_jp`'s check) and the next plan's
    (`ArmMotion.stale`). The echo of the last row itself comes a state message later (about 8 ms a motion
    against the simulator), which every motion of a transfer would add in turn."""
    return not guards.step_problems(end, setpoint, settings, settings.control_period)


def jaw_taken_up(setpoint: float, goal: float, settings: ArmSettings) -> bool:
    """Whether a streamed jaw ramp whose last set-point has been sent may count as done with the robot's jaw
    set-point at `setpoint`: within one control period's step of the `goal` at the jaw's velocity, as an arm
    (`taken_up`); the next ramp starts from the goal (`CrtkJaw._start`). The echo of the last row came a
    state message later, which each jaw-only leaf (a handover's release) waited for."""
    return not guards.jaw_step_problems(goal, setpoint, settings, settings.control_period)


def _is_ratio(wanted: float, value: float) -> bool:
    return abs(value - wanted) < 1e-9


def make_ready(
    arms: list[CrtkArm],
    enable_timeout: float = ENABLE_TIMEOUT,
    home_timeout: float = HOME_TIMEOUT,
    speed: float = 1.0,
) -> None:
    """Enable every arm that is not, then home every arm that is not homed; each step bounded in time; from
    then on each must stay enabled and homed (`CrtkArm.keep_ready`). First each arm's own moves are set to
    `speed` (`CrtkArm.slow_down`), homing too, whose bound grows as it slows.

    An arm just enabled is homed too, even if it says it is: a dVRK arm homed, disabled and enabled again
    reports `is_homed` (its encoders are still biased) but acts only once homed again, which is then quick
    (`mtsIntuitiveResearchKitArm.cpp`: `TransitionEnabled`, `RunHomed`; `is_homed` in `...PSM.cpp`)."""
    for arm in arms:
        arm.begin_run()
    for arm in arms:
        arm.slow_down(speed)
    home_timeout /= speed
    enabled = [arm for arm in arms if arm.operating_state.state != "ENABLED"]
    for arm in enabled:
        arm.state_command("enable")
    for arm in arms:
        arm.await_state(lambda s: s.state == "ENABLED" and not s.is_busy, "enable", enable_timeout)
    homing = {
        arm.name: arm.state_command("home")
        for arm in arms
        if arm in enabled or not arm.operating_state.is_homed
    }
    for arm in arms:
        after = homing.get(arm.name, -np.inf)  # a state from before the command (homed, say) does not count
        arm.await_state(
            lambda s: s.stamp > after and s.state == "ENABLED" and s.is_homed and not s.is_busy,
            "home",
            home_timeout,
        )
    for arm in arms:
        arm.await_valid_joints(enable_timeout)
        arm.keep_ready()
