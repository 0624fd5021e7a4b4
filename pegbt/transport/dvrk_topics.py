"""The ROS 2 topics a dVRK 2.x PSM serves, as cisst-ros's CRTK bridge declares them: name, type, durability.

Everything that talks to a dVRK the dVRK's way (the simulator's `--interface dvrk`, a CRTK client, a
recorder) declares these `Topic`s through a `pegbt.transport.ros2.Ros2Wire`; none of them builds a key.

From jhu-cisst/cisst-ros:
- `cisst_ros_crtk/src/mts_ros_crtk_bridge_provided.cpp`: `measured_js`, `setpoint_js` (JointState) and
  `measured_cp`, `setpoint_cp` (PoseStamped) are read commands published every period; `servo_jp`,
  `move_jp` (JointState) and `state_command` (crtk_msgs/StringStamped) are write commands, `hold` a void
  command (std_msgs/Empty, `cisst_ros_bridge/include/cisst_ros_bridge/mtsROSBridge.h`
  `mtsROSSubscriberVoid`); `operating_state` (crtk_msgs/OperatingState) and `error`, `warning`, `status`
  (std_msgs/String) are events.
- `cisst_ros_bridge/include/cisst_ros_bridge/mtsROSBridge.h`: an event publisher (`AddPublisherFromEventWrite`)
  is latched with a queue of 100 by default, and `cisst_ros_bridge/include/cisst_ros_bridge/cisst_ral.h`
  makes a latched ROS 2 publisher TRANSIENT_LOCAL with that depth. So all four event topics are latched,
  depth 100: a late joiner gets the last 100 messages of each.
- the jaw's topics are the same CRTK commands under `jaw/` (sawIntuitiveResearchKit
  `core/components/code/mtsIntuitiveResearchKitPSM.cpp`, `Init`).
"""

from __future__ import annotations

from dataclasses import dataclass

from pegbt.transport import codec
from pegbt.transport.endpoints import DEFAULT_POINTS_TOPIC
from pegbt.transport.ros2 import Topic

EVENT_DEPTH = 100  # mtsROSBridge.h: AddPublisherFromEventWrite(..., queue_size = 100, latched = true)


def _event(name: str, typename: str) -> Topic:
    return Topic(name, typename, latched=True, depth=EVENT_DEPTH)


