"""CRTK key names: the zenoh key of a topic is its dVRK ROS 2 topic name without the leading slash.

`/PSM1/measured_js` on a dVRK is `PSM1/measured_js` here, under an optional namespace prefix
(`lab2/PSM1/measured_js`), so a zenoh–ROS 2 bridge maps one onto the other with no renaming.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pegbt.errors import PegbtError

# ROS 2 name tokens (what a bridge's namespace can be): letters, digits and _, not starting with a digit
_NAMESPACE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*")


def check_namespace(namespace: str, field: str = "namespace") -> str:
    """`namespace` if it can prefix keys (ROS 2 name tokens joined by `/`; empty for none), else a `PegbtError`.

    Why: zenoh reads `*`, `$`, `?` and `#` in a key as wildcards or syntax, so a namespace holding them
    would make the endpoint publish to or subscribe on keys nobody meant.
    """
    if namespace.strip("/") and not _NAMESPACE.fullmatch(namespace.strip("/")):
        raise PegbtError(
            f"{namespace!r} is not a key prefix: use ROS 2 names (letters, digits, _; not starting "
            "with a digit), joined by /",
            field=field,
        )
    return namespace


def scoped(namespace: str, name: str) -> str:
    """`name` under `namespace` (no prefix when the namespace is empty)."""
    namespace = namespace.strip("/")
    return f"{namespace}/{name}" if namespace else name


@dataclass(frozen=True)
class ArmKeys:
    """The CRTK topics of one arm and its jaw."""

    arm: str
    namespace: str = ""

    def _key(self, topic: str) -> str:
        return scoped(self.namespace, f"{self.arm}/{topic}")

    @property
    def measured_js(self) -> str:
        return self._key("measured_js")

    @property
    def setpoint_js(self) -> str:
        return self._key("setpoint_js")

    @property
    def fiducial_js(self) -> str:
        """Physical joints as an external tracker (the paper's RGBD fiducials) sees them; simulator only."""
        return self._key("fiducial_js")

    @property
    def measured_cp(self) -> str:
        return self._key("measured_cp")

    @property
    def servo_jp(self) -> str:
        return self._key("servo_jp")

    @property
    def move_jp(self) -> str:
        return self._key("move_jp")

    @property
    def follow_jt(self) -> str:
        """A whole joint trajectory (trajectory_msgs/JointTrajectory): a pegbt extension of CRTK."""
        return self._key("follow_jt")

    @property
    def operating_state(self) -> str:
        return self._key("operating_state")

    @property
    def state_command(self) -> str:
        return self._key("state_command")

    @property
    def error(self) -> str:
        return self._key("error")

    @property
    def jaw_measured_js(self) -> str:
        return self._key("jaw/measured_js")

    @property
    def jaw_setpoint_js(self) -> str:
        return self._key("jaw/setpoint_js")

    @property
    def jaw_servo_jp(self) -> str:
        return self._key("jaw/servo_jp")

    @property
    def jaw_move_jp(self) -> str:
        return self._key("jaw/move_jp")

    @property
    def hold(self) -> str:
        """std_msgs/Empty: stop at the current set-point. The dVRK's own `hold` (sawIntuitiveResearchKit
        core/components/code/mtsIntuitiveResearchKitArm.cpp `hold()`: servo goal = the PID's set-point;
        bridged to a ROS topic by cisst-ros cisst_ros_crtk/src/mts_ros_crtk_bridge_provided.cpp)."""
        return self._key("hold")

    @property
    def jaw_hold(self) -> str:
        """As `hold`, for the jaw (the simulator's; a robot without it gets a servo at the set-point)."""
        return self._key("jaw/hold")


@dataclass(frozen=True)
class CameraKeys:
    """The depth camera: clouds on `points`; `trigger` asks the simulator for one."""

    name: str = "camera"
    namespace: str = ""

    @property
    def points(self) -> str:
        return scoped(self.namespace, f"{self.name}/depth/points")

    @property
    def trigger(self) -> str:
        return scoped(self.namespace, f"{self.name}/trigger")


@dataclass(frozen=True)
class SimKeys:
    """The simulator's own keys: its clock (lockstep stepping), its log stream and its ground truth."""

    namespace: str = ""

    @property
    def step(self) -> str:
        """Step requests (JSON), put by a client's `SimClock`."""
        return scoped(self.namespace, "sim/step")

    def stepped(self, clock: str) -> str:
        """Where the simulator answers the step requests of the `SimClock` named `clock`."""
        return scoped(self.namespace, f"sim/stepped/{clock}")

    @property
    def clock(self) -> str:
        return scoped(self.namespace, "sim/clock")

    @property
    def events(self) -> str:
        return scoped(self.namespace, "sim/events")

    @property
    def truth(self) -> str:
        """Block states and the log so far, for the judge of a trial (never for behaviours)."""
        return scoped(self.namespace, "sim/truth")
