"""A small CRTK robot double written with raw zenoh and rosbags (none of pegbt's transport): two PSMs as a
dVRK 2.x serves them through zenoh-bridge-ros2dds, and a streaming depth camera.

What it reproduces, from jhu-dvrk/sawIntuitiveResearchKit `core/components/code/mtsIntuitiveResearchKitArm.cpp`:
DISABLED at start; `enable` powers up (busy, then ENABLED); `home` is a motion that takes seconds (busy,
then homed), or never ends with an error; `operating_state` published on change only, from a zenoh-ext
advanced publisher's cache (latched); a command to an arm not ready is dropped with a throttled
"arm not ready" warning (`ArmIsReady`); a set-point outside the joint limits is clipped (`clip_jp`);
`hold` stays at the set-point; until the arm is enabled and homed its joints are invalid: seven zeros
stamped 0 (`get_robot_data`; cisst-ros writes an invalid datum's stamp as 0); the clutch (`clutch`) puts a
ready arm in MANUAL, ENABLED, homed and busy, where a `servo_jp` is still executed
(`mtsIntuitiveResearchKitPSM.cpp`, `EventHandlerManipClutch`, `RunManual`), the button reported on
`PSMn/IO/arm_clutch` (sensor_msgs/Joy, latched); `trajectory_j/set_ratio_v` and `_a` slow its `move_jp` and
homing, each ratio confirmed on `trajectory_j/ratio_v`, `_a` (dVRK 2.3+, `trajectory_j_set_ratio_v`); `error`, `warning` and
`status` are latched with a depth of 100 (cisst-ros `mtsROSBridge.h`), and `old_errors` of them were said
before anybody joined. It records every command it receives, with its zenoh attachment.
"""

from __future__ import annotations

import json
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

# crtk_msgs/msg/OperatingState.msg and StringStamped.msg (collaborative-robotics/crtk_msgs)
_STORE = get_typestore(Stores.ROS2_HUMBLE)
_STORE.register(
    get_types_from_msg(
        "std_msgs/Header header\nstring state\nbool is_homed\nbool is_busy\n", "crtk_msgs/msg/OperatingState"
    )
)
_STORE.register(get_types_from_msg("std_msgs/Header header\nstring string\n", "crtk_msgs/msg/StringStamped"))
T = _STORE.types
# the dVRK's PSM and large needle driver limits (share/kinematic/PSM.json, share/tool/LARGE_NEEDLE_DRIVER_400006.json)
LOWER = np.array([-1.588, -0.925025, 0.0, -4.53786, -1.39626, -1.39626])
UPPER = np.array([1.588, 0.925025, 0.24, 4.53786, 1.39626, 1.39626])
START = np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])


def header(stamp: float) -> Any:
    sec = int(stamp)
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=int((stamp - sec) * 1e9)), frame_id=""
    )


def cdr(message: Any) -> bytes:
    return bytes(_STORE.serialize_cdr(message, message.__msgtype__))


def joint_state(q: np.ndarray, stamp: float) -> bytes:
    return cdr(
        T["sensor_msgs/msg/JointState"](
            header=header(stamp),
            name=[],
            position=np.asarray(q, dtype=float),
            velocity=np.zeros(0),
            effort=np.zeros(0),
        )
    )


def cloud(points: np.ndarray, stamp: float) -> bytes:
    """An organised PointCloud2 with x, y, z and rgb float32 fields (16-byte points), as a RealSense sends."""
    field_type = T["sensor_msgs/msg/PointField"]
    fields = [
        field_type(name=n, offset=4 * i, datatype=7, count=1) for i, n in enumerate(("x", "y", "z", "rgb"))
    ]
    data = np.column_stack([points, np.zeros(len(points))]).astype("<f4")
    return cdr(
        T["sensor_msgs/msg/PointCloud2"](
            header=header(stamp),
            height=2,
            width=len(points) // 2,
            fields=fields,
            is_bigendian=False,
            point_step=16,
            row_step=16 * (len(points) // 2),
            data=data.view(np.uint8).reshape(-1),
            is_dense=False,
        )
    )


def session_config(listen: str) -> zenoh.Config:
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps("peer"))
    config.insert_json5("listen/endpoints", json.dumps([listen]))
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("scouting/gossip/enabled", "false")
    config.insert_json5("timestamping/enabled", "true")
    return config