@dataclass(frozen=True)
class PsmTopics:
    """The topics of one PSM (`PSM1`): what it publishes and what it subscribes to."""

    arm: str

    def _name(self, topic: str) -> str:
        return f"/{self.arm}/{topic}"

    # ------------------------------------------------------------------ published
    @property
    def measured_js(self) -> Topic:
        return Topic(self._name("measured_js"), codec.JOINT_STATE)

    @property
    def setpoint_js(self) -> Topic:
        return Topic(self._name("setpoint_js"), codec.JOINT_STATE)

    @property
    def measured_cp(self) -> Topic:
        return Topic(self._name("measured_cp"), codec.POSE_STAMPED)

    @property
    def setpoint_cp(self) -> Topic:
        return Topic(self._name("setpoint_cp"), codec.POSE_STAMPED)

    @property
    def jaw_measured_js(self) -> Topic:
        return Topic(self._name("jaw/measured_js"), codec.JOINT_STATE)

    @property
    def jaw_setpoint_js(self) -> Topic:
        return Topic(self._name("jaw/setpoint_js"), codec.JOINT_STATE)

    @property
    def operating_state(self) -> Topic:
        return _event(self._name("operating_state"), codec.OPERATING_STATE)

    @property
    def error(self) -> Topic:
        return _event(self._name("error"), codec.STRING)

    @property
    def warning(self) -> Topic:
        return _event(self._name("warning"), codec.STRING)

    @property
    def status(self) -> Topic:
        return _event(self._name("status"), codec.STRING)

    @property
    def trajectory_j_ratio_v(self) -> Topic:
        """The fraction of its own velocity limits the arm's `move_jp` and homing run at (std_msgs/Float64,
        an event: latched); dVRK 2.3 and later (`mtsIntuitiveResearchKitArm.cpp`, `trajectory_j_set_ratio_v`;
        `ros/dvrk_robot/src/system_ROS.cpp`, `bridge_interface_provided_arm`)."""
        return _event(self._name("trajectory_j/ratio_v"), codec.FLOAT64)

    @property
    def trajectory_j_ratio_a(self) -> Topic:
        """The same for its acceleration limits."""
        return _event(self._name("trajectory_j/ratio_a"), codec.FLOAT64)

    @property
    def io_arm_clutch(self) -> Topic:
        """The arm's clutch button as its IO board reports each press and release (sensor_msgs/Joy, 1 pressed,
        0 released), whatever the arm's state: dVRK 2.4's `PSMn/IO/arm_clutch` (sawIntuitiveResearchKit
        `ros/dvrk_robot/src/system_ROS.cpp`, `add_topics_PSM_IO`, an event publisher: latched, depth 100);
        2.3 named it `PSMn/io/manip_clutch` (`ros/dvrk_robot/src/dvrk_console.cpp`, `add_topics_psm_io`)."""
        return _event(self._name("IO/arm_clutch"), codec.JOY)

    @property
    def fiducial_js(self) -> Topic:
        """Not the dVRK's: the physical joints as an external tracker sees them (the simulator's ground truth
        of the cable effects, the paper's RGBD fiducials)."""
        return Topic(self._name("fiducial_js"), codec.JOINT_STATE)

    # ------------------------------------------------------------------ subscribed
    @property
    def servo_jp(self) -> Topic:
        return Topic(self._name("servo_jp"), codec.JOINT_STATE)

    @property
    def move_jp(self) -> Topic:
        return Topic(self._name("move_jp"), codec.JOINT_STATE, command=True)

    @property
    def hold(self) -> Topic:
        return Topic(self._name("hold"), codec.EMPTY, command=True)

    @property
    def state_command(self) -> Topic:
        return Topic(self._name("state_command"), codec.STRING_STAMPED, command=True)

    @property
    def jaw_servo_jp(self) -> Topic:
        return Topic(self._name("jaw/servo_jp"), codec.JOINT_STATE)

    @property
    def jaw_move_jp(self) -> Topic:
        return Topic(self._name("jaw/move_jp"), codec.JOINT_STATE, command=True)

    @property
    def trajectory_j_set_ratio_v(self) -> Topic:
        """Set `trajectory_j/ratio_v`, within ]0, 1] (else the arm warns and keeps its ratio)."""
        return Topic(self._name("trajectory_j/set_ratio_v"), codec.FLOAT64, command=True)

    @property
    def trajectory_j_set_ratio_a(self) -> Topic:
        return Topic(self._name("trajectory_j/set_ratio_a"), codec.FLOAT64, command=True)

    def published(self) -> tuple[Topic, ...]:
        """What the PSM publishes (with the simulator's `fiducial_js`)."""
        return (
            self.measured_js,
            self.setpoint_js,
            self.measured_cp,
            self.setpoint_cp,
            self.jaw_measured_js,
            self.jaw_setpoint_js,
            self.operating_state,
            self.error,
            self.warning,
            self.status,
            self.trajectory_j_ratio_v,
            self.trajectory_j_ratio_a,
            self.io_arm_clutch,
            self.fiducial_js,
        )

    def subscribed(self) -> tuple[Topic, ...]:
        """The commands the PSM takes."""
        return (
            self.servo_jp,
            self.move_jp,
            self.hold,
            self.state_command,
            self.jaw_servo_jp,
            self.jaw_move_jp,
            self.trajectory_j_set_ratio_v,
            self.trajectory_j_set_ratio_a,
        )


def clutch_button_topic(arm: str) -> Topic:
    """Not the dVRK's: the simulator's stand-in for a person pressing and releasing `arm`'s clutch button
    (sensor_msgs/Joy, 1 pressed, 0 released); the simulator then publishes what a dVRK's IO board does
    (`PsmTopics.io_arm_clutch`). A robot takes no such command: on it, the button is pressed by hand."""
    return Topic(f"/pegbt_sim/{arm}/arm_clutch", codec.JOY, command=True)


def point_cloud_topic(name: str = DEFAULT_POINTS_TOPIC) -> Topic:
    """A depth camera's stream of sensor_msgs/PointCloud2 (best effort, volatile, as realsense2_camera's); a
    reader takes the newest cloud."""
    return Topic(name, codec.POINT_CLOUD2, keep_last=1)
