"""The monitor's web server (aiohttp, on 127.0.0.1 only): the page, its bundled JavaScript, and a WebSocket.

Messages are JSON objects: the tick log's own records (`header`, `tick`, `halt`, `crash`, `end`, see
`pegbt.executive.ticklog`), and `mode`, `causes`, `scene`, `world`. The server keeps every message it has
sent: a page that connects late gets them all first, then the new ones. Producers may run on any thread;
`publish` hands messages to the server's event loop, which sends them in batches (one WebSocket frame of
a JSON list every `FLUSH_PERIOD`) so a fast lockstep run does not cost a frame per tick.
"""

from __future__ import annotations

import asyncio
import json
import threading
from pathlib import Path
from typing import Any

from aiohttp import WSMsgType, web

from pegbt.errors import PegbtError

WEB_DIR = Path(__file__).resolve().parent / "web"
BUNDLE = WEB_DIR / "dist" / "monitor.js"
FLUSH_PERIOD = 0.05  # s between two batches sent to the pages
HOST = "127.0.0.1"


class MonitorServer:
    """Serves the monitor page on `http://127.0.0.1:PORT/` from a thread of its own until `stop()`."""

    def __init__(self, port: int) -> None:
        if not BUNDLE.exists():
            raise PegbtError(
                "the monitor page is not built: run dev/setup (it runs npm ci and the esbuild build)",
                file=BUNDLE,
            )
        self.port = port
        self._history: list[str] = []  # each message once, JSON-encoded, in the order sent
        self._pending: list[str] = []
        self._clients: set[web.WebSocketResponse] = set()
        self._loop = asyncio.new_event_loop()
        self._started = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._serve, name="pegbt-monitor", daemon=True)

    @property
    def url(self) -> str:
        return f"http://{HOST}:{self.port}/"

    def start(self) -> MonitorServer:
        self._thread.start()
        self._started.wait(30)
        if self._error is not None:
            raise PegbtError(f"cannot serve the monitor on port {self.port}: {self._error}", field="port")
        return self

    def publish(self, message: dict[str, Any]) -> None:
        """Send `message` to every page, now and to any that connects later; safe from any thread."""
        text = json.dumps(message, separators=(",", ":"))
        self._loop.call_soon_threadsafe(self._pending.append, text)

    def serve_until_interrupted(self, what: str) -> None:
        """Block until Ctrl-C, saying where the page is."""
        print(f"monitor: {what} at {self.url} (Ctrl-C to stop)", flush=True)
        try:
            threading.Event().wait()
        except KeyboardInterrupt:
            pass

    def stop(self) -> None:
        if self._thread.is_alive():
            asyncio.run_coroutine_threadsafe(self._shutdown(), self._loop).result(10)
            self._thread.join(10)

    def _serve(self) -> None:
        asyncio.set_event_loop(self._loop)
        app = web.Application()
        app.router.add_get("/", self._page)
        app.router.add_get("/ws", self._socket)
        app.router.add_get("/static/monitor.css", self._stylesheet)
        app.router.add_static("/static/dist/", BUNDLE.parent, follow_symlinks=False)
        self._runner = web.AppRunner(app, access_log=None)
        try:
            self._loop.run_until_complete(self._runner.setup())
            self._loop.run_until_complete(web.TCPSite(self._runner, HOST, self.port).start())
        except OSError as error:
            self._error = error
            self._started.set()
            return
        self._flusher = self._loop.create_task(self._flush_forever())
        self._started.set()
        self._loop.run_forever()

    async def _shutdown(self) -> None:
        self._flush()
        self._flusher.cancel()
        for client in list(self._clients):
            await client.close()
        await self._runner.cleanup()
        self._loop.call_soon(self._loop.stop)

    async def _page(self, request: web.Request) -> web.FileResponse:
        return web.FileResponse(WEB_DIR / "index.html")

    async def _stylesheet(self, request: web.Request) -> web.FileResponse:
        return web.FileResponse(WEB_DIR / "monitor.css")

    async def _socket(self, request: web.Request) -> web.WebSocketResponse:
        socket = web.WebSocketResponse(heartbeat=30, max_msg_size=0)
        await socket.prepare(request)
        await socket.send_str("[" + ",".join(self._history) + "]")
        self._clients.add(socket)
        try:
            async for message in socket:
                if message.type == WSMsgType.ERROR:
                    break
        finally:
            self._clients.discard(socket)
        return socket

    async def _flush_forever(self) -> None:
        while True:
            await asyncio.sleep(FLUSH_PERIOD)
            self._flush()

    def _flush(self) -> None:
        if not self._pending:
            return
        batch, self._pending = self._pending, []
        self._history.extend(batch)
        frame = "[" + ",".join(batch) + "]"
        for client in list(self._clients):
            if not client.closed:
                asyncio.ensure_future(client.send_str(frame))
