"""How pegbt talks to a robot: zenoh sessions on loopback by default, CDR-serialised ROS 2 messages
under CRTK key names, and the arm and camera clients behaviours use.

    link = connect()                          # tcp/127.0.0.1:7447, peer mode, no scouting
    clock = SimClock(link)                    # or WallClock() for a real dVRK
    psm1 = ArmClient(link, "PSM1", clock=clock)
    handle = psm1.move_jp(goal)               # returns at once; poll handle.status in later ticks
"""

from pegbt.transport.arm import ArmClient, EndpointSilent, JawClient, MotionHandle, MotionStatus
from pegbt.transport.camera import CameraClient, CaptureHandle
from pegbt.transport.clock import Clock, SimClock, WallClock
from pegbt.transport.guards import CommandRefused
from pegbt.transport.link import Link, connect
from pegbt.transport.session import DEFAULT_ENDPOINT, SessionSettings, client_settings, endpoint_settings, open_session

__all__ = [
    "ArmClient",
    "CameraClient",
    "CaptureHandle",
    "Clock",
    "CommandRefused",
    "DEFAULT_ENDPOINT",
    "EndpointSilent",
    "JawClient",
    "Link",
    "MotionHandle",
    "MotionStatus",
    "SessionSettings",
    "SimClock",
    "WallClock",
    "client_settings",
    "connect",
    "endpoint_settings",
    "open_session",
]
