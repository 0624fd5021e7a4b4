"""Zenoh endpoint addresses: the default one (and the default camera topic), and the checks every
session's endpoints pass.

Kept apart from `session.py` (which imports zenoh) so that `pegbt --help` can show the default address
without loading zenoh.

Why listen endpoints are held to loopback: a session that listens on another interface accepts any
peer on that network, which could then command the arms. Connecting out is different: a real dVRK's
bridge runs on another machine, so connect endpoints may name any host.
"""

from __future__ import annotations

import ipaddress

from pegbt.errors import PegbtError

DEFAULT_PORT = 7447
DEFAULT_ENDPOINT = f"tcp/127.0.0.1:{DEFAULT_PORT}"
# where a depth camera's cloud is found unless told otherwise: realsense2_camera's, under its default names
DEFAULT_POINTS_TOPIC = "/camera/camera/depth/color/points"


def split_endpoint(endpoint: str) -> tuple[str, str, str]:
    """`(protocol, host, port)` of `tcp/HOST:PORT` (IPv6 hosts in brackets); a `PegbtError` if it is not one."""
    protocol, _, address = endpoint.partition("/")
    address = address.split("?", 1)[0].split("#", 1)[0]  # zenoh's metadata and configuration suffixes
    host, _, port = address.rpartition(":")
    if not protocol or not host or not port.isdigit() or int(port) > 65535:
        raise PegbtError(f"zenoh endpoint must look like tcp/HOST:PORT, got {endpoint!r}", field="endpoint")
    return protocol, host.strip("[]"), port


def is_loopback(host: str) -> bool:
    """Whether `host` (a name or an IP address) can only be reached from this machine."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # another host name: it may resolve to any interface


def check_listen(endpoint: str, allow_remote: bool = False, any_port: bool = False) -> str:
    """`endpoint` if a session may listen there: a port of its own (not 0, unless `any_port`), on loopback
    unless `allow_remote`."""
    _, host, port = split_endpoint(endpoint)
    if int(port) == 0 and not any_port:
        raise PegbtError(
            f"listen endpoint {endpoint!r} asks for any free port, which zenoh does not report; "
            "give a port (pegbt.sim.process.free_port finds one)",
            field="listen",
        )
    if not allow_remote and not is_loopback(host):
        raise PegbtError(
            f"listen endpoint {endpoint!r} is not on loopback (127.0.0.1, ::1): peers on that network "
            "could command the arms; pass --allow-remote-listen if that is meant",
            field="listen",
        )
    return endpoint
