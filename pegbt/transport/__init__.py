"""How pegbt talks to a robot: zenoh sessions on loopback by default, CDR-serialised ROS 2 messages
under CRTK key names, and the arm and camera clients behaviours use.

    link = connect()                          # tcp/127.0.0.1:7447, peer mode, no scouting
    clock = SimClock(link)                    # or WallClock() for a real dVRK
    psm1 = ArmClient(link, "PSM1", clock=clock)
    handle = psm1.move_jp(goal)               # returns at once; poll handle.status in later ticks

The names below load on first use (PEP 562), so that importing a light module of this package
(`pegbt.transport.endpoints`, say, for `pegbt --help`) does not load zenoh and the message types.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "ArmClient": "arm",
    "EndpointSilent": "arm",
    "JawClient": "arm",
    "MotionHandle": "arm",
    "MotionStatus": "arm",
    "CameraClient": "camera",
    "CaptureHandle": "camera",
    "Clock": "clock",
    "SimClock": "clock",
    "WallClock": "clock",
    "CommandRefused": "guards",
    "Link": "link",
    "connect": "link",
    "DEFAULT_ENDPOINT": "endpoints",
    "SessionSettings": "session",
    "client_settings": "session",
    "endpoint_settings": "session",
    "open_session": "session",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
