"""The ROS 2 topics of a CRTK robot as a dVRK 2.x serves them: one PSM, its jaw, and a depth camera's cloud.

Names and types follow the dVRK's ROS 2 bridge (jhu-cisst/cisst-ros
`cisst_ros_crtk/src/mts_ros_crtk_bridge_provided.cpp`): joint states and commands are
sensor_msgs/JointState, `operating_state` crtk_msgs/OperatingState (published on change, latched),
`state_command` crtk_msgs/StringStamped, `hold` a void command (std_msgs/Empty), and the arm's human-readable
`error`, `warning` and `status` events std_msgs/String. A `Ros2Wire` turns them into zenoh keys.
"""

from __future__ import annotations

from dataclasses import dataclass

from pegbt.transport.codec import EMPTY, JOINT_STATE, OPERATING_STATE, POINT_CLOUD2, STRING, STRING_STAMPED
from pegbt.transport.ros2 import Topic

MESSAGE_LEVELS = ("error", "warning", "status")  # the dVRK's mtsMessage events, most severe first
DEFAULT_CAMERA_TOPIC = "/camera/depth/points"


@dataclass(frozen=True)
class PsmTopics:
    """The topics of one arm (`PSM1`) and its jaw."""

    arm: str

    def _topic(self, name: str, typename: str, latched: bool = False) -> Topic:
        return Topic(f"/{self.arm}/{name}", typename, latched)

    @property
    def measured_js(self) -> Topic:
        return self._topic("measured_js", JOINT_STATE)

    @property
    def setpoint_js(self) -> Topic:
        return self._topic("setpoint_js", JOINT_STATE)

    @property
    def jaw_measured_js(self) -> Topic:
        return self._topic("jaw/measured_js", JOINT_STATE)

    @property
    def jaw_setpoint_js(self) -> Topic:
        return self._topic("jaw/setpoint_js", JOINT_STATE)

    @property
    def operating_state(self) -> Topic:
        return self._topic("operating_state", OPERATING_STATE, latched=True)

    def message(self, level: str) -> Topic:
        """`error`, `warning` or `status`: the arm's human-readable events."""
        return self._topic(level, STRING)

    @property
    def servo_jp(self) -> Topic:
        return self._topic("servo_jp", JOINT_STATE)

    @property
    def jaw_servo_jp(self) -> Topic:
        return self._topic("jaw/servo_jp", JOINT_STATE)

    @property
    def move_jp(self) -> Topic:
        return self._topic("move_jp", JOINT_STATE)

    @property
    def hold(self) -> Topic:
        return self._topic("hold", EMPTY)

    @property
    def state_command(self) -> Topic:
        return self._topic("state_command", STRING_STAMPED)


def camera_topic(name: str = DEFAULT_CAMERA_TOPIC) -> Topic:
    """A streaming depth camera's sensor_msgs/PointCloud2 topic (a RealSense: `/camera/camera/depth/color/points`)."""
    return Topic(name if name.startswith("/") else f"/{name}", POINT_CLOUD2)
