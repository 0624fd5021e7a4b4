"""Which ROS 2 wire a process speaks, and the zenoh session it needs: `bridge` (zenoh-bridge-ros2dds's
keys, a peer session connected to the bridge) or `rmw_zenoh` (rmw_zenoh's keys, attachments and liveliness
tokens, a peer session connected to the graph's zenoh router, gossip on).

The simulator's dVRK interface, the executive's CRTK client and its servo streamer all open their wire
here, so `--ros2` means the same thing to each of them.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import zenoh

from pegbt.errors import PegbtError
from pegbt.transport.ros2 import BridgeWire, Ros2Wire
from pegbt.transport.session import SessionSettings, open_session, ros2_graph_settings

ROS2_WIRES = ("bridge", "rmw_zenoh")


def wire_session_settings(kind: str, connect: Sequence[str], listen: Sequence[str] = ()) -> SessionSettings:
    """The session a `kind` wire runs on: for `rmw_zenoh`, connected to the router(s) `connect`."""
    if kind == "rmw_zenoh":
        if not connect:
            raise PegbtError(
                "--ros2 rmw_zenoh joins a ROS 2 graph through its zenoh router: give the router's address "
                "(e.g. tcp/127.0.0.1:7447, where `ros2 run rmw_zenoh_cpp rmw_zenohd` listens)",
                field="--ros2",
            )
        return ros2_graph_settings(connect)
    if kind != "bridge":
        raise PegbtError(f"--ros2 must be one of {', '.join(ROS2_WIRES)}, got {kind!r}", field="--ros2")
    return SessionSettings(listen=tuple(listen), connect=tuple(connect))


# ROS 2's names (ros2/rmw, rmw/src/validate_namespace.c and validate_node_name.c): tokens of letters, digits
# and underscores, not starting with a digit, joined by single slashes. Anything else would reach zenoh as a
# key expression: `*` or `**` subscribe and publish to every key they match, `$`, `#` and `?` are refused.
_TOKEN = r"[A-Za-z_][A-Za-z0-9_]*"
_NAMESPACE = re.compile(rf"/?(?:{_TOKEN}(?:/{_TOKEN})*)?/?")
_NODE_NAME = re.compile(_TOKEN)
MAX_NAME = 255  # rmw's RMW_NODE_NAME_MAX_NAME_LENGTH; a namespace's is 255 less the node name's


def check_names(namespace: str, node_name: str) -> None:
    """A `PegbtError` unless `namespace` and `node_name` are ROS 2 names (see `_NAMESPACE`)."""
    if len(namespace) > MAX_NAME or not _NAMESPACE.fullmatch(namespace):
        raise PegbtError(
            f"not a ROS 2 namespace: {namespace[:80]!r} (tokens of letters, digits and _, not starting with a "
            f"digit, joined by /; at most {MAX_NAME} characters)",
            field="--namespace",
        )
    if len(node_name) > MAX_NAME or not _NODE_NAME.fullmatch(node_name):
        raise PegbtError(
            f"not a ROS 2 node name: {node_name[:80]!r} (letters, digits and _, not starting with a digit)",
            field="node name",
        )


def make_wire(kind: str, session: zenoh.Session, namespace: str, node_name: str) -> Ros2Wire:
    """A `kind` wire on `session`; `namespace` prefixes the topics (the bridge's namespace, or the node's
    namespace in the ROS 2 graph), `node_name` is the node rmw_zenoh announces; both ROS 2 names."""
    check_names(namespace, node_name)
    if kind == "rmw_zenoh":
        from pegbt.transport.rmw_zenoh import RmwZenohWire

        return RmwZenohWire(session, node_name=node_name, namespace="/" + namespace.strip("/"))
    return BridgeWire(session, namespace)


def open_wire(
    kind: str, connect: Sequence[str], namespace: str, node_name: str
) -> tuple[zenoh.Session, Ros2Wire]:
    """A client's session and wire of `kind`, connected to `connect` (a bridge, or a graph's router)."""
    session = open_session(wire_session_settings(kind, connect))
    try:
        return session, make_wire(kind, session, namespace, node_name)
    except BaseException:
        session.close()
        raise
