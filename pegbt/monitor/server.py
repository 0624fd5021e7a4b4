"""The monitor's web server (aiohttp, on 127.0.0.1 only): the page, its bundled JavaScript, and a WebSocket.

Messages are JSON objects: the tick log's own records (`header`, `tick`, `halt`, `crash`, `end`, see
`pegbt.executive.ticklog`), and `mode`, `causes`, `scene`, `world`, `snapshot` (`pegbt.monitor.history`).
A page that connects late gets the history's snapshot first, then the new messages. Producers may run on
any thread; `publish` hands messages to the server's event loop, which sends them in batches (one
WebSocket frame of a JSON list every `FLUSH_PERIOD`) so a fast lockstep run does not cost a frame per tick.

Who may read the run (as Jupyter Server guards its kernels): the page and its static files carry no run
data and need no token; the WebSocket does, and its upgrade is refused (403) without the token printed in
the page's URL (`?token=…`, compared in constant time), or from any `Origin` but the page's own (browsers
let any page open a WebSocket anywhere); every request is refused (403) unless its `Host` is
`127.0.0.1:PORT` or `localhost:PORT`, so a DNS-rebound name reaches nothing. Nothing a page sends can
hold up the run: the server runs on a thread of its own, a message larger than `MAX_MESSAGE` closes the
socket at its header, and a page that falls behind (more than `CLIENT_BUFFER` bytes or `CLIENT_LAG` seconds
of frames waiting) is dropped rather than buffered for.
"""

from __future__ import annotations

import asyncio
import hmac
import json
import logging
import secrets
import threading
import time
from collections import deque
from collections.abc import Awaitable, Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from aiohttp import WSMsgType, web
from aiohttp.http_exceptions import HttpProcessingError

from pegbt.errors import PegbtError
from pegbt.monitor.history import History
from pegbt.stopsignals import stop_signals

WEB_DIR = Path(__file__).resolve().parent / "web"
BUNDLE = WEB_DIR / "dist" / "monitor.js"
FLUSH_PERIOD = 0.05  # s between two batches sent to the pages
HOST = "127.0.0.1"
MAX_MESSAGE = 4096  # bytes of one message from a page (the page sends none)
CLIENT_BUFFER = 1024 * 1024  # bytes of frames waiting for one page (beyond its first) before it is dropped
CLIENT_LAG = 5.0  # s the oldest frame for one page may wait before the page is dropped
MAX_CLIENTS = 32

Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


@dataclass
class _Client:
    """One page's socket and the frames waiting for it (each with when it was queued)."""

    socket: web.WebSocketResponse
    request: web.Request
    frames: deque[tuple[float, bytes]] = field(default_factory=deque)
    queued: int = 0
    ready: asyncio.Event = field(default_factory=asyncio.Event)


