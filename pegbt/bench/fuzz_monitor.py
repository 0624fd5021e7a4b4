"""The monitor campaign: malformed HTTP requests and WebSocket upgrades against one server on 127.0.0.1
(`start_ephemeral`, fed a run whose log name is a secret marker): bad, missing or foreign Host, Origin and
token; garbage request lines and headers; frames declaring huge lengths or over `MAX_MESSAGE`; frames the
protocol forbids; clients that stop reading while the run publishes. Every socket waits at most
`ANSWER_S`, every input sends a bounded number of bytes, and after each one a probe must still be answered.

A traceback is the server logging an error (an unhandled exception in a handler or its loop) or its thread
dying; a hang is a request (or a forbidden frame) not answered or closed within `ANSWER_S`; `absurd_accepted`
is the marker served to a request without the right token, Origin and Host. A request with all three must
be served the run (`good_refused` otherwise)."""

from __future__ import annotations

import logging
import random
import re
import secrets
import socket
import struct
from collections.abc import Callable
from pathlib import Path

from pegbt.bench.fuzzing import SILENT, Hang, Tally

ANSWER_S = 3.0
READ_LIMIT = 1 << 20  # bytes of an answer read before judging it
CLOSE_LIMIT = 64 << 20  # bytes of frames read while waiting for a socket to be closed


class _Errors(logging.Handler):
    """The errors the server's libraries log (aiohttp's handlers, asyncio's loop)."""

    def __init__(self) -> None:
        super().__init__(logging.ERROR)
        self.records: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.name.startswith(("aiohttp", "asyncio", "pegbt.monitor")):
            self.records.append(f"{record.name}: {record.getMessage()[:120]}")


class ServerError(Exception):
    """The server logged an error or stopped while reading an input."""


def _answer(connection: socket.socket, marker: bytes, head_only: bool = False) -> tuple[bytes, bool]:
    """What the server sends until it closes, its response (other than an upgrade) is whole, the marker
    shows or `READ_LIMIT` bytes came; and whether it closed."""
    data = b""
    while len(data) < READ_LIMIT and marker not in data and not _whole(data, head_only):
        try:
            chunk = connection.recv(65536)
        except TimeoutError:
            return data, False
        except ConnectionError:
            return data, True
        if not chunk:
            return data, True
        data += chunk
    return data, False


def _whole(data: bytes, head_only: bool) -> bool:
    """Whether `data` holds a whole response that is not an upgrade (head and `Content-Length` of body)."""
    head, found, body = data.partition(b"\r\n\r\n")
    if not found or _status(data) in (None, 101):
        return False
    length = re.search(rb"(?im)^content-length:\s*(\d+)", head)
    return head_only or (length is not None and len(body) >= int(length.group(1)))


def _status(data: bytes) -> int | None:
    parts = data.split(b" ", 2)
    return int(parts[1]) if len(parts) > 1 and data.startswith(b"HTTP/1.") and parts[1].isdigit() else None


