"""Raw WebSocket clients of the monitor, as a hostile or broken program would be one: upgrade requests with
any Host, Origin and token, frames of any declared length, readers that never read. Plain `socket`, so the
caller (a test, `pegbt bench monitor-limits`, a fuzz campaign) controls every byte, and a client that waits
costs its process nothing."""

from __future__ import annotations

import base64
import json
import os
import socket
import struct
from typing import Any

HANDSHAKE_TIMEOUT_S = 10.0


def upgrade_request(port: int, *, token: str | None, origin: str | None, host: str | None = None) -> bytes:
    """A WebSocket upgrade of `/ws` (RFC 6455 section 4.1); `None` leaves that part out."""
    path = "/ws" if token is None else f"/ws?token={token}"
    headers = [
        f"GET {path} HTTP/1.1",
        *([f"Host: {host or f'127.0.0.1:{port}'}"] if host != "" else []),
        "Upgrade: websocket",
        "Connection: Upgrade",
        f"Sec-WebSocket-Key: {base64.b64encode(os.urandom(16)).decode()}",
        "Sec-WebSocket-Version: 13",
        *([f"Origin: {origin}"] if origin is not None else []),
    ]
    return ("\r\n".join(headers) + "\r\n\r\n").encode()


def open_socket(
    port: int,
    *,
    token: str | None,
    origin: str | None = None,
    host: str | None = None,
    receive_buffer: int | None = None,
) -> tuple[int, socket.socket]:
    """The status of the upgrade and the connected socket (the response's headers read, nothing more).
    `origin` and `host` default to the page's own; `""` leaves the header out. `receive_buffer` shrinks
    the socket's buffer before it connects (a page that never reads then holds back the server at once)."""
    origin = f"http://127.0.0.1:{port}" if origin is None else origin or None
    connection = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if receive_buffer is not None:
        connection.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer)
    connection.settimeout(HANDSHAKE_TIMEOUT_S)
    connection.connect(("127.0.0.1", port))
    connection.sendall(upgrade_request(port, token=token, origin=origin, host=host))
    head = b""
    while b"\r\n\r\n" not in head:
        chunk = connection.recv(1)
        if not chunk:
            break
        head += chunk
    return int(head.split(b" ", 2)[1]), connection


def upgrade_status(port: int, **request: Any) -> int:
    status, connection = open_socket(port, **request)
    connection.close()
    return status


def http_status(port: int, path: str, host: str) -> int:
    with socket.create_connection(("127.0.0.1", port), timeout=HANDSHAKE_TIMEOUT_S) as connection:
        connection.sendall(f"GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n".encode())
        return int(connection.recv(64).split(b" ", 2)[1])


def frame_header(length: int, opcode: int = 0x1) -> bytes:
    """A client's masked final frame header declaring `length` bytes of payload (RFC 6455 section 5.2)."""
    if length < 126:
        size = struct.pack("!B", 0x80 | length)
    elif length < 1 << 16:
        size = struct.pack("!BH", 0x80 | 126, length)
    else:
        size = struct.pack("!BQ", 0x80 | 127, length)
    return struct.pack("!B", 0x80 | opcode) + size + b"\0\0\0\0"  # a zero mask leaves the payload as sent


def read_frame(connection: socket.socket) -> tuple[int, bytes]:
    """One unmasked frame from the server: its opcode and payload."""

    def exactly(count: int) -> bytes:
        data = b""
        while len(data) < count:
            chunk = connection.recv(count - len(data))
            if not chunk:
                raise ConnectionError("closed mid-frame")
            data += chunk
        return data

    first, second = exactly(2)
    length = second & 0x7F
    if length == 126:
        (length,) = struct.unpack("!H", exactly(2))
    elif length == 127:
        (length,) = struct.unpack("!Q", exactly(8))
    return first & 0x0F, exactly(length)


def read_messages(connection: socket.socket) -> list[dict[str, Any]]:
    """The messages of the server's next text frame (a JSON list)."""
    opcode, payload = read_frame(connection)
    assert opcode == 0x1, f"expected a text frame, got opcode {opcode}: {payload[:80]!r}"
    return json.loads(payload)