class MonitorServer:
    """Serves the monitor page on `http://127.0.0.1:PORT/` from a thread of its own until `stop()`.

    `port=0` takes a free port (`port` is the one taken once started). `require_token=False` serves the
    run to any program on this machine that reaches the port (`--no-token`). `history`: `History()` for
    a live run (bounded, the default), `History.whole()` for a replay (every message)."""

    def __init__(self, port: int, *, require_token: bool = True, history: History | None = None) -> None:
        if not BUNDLE.exists():
            raise PegbtError(
                "the monitor page is not built: run dev/setup (it runs npm ci and the esbuild build)",
                file=BUNDLE,
            )
        self.port = port
        self.token = secrets.token_urlsafe(32) if require_token else None
        self.history = history if history is not None else History()
        self._pending: list[tuple[dict[str, Any], str]] = []
        self._clients: dict[web.WebSocketResponse, _Client] = {}
        self.dropped = 0  # pages dropped for falling behind
        self._loop = asyncio.new_event_loop()
        self._started = threading.Event()
        self._error: BaseException | None = None
        self._allowed_hosts: set[str] = set()  # known once the port is bound
        self._allowed_origins: set[str] = set()
        self._thread = threading.Thread(target=self._serve, name="pegbt-monitor", daemon=True)

    @property
    def url(self) -> str:
        """The page's address, with the token a browser needs."""
        query = f"?token={self.token}" if self.token else ""
        return f"http://{HOST}:{self.port}/{query}"

    @property
    def clients(self) -> int:
        return len(self._clients)

    def start(self) -> MonitorServer:
        logging.getLogger("aiohttp.server").addFilter(_answered_malformed)
        self._thread.start()
        self._started.wait(30)
        if self._error is not None:
            raise PegbtError(f"cannot serve the monitor on port {self.port}: {self._error}", field="port")
        return self

    def publish(self, message: dict[str, Any]) -> None:
        """Send `message` to every page, now and to any that connects later; safe from any thread."""
        text = json.dumps(message, separators=(",", ":"))
        self._loop.call_soon_threadsafe(self._pending.append, (message, text))

    def serve_until_interrupted(self, what: str) -> None:
        """Block until Ctrl-C or SIGTERM, saying where the page is. The handlers are installed for the wait:
        a process started where SIGINT is ignored (a shell script's background job inherits that) would
        otherwise serve for ever, deaf to the Ctrl-C it asks for."""
        try:
            with stop_signals():
                print(f"monitor: {what} at {self.url} (Ctrl-C to stop)", flush=True)
                threading.Event().wait()
        except KeyboardInterrupt:
            pass

    def stop(self) -> None:
        if self._thread.is_alive():
            asyncio.run_coroutine_threadsafe(self._shutdown(), self._loop).result(10)
            self._thread.join(10)

    def _serve(self) -> None:
        asyncio.set_event_loop(self._loop)
        app = web.Application(middlewares=[self._check_host])
        app.router.add_get("/", self._page)
        app.router.add_get("/ws", self._socket)
        app.router.add_get("/static/monitor.css", self._stylesheet)
        app.router.add_static("/static/dist/", BUNDLE.parent, follow_symlinks=False)
        self._runner = web.AppRunner(app, access_log=None)
        try:
            self._loop.run_until_complete(self._runner.setup())
            site = web.TCPSite(self._runner, HOST, self.port)
            self._loop.run_until_complete(site.start())
        except OSError as error:
            self._error = error
            self._started.set()
            return
        server = site._server  # the asyncio server, for the port a port of 0 took
        assert isinstance(server, asyncio.Server), "a TCPSite's server once started"
        self.port = server.sockets[0].getsockname()[1]
        self._allowed_hosts = {f"{HOST}:{self.port}", f"localhost:{self.port}"}
        self._allowed_origins = {f"http://{host}" for host in self._allowed_hosts}
        self._flusher = self._loop.create_task(self._flush_forever())
        self._started.set()
        self._loop.run_forever()

    async def _shutdown(self) -> None:
        self._flush()
        self._flusher.cancel()
        for client in list(self._clients.values()):
            self._drop(client)
        await self._runner.cleanup()
        self._loop.call_soon(self._loop.stop)

    @web.middleware
    async def _check_host(self, request: web.Request, handler: Handler) -> web.StreamResponse:
        if request.headers.get("Host") not in self._allowed_hosts:
            raise web.HTTPForbidden(text="this monitor answers only to 127.0.0.1 and localhost on its port\n")
        return await handler(request)

    async def _page(self, request: web.Request) -> web.FileResponse:
        return web.FileResponse(WEB_DIR / "index.html", headers={"Referrer-Policy": "no-referrer"})

    async def _stylesheet(self, request: web.Request) -> web.FileResponse:
        return web.FileResponse(WEB_DIR / "monitor.css")

    async def _socket(self, request: web.Request) -> web.WebSocketResponse:
        if request.headers.get("Origin") not in self._allowed_origins:
            raise web.HTTPForbidden(text="the run is shown only to the monitor's own page\n")
        if self.token and not _same(request.query.get("token", ""), self.token):
            raise web.HTTPForbidden(text="a wrong or missing token: open the URL the monitor printed\n")
        if len(self._clients) >= MAX_CLIENTS:
            raise web.HTTPServiceUnavailable(text=f"at most {MAX_CLIENTS} pages at once\n")
        socket = web.WebSocketResponse(heartbeat=30, max_msg_size=MAX_MESSAGE, compress=False)
        await socket.prepare(request)
        self._flush()  # the history is up to date before this page's first frame
        client = _Client(socket, request)
        self._clients[socket] = client
        self._queue(client, _frame(self.history.snapshot()))
        sender = asyncio.ensure_future(self._send_forever(client))
        try:
            async for message in socket:
                if message.type == WSMsgType.ERROR:
                    break
        finally:
            sender.cancel()
            self._clients.pop(socket, None)
        return socket

    async def _send_forever(self, client: _Client) -> None:
        try:
            while True:
                await client.ready.wait()
                client.ready.clear()
                while client.frames:
                    _, frame = client.frames.popleft()
                    client.queued -= len(frame)
                    await client.socket.send_frame(frame, WSMsgType.TEXT)
        except (ConnectionError, RuntimeError):  # the page went away mid-frame
            self._drop(client)

    async def _flush_forever(self) -> None:
        while True:
            await asyncio.sleep(FLUSH_PERIOD)
            self._flush()

    def _flush(self) -> None:
        if not self._pending:
            return
        batch, self._pending = self._pending, []
        for message, text in batch:
            self.history.add(message, text)
        frame = _frame(text for _, text in batch)
        for client in list(self._clients.values()):
            self._queue(client, frame)

    def _queue(self, client: _Client, frame: bytes) -> None:
        """Queue `frame` for one page, or drop the page if what waits for it is too much or too old."""
        now = time.monotonic()
        if client.frames and (client.queued > CLIENT_BUFFER or now - client.frames[0][0] > CLIENT_LAG):
            self.dropped += 1
            self._drop(client)
            return
        client.frames.append((now, frame))
        client.queued += len(frame)
        client.ready.set()

    def _drop(self, client: _Client) -> None:
        """Cut the page's connection at once: no closing handshake to wait for, its frames freed."""
        self._clients.pop(client.socket, None)
        client.frames.clear()
        client.queued = 0
        if client.request.transport is not None:
            client.request.transport.abort()


def _answered_malformed(record: logging.LogRecord) -> bool:
    """Leave out aiohttp's traceback for a request it could not parse: the client's error, answered 400."""
    return not (record.exc_info and isinstance(record.exc_info[1], HttpProcessingError))


def _frame(texts: Iterable[str]) -> bytes:
    """One WebSocket text frame's payload: the messages as a JSON list, encoded once for every page."""
    return ("[" + ",".join(texts) + "]").encode()


def _same(given: str, token: str) -> bool:
    """Constant-time comparison of UTF-8 bytes (`compare_digest` refuses non-ASCII `str`)."""
    return hmac.compare_digest(given.encode("utf-8", "surrogateescape"), token.encode())


def start_ephemeral(messages: Iterable[dict[str, Any]] = (), **options: Any) -> MonitorServer:
    """A started server on a free port of 127.0.0.1, fed `messages` (for tests, benches and fuzzing)."""
    server = MonitorServer(0, **options).start()
    for message in messages:
        server.publish(message)
    return server
