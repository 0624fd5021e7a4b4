"""`pegbt sim --interface dvrk`: the simulator behind the topics a dVRK 2.x PSM serves, and a depth camera
that streams as a RealSense does or captures when asked as a Zivid does (`pegbt.sim.zivid`), in real time.

Every topic is declared through a `Ros2Wire` (`pegbt.transport.dvrk_topics` names them), so the same
endpoint serves zenoh-bridge-ros2dds's keys (`BridgeWire`) or another wire's; it builds no key itself, and
serves nothing else: no `follow_jt`, no `sim/*` key, no attachment; it takes one command a dVRK takes from a
person, not a topic: each arm's clutch button (`clutch_button_topic`), which it reports as the dVRK's IO
board does (`PSMn/IO/arm_clutch`). The arms are `DvrkArm`s (the dVRK's
controller over the simulator's joints and cable physics), acting in the same world as the pegbt
interface's arms (`Scene`).

One thread owns the simulation. Zenoh callbacks only put what arrives in an inbox; the loop applies each
command as it comes (what the arm says about it goes out at once), and every control period advances the
arms, moves the world, publishes the joint and Cartesian states (every `state_period`), the operating
state whenever the arm updates it (changed or not, as the dVRK does), and a point cloud every
`camera_period` (a Zivid: once per capture request). What the robot sends is stamped on the robot computer's
clock, `robot_clock_offset` s from this one's (the dVRK stamps with its own ROS clock: cisst-ros
`cisst_ros_bridge/include/cisst_ros_bridge/mtsCISSTToROS.h`, `cisst_header_to_ros_header`, which writes an
invalid datum's stamp as 0); the camera, another device, stamps on this computer's. A control period that
starts a period or more late is an overrun, written to the simulator's log with how late it was; so is
every safety event of the arms (a clip, a dropped command, a tracking-error fault). The log (`--log`) stays
the judge.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pegbt.errors import PegbtError
from pegbt.motion.kinematics import forward_kinematics
from pegbt.motion.limits import arm_settings
from pegbt.physics import ArmPhysics
from pegbt.psm import ARMS
from pegbt.sim import dvrk_config as dvrk
from pegbt.sim.arm import DEFAULT_JOINTS, DEFAULT_SERVO_TAU
from pegbt.sim.camera_stream import CameraStream
from pegbt.sim.dvrk_arm import DvrkArm
from pegbt.sim.interfaces import SimWorld, StreamingCamera
from pegbt.sim.log import SimLog
from pegbt.sim.scene import Scene
from pegbt.sim.zivid import ZividDriver
from pegbt.transport import codec
from pegbt.transport.dvrk_topics import PsmTopics, clutch_button_topic, point_cloud_topic
from pegbt.transport.endpoints import DEFAULT_POINTS_TOPIC
from pegbt.transport.ros2 import Ros2Wire, Topic, TopicPublisher, TopicSubscriber

CAMERA_FRAME = "camera_depth_optical_frame"  # realsense2_camera's frame of its depth cloud
TRACKING_GRACE = 0.1  # s after a skip: the queued set-points applied, the encoders settle (92 % a period)
CAMERA_BUDGET = 0.3  # of each control period, at most, for rendering the camera's frame


@dataclass(frozen=True)
class DvrkEndpointConfig:
    """The arms, their cable physics and start, the log file, and how often states and clouds go out."""

    arms: tuple[str, ...] = ARMS
    physics: str = "ideal"  # preset name or a JSON file (preset or sim-to-real report)
    log_path: Path | None = None
    initial_joints: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    servo_tau: float = DEFAULT_SERVO_TAU
    state_period: float = dvrk.PUBLISH_PERIOD
    camera_topic: str = DEFAULT_POINTS_TOPIC
    camera_period: float = 0.1
    camera: str = "stream"  # "stream": a RealSense's; "zivid": the Zivid driver's capture service
    robot_clock_offset: float = 0.0  # s the robot computer's clock is ahead of this one's


class OverrunWatch:
    """Control periods that start late: each run of them is one `overrun` entry in the log, saying when it
    began (s), how many periods ran late and the worst lateness. Far behind (a busy machine), the loop
    skips periods rather than bursting through them, and the entry counts them as skipped."""

    def __init__(self, period: float, log: SimLog) -> None:
        self._period = period
        self._log = log
        self._began: float | None = None
        self._late_ticks = 0
        self._worst = 0.0
        self._skipped = 0

    def check(self, now: float, due: float, elapsed: float) -> float:
        """The due time of the period starting at wall time `now` (epoch s), moved on if skipping."""
        late = now - due
        if late < self._period:
            if self._began is not None:
                self._log.record(
                    self._began,
                    "overrun",
                    periods=self._late_ticks,
                    worst_late=round(self._worst, 6),
                    skipped=self._skipped,
                )
                self._began, self._late_ticks, self._worst, self._skipped = None, 0, 0.0, 0
            return due
        if self._began is None:
            self._began = elapsed
        self._late_ticks += 1
        self._worst = max(self._worst, late)
        if late > 10 * self._period:
            skipped = int(late // self._period)
            self._skipped += skipped
            return due + skipped * self._period
        return due


class DvrkEndpoint:
    """The simulated PSMs and camera behind their ROS 2 topics. `run()` serves until `stop()`."""

    def __init__(
        self,
        wire: Ros2Wire,
        config: DvrkEndpointConfig = DvrkEndpointConfig(),
        *,
        world: SimWorld | None = None,
        camera: StreamingCamera | None = None,
    ) -> None:
        if camera is not None and world is None:
            raise PegbtError("a camera needs a world to look at", field="camera")
        self.config = config
        self.world = world
        self.camera = camera
        self.arms = {
            name: DvrkArm(
                name,
                arm_settings(name),
                ArmPhysics.load(config.physics, name),
                q0=config.initial_joints.get(name, DEFAULT_JOINTS),
                servo_tau=config.servo_tau,
            )
            for name in config.arms
        }
        self.period = next(iter(self.arms.values())).period
        self.topics = {name: PsmTopics(name) for name in self.arms}
        self.log = SimLog(config.log_path)
        self._scene = Scene(world, {n: a.sim for n, a in self.arms.items()}, self.log) if world else None
        self.start_time = time.time()
        self.time = self.start_time
        self._inbox: queue.Queue[tuple[str, Callable[[bytes], None], bytes]] = queue.Queue()
        self._stop = threading.Event()
        self._logged_states: dict[str, tuple[str, str, bool, bool]] = {}
        self._publishers: dict[str, TopicPublisher] = {}
        self._subscribers: list[TopicSubscriber] = []
        self._overrun = OverrunWatch(self.period, self.log)
        zivid = config.camera == "zivid" and camera is not None and world is not None
        self._camera = (
            CameraStream(camera, world, config.camera_period, self.period, CAMERA_BUDGET, CAMERA_FRAME)
            if camera is not None and world is not None and not zivid
            else None
        )
        self._zivid: ZividDriver | None = None
        if zivid:
            assert camera is not None and world is not None  # zivid says so
            self._zivid = ZividDriver(wire, camera, world, self.period, CAMERA_BUDGET)
        self._declare(wire)

    # ------------------------------------------------------------------ wiring
    def _declare(self, wire: Ros2Wire) -> None:
        """A publisher for every topic the arms (and the camera) publish, a subscriber for every command."""
        published = [topic for topics in self.topics.values() for topic in topics.published()]
        if self._camera is not None:
            published.append(point_cloud_topic(self.config.camera_topic))
        for topic in published:
            self._publishers[topic.name] = wire.publisher(topic)
        for name, topics in self.topics.items():
            arm = self.arms[name]
            handlers: dict[Topic, Callable[[bytes], None]] = {
                topics.servo_jp: _joint_command(arm.servo_jp),
                topics.move_jp: _joint_command(arm.move_jp),
                topics.jaw_servo_jp: _joint_command(arm.jaw_servo_jp),
                topics.jaw_move_jp: _joint_command(arm.jaw_move_jp),
                topics.hold: _void_command(arm.hold),
                topics.state_command: _string_command(arm.state_command),
                clutch_button_topic(name): _button(partial(self._clutch, name)),
                topics.trajectory_j_set_ratio_v: _float_command(partial(self._ratio, name, "v")),
                topics.trajectory_j_set_ratio_a: _float_command(partial(self._ratio, name, "a")),
            }
            for topic, handler in handlers.items():
                self._subscribers.append(wire.subscriber(topic, partial(self._arrived, name, handler)))

    def _clutch(self, name: str, pressed: bool) -> None:
        """A person presses or releases `name`'s clutch: its IO board reports the button whatever the arm's
        state (sawIntuitiveResearchKit `ros/dvrk_robot/src/system_ROS.cpp`, `add_topics_PSM_IO`), then the
        arm reacts (`DvrkArm.clutch`)."""
        self._put(self.topics[name].io_arm_clutch, codec.encode_button(self.robot_time, pressed))
        self.arms[name].clutch(pressed)

    def _ratio(self, name: str, kind: str, ratio: float) -> None:
        """Arm.cpp `trajectory_j_set_ratio_v` / `_a`: taken, the arm publishes its new ratio (an event)."""
        if self.arms[name].trajectory_j_set_ratio(kind, ratio):
            self._put(getattr(self.topics[name], f"trajectory_j_ratio_{kind}"), codec.encode_float64(ratio))

    def _arrived(self, arm: str, handler: Callable[[bytes], None], payload: bytes) -> None:
        self._inbox.put((arm, handler, payload))

    # ------------------------------------------------------------------ the loop
    def stop(self) -> None:
        self._stop.set()

    @property
    def elapsed(self) -> float:
        """Seconds since the simulator started (the log's times)."""
        return self.time - self.start_time

    def run(self) -> str:
        """Serve until stopped; returns "stopped"."""
        self.log.record(
            0.0,
            "start",
            mode="realtime",
            interface="dvrk",
            epoch=self.start_time,  # the wall time the log's times count from (a judge on another clock)
            physics=self.config.physics,
            arms=list(self.arms),
            state_period=self.config.state_period,
            camera_period=self.config.camera_period if self._camera is not None else None,
            camera=self.config.camera if self.camera is not None else None,
        )
        if self._scene is not None:
            self._scene.update(0.0)
        self._report()
        self._publish_states()
        next_tick = time.time() + self.period
        next_state = self.config.state_period
        while not self._stop.is_set():
            try:
                item = self._inbox.get(timeout=max(0.0, next_tick - time.time()))
            except queue.Empty:
                item = None
            if item is not None:
                self._command(*item)
            now = time.time()
            if now < next_tick:
                continue
            due = self._overrun.check(now, next_tick, next_tick - self.start_time)
            if due != next_tick:
                self._excuse_tracking(due, due - next_tick)
            next_tick = due
            self.time = next_tick
            self._tick()
            if self.elapsed >= next_state - self.period / 2:  # epoch-based times are only µs-exact
                self._publish_states()
                next_state = max(next_state, self.elapsed) + self.config.state_period
            if self._camera is not None:
                self._stream()
            if self._zivid is not None and self._zivid.step(self.elapsed) and self._scene is not None:
                self._scene.log_events()  # a noise burst is the capture's event
            next_tick += self.period
        return "stopped"

    def _excuse_tracking(self, due: float, skipped: float) -> None:
        """The loop skipped `skipped` s of control periods (a busy machine) and resumes at `due` (epoch s): the
        set-points that queued meanwhile are applied at once. Until the arms have settled on them, a tracking
        error is the simulator's lateness, not the client's commands; the log says so."""
        until = due - self.start_time + TRACKING_GRACE
        for arm in self.arms.values():
            arm.excuse_tracking(until)
        self.log.record(self.elapsed, "tracking_excused", until=round(until, 6), skipped=round(skipped, 6))

    def _command(self, arm: str, handler: Callable[[bytes], None], payload: bytes) -> None:
        """Apply one command now; a payload that is not the topic's message is dropped and logged."""
        self.arms[arm].now = self.elapsed
        try:
            handler(payload)
        except PegbtError as error:
            self.log.record(self.elapsed, "safety", event="undecodable", arm=arm, reason=error.message)
        self._report()

    def _tick(self) -> None:
        for arm in self.arms.values():
            arm.advance(self.elapsed)
        if self._scene is not None:
            self._scene.update(self.elapsed)
        self._report()

    # ------------------------------------------------------------------ publishing
    def _put(self, topic: Topic, payload: bytes) -> None:
        self._publishers[topic.name].put(payload)

    @property
    def robot_time(self) -> float:
        """Now on the robot computer's clock: the time the loop is at, `robot_clock_offset` from this one's."""
        return self.time + self.config.robot_clock_offset

    def _report(self) -> None:
        """What each arm said (status, warning, error), its safety events and its operating state if the arm
        updated it."""
        stamp = max(self.time, time.time()) + self.config.robot_clock_offset
        for name, arm in self.arms.items():
            topics = self.topics[name]
            for report in arm.reports:
                self._put(getattr(topics, report.topic), codec.encode_string(report.text))
            for event in arm.safety:
                self.log.record(
                    self.elapsed,
                    "safety",
                    event=event.event,
                    arm=name,
                    command=event.command,
                    **event.details,
                )
            arm.reports.clear()
            arm.safety.clear()
            for update in arm.state_events:
                state = codec.OperatingState(stamp, update.state, update.is_homed, update.is_busy)
                self._put(topics.operating_state, codec.encode_operating_state(state))
                logged = (update.state, update.substate, update.is_homed, update.is_busy)
                if self._logged_states.get(name) != logged:
                    self._logged_states[name] = logged
                    self.log.record(
                        self.elapsed,
                        "arm_state",
                        arm=name,
                        state=update.state,
                        substate=update.substate,
                        is_homed=update.is_homed,
                        is_busy=update.is_busy,
                    )
            arm.state_events.clear()

    def _publish_states(self) -> None:
        """Joint and Cartesian states of every arm and its jaw, and the fiducial tracker's joints; what the
        arm does not have valid yet is sent as the dVRK sends it (`_joint_states`)."""
        stamp = self.robot_time
        for name, arm in self.arms.items():
            topics = self.topics[name]
            for topic, payload in self._joint_states(arm, stamp):
                self._put(getattr(topics, topic), payload)
            self._put(
                topics.fiducial_js, codec.encode_joint_state(stamp, arm.sim.physical, names=dvrk.JOINT_NAMES)
            )

    @staticmethod
    def _joint_states(arm: DvrkArm, stamp: float) -> list[tuple[str, bytes]]:
        """What the dVRK's bridge sends of `arm` (mtsIntuitiveResearchKitArm.cpp `get_robot_data`,
        mtsIntuitiveResearchKitPSM.cpp `UpdateStateJointKinematics`): before its joints are ready, seven
        zeros stamped 0 (invalid); then, until the tool engages, the PID's seven joints; then the six joints.
        The jaw and the Cartesian poses are stamped 0 until the tool engages."""
        joints, jaw, base = arm.sim.joints, arm.sim.jaw, f"{arm.name}_base"
        encode_js, encode_cp = codec.encode_joint_state, codec.encode_pose_stamped
        if arm.cartesian_ready:
            measured, setpoint, velocity = joints.encoder, joints.setpoint, joints.velocity
            names: tuple[str, ...] = dvrk.JOINT_NAMES
            kinematic = stamp
        elif arm.joint_ready:
            measured, setpoint = dvrk.pid_positions(arm.measured), dvrk.pid_positions(arm.setpoint)
            velocity = dvrk.pid_positions(np.concatenate([joints.velocity, jaw.velocity]))
            names, kinematic = dvrk.PID_NAMES, stamp
        else:
            measured = setpoint = velocity = np.zeros(len(dvrk.PID_NAMES))
            names, kinematic = dvrk.PID_NAMES, 0.0
        cartesian = stamp if arm.cartesian_ready else 0.0
        jaw_measured = jaw.encoder if arm.cartesian_ready else np.zeros(1)
        jaw_setpoint = jaw.setpoint if arm.cartesian_ready else np.zeros(1)
        return [
            ("measured_js", encode_js(kinematic, measured, velocity, names=names)),
            ("setpoint_js", encode_js(kinematic, setpoint, names=names)),
            ("measured_cp", encode_cp(cartesian, forward_kinematics(joints.encoder), base)),
            ("setpoint_cp", encode_cp(cartesian, forward_kinematics(joints.setpoint), base)),
            ("jaw_measured_js", encode_js(cartesian, jaw_measured, jaw.velocity, names=dvrk.JAW_NAMES)),
            ("jaw_setpoint_js", encode_js(cartesian, jaw_setpoint, names=dvrk.JAW_NAMES)),
        ]

    def _stream(self) -> None:
        assert self._camera is not None and self._scene is not None
        topic = point_cloud_topic(self.config.camera_topic)
        cloud = self._camera.step(self.elapsed, self.time, listened=self._publishers[topic.name].matched)
        if cloud is not None:
            self._scene.log_events()  # a noise burst is the camera's event
            self._put(topic, cloud)

    # ------------------------------------------------------------------ shutdown
    def close(self) -> None:
        if self._zivid is not None:
            self._zivid.close()
        for entity in (*self._subscribers, *self._publishers.values()):
            entity.close()
        self._subscribers.clear()
        self._publishers.clear()
        self.log.close()


def _joint_command(command: Callable[[NDArray[np.float64]], None]) -> Callable[[bytes], None]:
    """A JointState command (servo_jp, move_jp and the jaw's): its positions."""
    return lambda payload: command(codec.decode_joint_state(payload).position)


def _string_command(command: Callable[[str], None]) -> Callable[[bytes], None]:
    """A crtk_msgs/StringStamped command (state_command): its string."""
    return lambda payload: command(codec.decode_string_stamped(payload)[1])


def _button(command: Callable[[bool], None]) -> Callable[[bytes], None]:
    """A button event (sensor_msgs/Joy): pressed or released."""
    return lambda payload: command(codec.decode_button(payload))


def _float_command(command: Callable[[float], None]) -> Callable[[bytes], None]:
    """A std_msgs/Float64 command (a trajectory ratio)."""
    return lambda payload: command(codec.decode_float64(payload))


def _void_command(command: Callable[[], None]) -> Callable[[bytes], None]:
    """A std_msgs/Empty command (hold): nothing to read."""
    return lambda payload: command()
