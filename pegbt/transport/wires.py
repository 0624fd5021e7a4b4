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
from pegbt.transport.keys import check_namespace
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


# A ROS 2 node name (ros2/rmw, rmw/src/validate_node_name.c): letters, digits and _, not starting with a digit.
_NODE_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,254}")
MAX_NAMESPACE = 255  # rmw/include/rmw/validate_namespace.h, RMW_NAMESPACE_MAX_LENGTH


def check_names(namespace: str, node_name: str) -> None:
    """A `PegbtError` unless `namespace` can prefix keys (`check_namespace`) and `node_name` is a ROS 2 node
    name: either goes into rmw_zenoh's liveliness tokens, where zenoh reads `*`, `$`, `?` and `#`."""
    check_namespace(namespace, "--namespace")
    if len(namespace) > MAX_NAMESPACE:
        raise PegbtError(f"a ROS 2 namespace is at most {MAX_NAMESPACE} characters", field="--namespace")
    if not _NODE_NAME.fullmatch(node_name):
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