@dataclass
class Received:
    key: str
    at: float  # time.monotonic()
    attachment: bytes | None
    message: Any


@dataclass
class ArmDouble:
    name: str
    state: str = "DISABLED"
    homed: bool = False
    busy: bool = False
    setpoint: np.ndarray = field(default_factory=lambda: START.copy())
    jaw: float = 0.0
    last_warning: float = -10.0
    clips: int = 0
    setpoint_quiet_until: float = 0.0  # monotonic time before which setpoint_js is not published
    manual: bool = False  # its clutch is pressed
    biased: bool = False  # its encoders biased: on `home`, before the homing motion
    ratio: dict[str, float] = field(default_factory=lambda: {"v": 1.0, "a": 1.0})  # trajectory_j ratios

    @property
    def joints_valid(self) -> bool:
        return self.state == "ENABLED" and (self.homed or self.biased)


class CrtkDouble:
    """Serve two PSMs and a camera on `listen`; see the module docstring."""

    def __init__(
        self,
        listen: str,
        *,
        enabled: bool = False,
        homed: bool = False,
        home_seconds: float = 0.5,
        homes: bool = True,
        camera_topic: str = "camera/camera/depth/color/points",
        move_seconds: float = 0.3,
        clock_offset: float = 0.0,
        latched: bool = True,
        setpoint_lag: float = 0.0,
        old_errors: int = 0,
        ratios: bool = True,
        camera_period: float = 0.1,
    ) -> None:
        self.session = zenoh.open(session_config(listen))
        self.camera_period = camera_period
        self.ratios = ratios  # False: a dVRK before 2.3, which has no trajectory_j ratio
        self.home_seconds, self.homes, self.move_seconds = home_seconds, homes, move_seconds
        self.clock_offset = clock_offset
        # s a move_jp's not-busy state goes ahead of the set-point at its goal: setpoint_js is a topic of its
        # own, whose messages may come later than operating_state's
        self.setpoint_lag = setpoint_lag
        self.received: list[Received] = []
        self.arms = {
            name: ArmDouble(name, "ENABLED" if enabled else "DISABLED", homed) for name in ("PSM1", "PSM2")
        }
        self._lock = threading.RLock()
        self._timers: list[tuple[float, Any]] = []
        self._pub: dict[str, Any] = {}
        self._entities: list[Any] = []
        for arm in self.arms:
            for topic in ("measured_js", "setpoint_js", "jaw/measured_js", "jaw/setpoint_js"):
                self._pub[f"{arm}/{topic}"] = self.session.declare_publisher(f"{arm}/{topic}")
            for topic in (
                "error",
                "warning",
                "status",
                "IO/arm_clutch",
                "trajectory_j/ratio_v",
                "trajectory_j/ratio_a",
            ):  # latched, depth 100
                self._pub[f"{arm}/{topic}"] = zenoh.ext.declare_advanced_publisher(
                    self.session,
                    f"{arm}/{topic}",
                    cache=zenoh.ext.CacheConfig(max_samples=100),
                    publisher_detection=True,
                )
            # unlatched: a bridge whose cache a late joiner's advanced subscriber cannot query
            self._pub[f"{arm}/operating_state"] = (
                zenoh.ext.declare_advanced_publisher(
                    self.session,
                    f"{arm}/operating_state",
                    cache=zenoh.ext.CacheConfig(max_samples=1),
                    publisher_detection=True,
                )
                if latched
                else self.session.declare_publisher(f"{arm}/operating_state")
            )
            for topic in (
                "servo_jp",
                "jaw/servo_jp",
                "move_jp",
                "jaw/move_jp",
                "hold",
                "state_command",
                "trajectory_j/set_ratio_v",
                "trajectory_j/set_ratio_a",
            ):
                self._entities.append(
                    self.session.declare_subscriber(
                        f"{arm}/{topic}", lambda s, a=arm, t=topic: self._on(a, t, s)
                    )
                )
            self._publish_state(self.arms[arm])
            for n in range(old_errors):
                self.say(arm, "error", f"old error {n}, from before the run")
        self._camera = self.session.declare_publisher(camera_topic)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ what the robot says
    def now(self) -> float:
        """The robot computer's clock, `clock_offset` s from this one's: the dVRK stamps what it publishes with
        its own ROS clock (cisst-ros `cisst_ros_bridge/include/cisst_ros_bridge/mtsCISSTToROS.h`,
        `cisst_header_to_ros_header`: now minus the data's age), which need not agree with its clients'."""
        return time.time() + self.clock_offset

    def _publish_state(self, arm: ArmDouble) -> None:
        message = T["crtk_msgs/msg/OperatingState"](
            header=header(self.now()), state=arm.state, is_homed=arm.homed, is_busy=arm.busy
        )
        self._pub[f"{arm.name}/operating_state"].put(cdr(message))

    def say(self, arm: str, level: str, text: str) -> None:
        self._pub[f"{arm}/{level}"].put(cdr(T["std_msgs/msg/String"](data=f"{arm}: {text}")))

    def _later(self, seconds: float, action: Any) -> None:
        self._timers.append((time.monotonic() + seconds, action))

    # ------------------------------------------------------------------ commands
    def _on(self, name: str, topic: str, sample: zenoh.Sample) -> None:
        payload = sample.payload.to_bytes()
        kinds = {
            "state_command": "crtk_msgs/msg/StringStamped",
            "hold": "std_msgs/msg/Empty",
            "trajectory_j/set_ratio_v": "std_msgs/msg/Float64",
            "trajectory_j/set_ratio_a": "std_msgs/msg/Float64",
        }
        message = _STORE.deserialize_cdr(payload, kinds.get(topic, "sensor_msgs/msg/JointState"))
        attachment = None if sample.attachment is None else sample.attachment.to_bytes()
        with self._lock:
            self.received.append(Received(str(sample.key_expr), time.monotonic(), attachment, message))
            arm = self.arms[name]
            if topic == "state_command":
                self._state_command(arm, message.string)
            elif topic.startswith("trajectory_j/set_ratio_"):  # Arm.cpp trajectory_j_set_ratio_v, _a
                if not self.ratios:
                    return
                kind = topic[-1]
                if 0.0 < message.data <= 1.0:
                    arm.ratio[kind] = float(message.data)
                    ratio = T["std_msgs/msg/Float64"](data=float(message.data))
                    self._pub[f"{name}/trajectory_j/ratio_{kind}"].put(cdr(ratio))
            elif not (arm.state == "ENABLED" and arm.homed):
                if time.monotonic() - arm.last_warning > 2.0:  # throttled, as ArmIsReady does
                    arm.last_warning = time.monotonic()
                    self.say(name, "warning", f"{topic}, arm not ready")
            elif topic == "servo_jp":
                goal = np.asarray(message.position, dtype=float)
                clipped = np.clip(goal, LOWER, UPPER)
                arm.clips += int(not np.array_equal(goal, clipped))
                arm.setpoint = clipped
            elif topic == "jaw/servo_jp":
                arm.jaw = float(message.position[0])
            elif topic == "move_jp":
                arm.busy = True
                self._publish_state(arm)
                goal = np.clip(np.asarray(message.position, dtype=float), LOWER, UPPER)
                # the profile's cruise at ratio_v, its ramps at ratio_a: no faster than the slower of them
                slowest = min(arm.ratio["v"], arm.ratio["a"] ** 0.5)
                self._later(self.move_seconds / slowest, lambda: self._arrive(arm, goal))

    def _arrive(self, arm: ArmDouble, goal: np.ndarray) -> None:
        arm.setpoint, arm.busy = goal, False
        arm.setpoint_quiet_until = time.monotonic() + self.setpoint_lag
        self._publish_state(arm)

    def _state_command(self, arm: ArmDouble, command: str) -> None:
        self.say(arm.name, "status", f"desired state {command}")
        if command == "enable" and arm.state != "ENABLED":
            arm.busy = True
            self._publish_state(arm)

            def powered() -> None:
                arm.state, arm.busy = "ENABLED", False
                self.say(arm.name, "status", "power on")
                self._publish_state(arm)

            self._later(0.1, powered)
        elif command == "disable":  # Arm.cpp state_command: SetDesiredState("DISABLED"), from any client
            arm.state, arm.busy = "DISABLED", False
            self._publish_state(arm)
        elif command == "home":
            arm.busy, arm.biased = True, True
            self._publish_state(arm)

            def homed() -> None:
                if self.homes:
                    arm.homed, arm.busy = True, False
                else:
                    arm.busy = False
                    self.say(arm.name, "error", "unable to reach home position during calibration on pots")
                self._publish_state(arm)

            self._later(self.home_seconds / min(arm.ratio["v"], arm.ratio["a"] ** 0.5), homed)

    # ------------------------------------------------------------------ streams
    def _run(self) -> None:
        next_cloud = 0.0
        rng = np.random.default_rng(0)
        while not self._stop.wait(0.01):
            with self._lock:
                now = time.monotonic()
                due = [action for at, action in self._timers if at <= now]
                self._timers = [(at, action) for at, action in self._timers if at > now]
                for action in due:
                    action()
                for name, arm in self.arms.items():
                    valid = arm.joints_valid
                    stamp = self.now() if valid else 0.0
                    joints = arm.setpoint if valid else np.zeros(7)
                    for topic in ("measured_js", "setpoint_js"):
                        if topic == "measured_js" or now >= arm.setpoint_quiet_until:
                            self._pub[f"{name}/{topic}"].put(joint_state(joints, stamp))
                    for topic in ("jaw/measured_js", "jaw/setpoint_js"):
                        self._pub[f"{name}/{topic}"].put(
                            joint_state(np.array([arm.jaw if valid else 0.0]), stamp)
                        )
            if now >= next_cloud:
                next_cloud = now + self.camera_period
                points = rng.normal(size=(200, 3))
                points[::10] = np.nan  # pixels without depth
                self._camera.put(cloud(points, self.now()))

    def console(self, arm: str, command: str) -> None:
        """A state command from elsewhere (the dVRK's console, another ROS 2 node), not through pegbt."""
        with self._lock:
            self._state_command(self.arms[arm], command)

    def clutch(self, arm: str, pressed: bool) -> None:
        """A person presses or releases the arm's clutch button: its IO board reports it whatever the arm's
        state (`ros/dvrk_robot/src/system_ROS.cpp`, `add_topics_PSM_IO`), then the arm reacts."""
        with self._lock:
            buttons = np.array([int(pressed)], np.int32)
            joy = T["sensor_msgs/msg/Joy"](
                header=header(self.now()), axes=np.zeros(0, np.float32), buttons=buttons
            )
            self._pub[f"{arm}/IO/arm_clutch"].put(cdr(joy))
            double = self.arms[arm]
            if pressed and double.joints_valid and not double.manual:
                double.manual, double.busy = True, True
                self._publish_state(double)
            elif not pressed and double.manual:
                double.manual, double.busy = False, False
                self._publish_state(double)

    def commands(self, suffix: str) -> list[Received]:
        with self._lock:
            return [r for r in self.received if r.key.endswith(suffix)]

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        self.session.close()
