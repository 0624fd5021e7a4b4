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
from pegbt.transport.endpoints import DEFAULT_ENDPOINT, check_listen, split_endpoint

Session = zenoh.Session  # for modules above transport that hold a session but never call zenoh


@dataclass(frozen=True)
class SessionSettings:
    """Where a peer session listens and what it connects to.

    Always peer mode: client and router modes would route through, or become, a zenoh router, which the
    loopback-only rule does not cover. Listen endpoints must be loopback unless `allow_remote_listen`.
    """

    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    allow_remote_listen: bool = False
    gossip: bool = False

    def __post_init__(self) -> None:
        for endpoint in self.connect:
            split_endpoint(endpoint)
        for endpoint in self.listen:
            # gossip tells peers the port a listener got, so a ROS 2 graph session may ask for any free one
            check_listen(endpoint, self.allow_remote_listen, any_port=self.gossip)

    def config(self) -> zenoh.Config:
        """The zenoh configuration: peer mode, these endpoints, no multicast scouting, gossip only for a ROS 2
        graph, timestamps on."""
        config = zenoh.Config()
        config.insert_json5("mode", json.dumps("peer"))
        config.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        config.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        config.insert_json5("scouting/multicast/enabled", "false")
        config.insert_json5("scouting/gossip/enabled", json.dumps(self.gossip))
        # zenoh-ext's advanced publishers (latched ROS 2 topics) order their cache by timestamp
        config.insert_json5("timestamping/enabled", "true")
        return config


def endpoint_settings(
    listen: Sequence[str] = (DEFAULT_ENDPOINT,),
    connect: Sequence[str] = (),
    allow_remote_listen: bool = False,
) -> SessionSettings:
    """Settings for an endpoint (the simulator): listens on loopback port 7447 by default."""
    return SessionSettings(
        listen=tuple(listen), connect=tuple(connect), allow_remote_listen=allow_remote_listen
    )


def client_settings(connect: Sequence[str] = (DEFAULT_ENDPOINT,)) -> SessionSettings:
    """Settings for a client (the executive, a benchmark): connects to loopback port 7447 by default."""
    return SessionSettings(connect=tuple(connect))


def ros2_graph_settings(router: Sequence[str]) -> SessionSettings:
    """Settings for a node of a ROS 2 graph on rmw_zenoh: connect to its router, listen on loopback, and
    learn the other peers by gossip, as rmw_zenoh's default session does
    (`rmw_zenoh_cpp/config/DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5`; multicast stays off)."""
    return SessionSettings(listen=("tcp/127.0.0.1:0",), connect=tuple(router), gossip=True)


def open_session(settings: SessionSettings) -> zenoh.Session:
    """Open a zenoh session; a `PegbtError` naming the endpoints if zenoh refuses (port taken, bad address)."""
    try:
        return zenoh.open(settings.config())
    except zenoh.ZError as error:
        raise PegbtError(
            f"cannot open zenoh session (listen {list(settings.listen)}, connect {list(settings.connect)}): {error}",
            field="endpoint",
        ) from None


def reaches_anyone(session: zenoh.Session) -> bool:
    """Whether `session` is connected to any zenoh router or peer (a peer's `connect` to an address where
    nothing listens opens anyway, and keeps retrying)."""
    return bool(session.info.routers_zid() or session.info.peers_zid())
