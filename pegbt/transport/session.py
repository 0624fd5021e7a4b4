"""Zenoh sessions with safe defaults: peer mode on loopback, no multicast or gossip scouting.

The simulator listens on `tcp/127.0.0.1:7447` and clients connect there unless told otherwise. Other
endpoints (another machine, a zenoh router, a zenoh–ROS 2 bridge) are given explicitly, so nothing
ever listens on all interfaces or scouts the network by accident.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass

import zenoh

from pegbt.errors import PegbtError

DEFAULT_PORT = 7447
DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"
MODES = ("peer", "client", "router")


@dataclass(frozen=True)
class SessionSettings:
    """Where a session listens and what it connects to; `mode="client"` to go through a router."""

    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    mode: str = "peer"

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise PegbtError(f"zenoh mode must be one of {', '.join(MODES)}, got {self.mode!r}", field="mode")
        for endpoint in (*self.listen, *self.connect):
            protocol, _, address = endpoint.partition("/")
            if not protocol or ":" not in address:
                raise PegbtError(f"zenoh endpoint must look like tcp/HOST:PORT, got {endpoint!r}", field="endpoint")

    def config(self) -> zenoh.Config:
        """The zenoh configuration: these endpoints, and scouting switched off."""
        config = zenoh.Config()
        config.insert_json5("mode", json.dumps(self.mode))
        config.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        config.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        config.insert_json5("scouting/multicast/enabled", "false")
        config.insert_json5("scouting/gossip/enabled", "false")
        return config


def endpoint_settings(listen: Sequence[str] = (DEFAULT_ENDPOINT,), connect: Sequence[str] = ()) -> SessionSettings:
    """Settings for an endpoint (the simulator): listens on loopback port 7447 by default."""
    return SessionSettings(listen=tuple(listen), connect=tuple(connect))


def client_settings(connect: Sequence[str] = (DEFAULT_ENDPOINT,), mode: str = "peer") -> SessionSettings:
    """Settings for a client (the executive, a benchmark): connects to loopback port 7447 by default."""
    return SessionSettings(connect=tuple(connect), mode=mode)


def open_session(settings: SessionSettings) -> zenoh.Session:
    """Open a zenoh session; a `PegbtError` naming the endpoints if zenoh refuses (port taken, bad address)."""
    try:
        return zenoh.open(settings.config())
    except zenoh.ZError as error:
        raise PegbtError(
            f"cannot open zenoh session (listen {list(settings.listen)}, connect {list(settings.connect)}): {error}",
            field="endpoint",
        ) from None