class _Campaign:
    def __init__(self, rng: random.Random) -> None:
        from pegbt.monitor.server import start_ephemeral

        self.rng = rng
        self.marker = secrets.token_hex(12)
        self.server = start_ephemeral([{"type": "mode", "mode": "live", "log": self.marker}])
        assert self.server.token is not None, "the monitor requires a token by default"
        self.token = self.server.token
        self.port = self.server.port
        self.good_host = f"127.0.0.1:{self.port}"
        self.good_origin = f"http://127.0.0.1:{self.port}"

    # ------------------------------------------------------------------------------------------ requests
    def _connect(self) -> socket.socket:
        connection = socket.create_connection(("127.0.0.1", self.port), timeout=ANSWER_S)
        connection.settimeout(ANSWER_S)
        return connection

    def _upgrade(self, host: str | None, origin: str | None, token: str | None, extra: str = "") -> bytes:
        path = "/ws" if token is None else f"/ws?token={token}"
        lines = [
            f"GET {path} HTTP/1.1",
            *([f"Host: {host}"] if host is not None else []),
            "Upgrade: websocket",
            "Connection: Upgrade",
            "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
            "Sec-WebSocket-Version: 13",
            *([f"Origin: {origin}"] if origin is not None else []),
            *([extra] if extra else []),
        ]
        return ("\r\n".join(lines) + "\r\n\r\n").encode("utf-8", "surrogateescape")

    def _hosts(self) -> list[str | None]:
        port = self.port
        return [
            self.good_host,
            f"localhost:{port}",
            None,
            "",
            "evil.example",
            f"evil.example:{port}",
            f"127.0.0.1:{port + 1}",
            "127.0.0.1",
            f"127.0.0.1:{port}.evil.example",
            f"127.0.0.1:{port}\x00",
            "\udcff" * 3,
            "h" * 9000,
        ]

    def _origins(self) -> list[str | None]:
        port = self.port
        return [
            self.good_origin,
            f"http://localhost:{port}",
            None,
            "",
            "null",
            "http://evil.example",
            f"http://127.0.0.1:{port}.evil.example",
            f"https://127.0.0.1:{port}",
            f"http://127.0.0.1:{port}/",
            "file://",
        ]

    def _tokens(self) -> list[str | None]:
        token = self.token
        return [
            token,
            token,
            None,
            "",
            token[:-1],
            token + "x",
            token.upper(),
            "%00" + token,
            "é" * 40,
            "a" * 8000,
        ]

    def upgrade(self) -> tuple[Callable[[], object], str, bool]:
        host = self.rng.choice(self._hosts())
        origin = self.rng.choice(self._origins())
        token = self.rng.choice(self._tokens())
        hosts = {self.good_host, f"localhost:{self.port}"}
        allowed = host in hosts and origin in {f"http://{h}" for h in hosts} and token == self.token
        request = self._upgrade(host, origin, token)

        def read() -> object:
            with self._connect() as connection:
                connection.sendall(request)
                data, closed = _answer(connection, self.marker.encode())
            if self.marker.encode() in data:
                return True if allowed else SILENT
            if _status(data) is None and not closed:
                raise Hang()
            return False

        what = f"upgrade host={str(host)[:30]!r} origin={str(origin)[:30]!r} token ok={token == self.token}"
        return read, what, allowed

    def http(self) -> tuple[Callable[[], object], str, bool]:
        method = self.rng.choice(["GET", "HEAD", "POST", "PUT", "OPTIONS", "TRACE", "BREW", "G\x00T", "get"])
        path = self.rng.choice(
            [
                "/",
                "/ws",
                f"/ws?token={self.token}",
                "/static/monitor.css",
                "/static/dist/monitor.js",
                "/static/dist/../../server.py",
                "/static/dist/%2e%2e/%2e%2e/server.py",
                "//etc/passwd",
                "*",
                "/" + "a" * 20000,
                "/?" + "&".join(f"k{i}=v" for i in range(3000)),
                "http://evil.example/ws",
            ]
        )
        host = self.rng.choice(self._hosts())
        version = self.rng.choice(["HTTP/1.1", "HTTP/1.0", "HTTP/2.0", "HTTP/9.9", "HTTX/1.1", ""])
        headers = [f"{method} {path} {version}".rstrip(), *([f"Host: {host}"] if host is not None else [])]
        headers += self.rng.sample(self._garbage_headers(), self.rng.randint(0, 3))
        request = ("\r\n".join(headers) + "\r\n\r\n").encode("utf-8", "surrogateescape")
        return (
            self._plain(request, method == "HEAD"),
            f"{method!r} {path[:40]!r} {version} host={str(host)[:30]!r}",
            False,
        )

    def _garbage_headers(self) -> list[str]:
        return [
            "X-Long: " + "x" * 70000,
            "no colon here",
            ": empty name",
            "Content-Length: -1",
            "Content-Length: 99999999999999999999999",
            "Content-Length: 1\r\nContent-Length: 2",
            "Transfer-Encoding: chunked",
            "Transfer-Encoding: gzip, chunked, identity",
            "Upgrade: websocket",
            "Connection: Upgrade",
            "Sec-WebSocket-Version: 99",
            "Sec-WebSocket-Key: not base64!!",
            " folded: continuation",
            "X-Null: \x00\x01\x02",
            "X-High: \udcff\udcfe",
            *(f"X-{i}: {i}" for i in range(200)),
        ]

    def garbage(self) -> tuple[Callable[[], object], str, bool]:
        choices: list[tuple[str, bytes]] = [
            ("random bytes", bytes(self.rng.randrange(256) for _ in range(self.rng.randint(1, 4000)))),
            (
                "newlines before a request",
                b"\r\n" * 2000 + f"GET / HTTP/1.1\r\nHost: {self.good_host}\r\n\r\n".encode(),
            ),
            (
                "request then chunked garbage",
                f"POST / HTTP/1.1\r\nHost: {self.good_host}\r\n"
                "Transfer-Encoding: chunked\r\n\r\nzz\r\n\r\n".encode(),
            ),
            (
                "huge chunk",
                f"POST / HTTP/1.1\r\nHost: {self.good_host}\r\nTransfer-Encoding: chunked\r\n\r\n"
                "ffffffffffffffffffff\r\nx\r\n".encode(),
            ),
            ("TLS hello", b"\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03" + b"\0" * 200),
            ("HTTP/2 preface", b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n"),
            ("pipelined upgrades", self._upgrade(self.good_host, self.good_origin, "wrong") * 20),
            (
                "header flood",
                f"GET / HTTP/1.1\r\nHost: {self.good_host}\r\n".encode() + b"X: y\r\n" * 20000 + b"\r\n",
            ),
        ]
        what, request = self.rng.choice(choices)
        return self._plain(request), what, False

    def _plain(self, request: bytes, head_only: bool = False) -> Callable[[], object]:
        """Send a request that must not be served run data; answered (or closed) within `ANSWER_S`."""

        def read() -> object:
            with self._connect() as connection:
                try:
                    connection.sendall(request)
                except ConnectionError:
                    return False  # refused before it was all sent
                if self.rng.random() < 0.3:
                    connection.shutdown(socket.SHUT_WR)  # a client that sends and stops
                data, closed = _answer(connection, self.marker.encode(), head_only)
            if self.marker.encode() in data:
                return SILENT
            if _status(data) is None and not closed:
                raise Hang()
            return False if (_status(data) or 400) >= 400 else True

        return read

    def frame(self) -> tuple[Callable[[], object], str, bool]:
        from pegbt.bench.monitor_clients import frame_header
        from pegbt.monitor.server import MAX_MESSAGE

        kinds: list[tuple[str, bytes]] = [
            ("declared 2**63-1 bytes", frame_header(2**63 - 1)),
            ("declared 400 MB", frame_header(400 * 1024 * 1024) + b"x" * 65536),
            ("declared 2**64-1 bytes", b"\x81\xff" + b"\xff" * 8 + b"\0\0\0\0"),
            ("one byte over the limit", frame_header(MAX_MESSAGE + 1) + b"x" * (MAX_MESSAGE + 1)),
            ("binary over the limit", frame_header(MAX_MESSAGE * 4, opcode=0x2) + b"\0" * (MAX_MESSAGE * 4)),
            ("reserved opcode", frame_header(4, opcode=0x3) + b"abcd"),
            ("reserved bits", b"\xf1\x84\0\0\0\0abcd"),
            ("control frame of 200 bytes", frame_header(200, opcode=0x9) + b"p" * 200),
            ("fragmented ping", b"\x09\x84\0\0\0\0abcd"),
            ("continuation without a start", frame_header(4, opcode=0x0) + b"abcd"),
            ("bad UTF-8 text", frame_header(4) + b"\xff\xfe\xfd\xfc"),
            ("close with a bad code", frame_header(2, opcode=0x8) + struct.pack("!H", 999)),
        ]
        what, frame = self.rng.choice(kinds)
        request = self._upgrade(self.good_host, self.good_origin, self.token)

        def read() -> object:
            with self._connect() as connection:
                connection.sendall(request)
                data, _ = _answer(connection, self.marker.encode())
                if self.marker.encode() not in data:
                    return False  # a good upgrade refused: counted as `good_refused`
                try:
                    connection.sendall(frame)
                except ConnectionError:
                    return True
                closed = self._closes(connection)
            if not closed:
                raise Hang()
            return True

        return read, f"frame: {what}", True

    def _closes(self, connection: socket.socket) -> bool:
        """Whether the server closes the socket (a close frame or end of stream) within `ANSWER_S` of
        silence, the frames it sends first skipped (at most `CLOSE_LIMIT` bytes of them)."""
        from pegbt.bench.monitor_clients import read_frame

        skipped = 0
        while skipped < CLOSE_LIMIT:
            try:
                opcode, payload = read_frame(connection)
            except TimeoutError:
                return False
            except ConnectionError:
                return True
            if opcode == 0x8:
                return True
            skipped += len(payload)
        return False

    def stall(self) -> tuple[Callable[[], object], str, bool]:
        """A page that stops reading while the run publishes: the server must go on answering others."""
        size = self.rng.choice([1024, 65536, 400_000])
        count = self.rng.randint(1, 30)

        def read() -> object:
            connection = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            connection.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
            connection.settimeout(ANSWER_S)
            with connection:
                connection.connect(("127.0.0.1", self.port))
                connection.sendall(self._upgrade(self.good_host, self.good_origin, self.token))
                if _status(connection.recv(12)) != 101:
                    return False
                for n in range(count):
                    self.server.publish(
                        {"type": "padding", "n": n, "padding": "p" * size}
                    )  # not kept for later pages
                self.probe()
            return True

        return read, f"stalled reader of {count} messages of {size} bytes", True

    # ------------------------------------------------------------------------------------------ checks
    def probe(self) -> None:
        """The page must still be answered within `ANSWER_S`, and the server's thread be alive."""
        if not self.server._thread.is_alive():
            raise ServerError("the monitor's thread died")
        with self._connect() as connection:
            connection.sendall(
                f"GET / HTTP/1.1\r\nHost: {self.good_host}\r\nConnection: close\r\n\r\n".encode()
            )
            try:
                data = connection.recv(64)
            except TimeoutError:
                raise Hang() from None
        if _status(data) not in (200, 404):
            raise ServerError(f"the page answered {data[:40]!r}")


def fuzz_monitor_requests(count: int, rng: random.Random, work: Path) -> Tally:
    errors = _Errors()
    root = logging.getLogger()
    root.addHandler(errors)
    campaign = _Campaign(rng)
    tally = Tally()
    makers = [campaign.upgrade] * 4 + [campaign.http] * 3 + [campaign.garbage] * 2 + [campaign.frame] * 2
    try:
        for n in range(count):
            make = campaign.stall if n % 100 == 99 else rng.choice(makers)
            read, what, good = make()

            def checked(read: Callable[[], object] = read) -> object:
                outcome = read()
                campaign.probe()
                if errors.records:
                    logged, errors.records[:] = errors.records[0], []
                    raise ServerError(logged)
                return outcome

            tally.record(checked, parsed=True, absurd=False, what=what, good=good)
    finally:
        campaign.server.stop()
        root.removeHandler(errors)
    return tally
