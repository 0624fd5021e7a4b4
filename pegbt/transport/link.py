"""A `Link`: one zenoh session as the clients of a process share it.

It bundles the session, the key namespace, this process's message `Source`, and every `Inlet` the
clients opened, so a lockstep `SimClock` can wait for exactly what the simulator sent before answering.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

import zenoh

from pegbt.errors import PegbtError
from pegbt.transport.endpoints import DEFAULT_ENDPOINT
from pegbt.transport.keys import check_namespace
from pegbt.transport.sequencing import Inlet, Outlet, Received, Source, Tag
from pegbt.transport.session import client_settings, open_session


class EndpointSilent(PegbtError):
    """The endpoint stopped publishing (crashed, unplugged) or never started."""

    exit_status = 3  # the endpoint was lost: not the user's input


T = TypeVar("T")


class Link:
    """A session plus namespace, message source and the inlets opened through it."""

    def __init__(self, session: zenoh.Session, namespace: str = "", *, owns_session: bool = False) -> None:
        self.session = session
        self.namespace = check_namespace(namespace)
        self.source = Source()
        self.inlets: list[Inlet] = []
        self._outlets: list[Outlet] = []
        self._owns_session = owns_session
        self._taps: tuple[Callable[[str, Received[Any]], None], Callable[[str, bytes], None]] | None = None

    def inlet(
        self, key: str, decode: Callable[[bytes], T], on_message: Callable[[Received[T]], None] | None = None
    ) -> Inlet[T]:
        inlet = Inlet(self.session, key, decode, on_message)
        inlet.tap = self._taps and self._taps[0]
        self.inlets.append(inlet)
        return inlet

    def outlet(self, key: str) -> Outlet:
        outlet = Outlet(self.session, key, self.source)
        outlet.tap = self._taps and self._taps[1]
        self._outlets.append(outlet)
        return outlet

    def tap(self, received: Callable[[str, Received[Any]], None], sent: Callable[[str, bytes], None]) -> None:
        """Show every message the inlets take (on their keys or bundled in a step's reply) to `received`
        and every payload the outlets put to `sent`: what crosses the wire, as the clients see it."""
        self._taps = (received, sent)
        for inlet in self.inlets:
            inlet.tap = received
        for outlet in self._outlets:
            outlet.tap = sent

    def query(self, key: str, request: dict[str, Any], timeout: float) -> dict[str, Any]:
        """Send a JSON request to the simulator's queryable `key`; its JSON answer, or a `PegbtError` if
        none comes or it refuses."""
        # the first reply, as soon as it comes: the query's end follows, and nobody needs to wait for it; the query
        # (and so its reply, which takes its QoS) blocks rather than drops in a congested queue
        replies = self.session.get(
            key,
            payload=json.dumps(request),
            timeout=timeout,
            express=True,
            congestion_control=zenoh.CongestionControl.BLOCK,
        )
        reply = next(iter(replies), None)
        if reply is None:
            raise PegbtError(
                f"no simulator answers on {key} (is `pegbt sim` running and reachable?)", field=key
            )
        if reply.ok is None:
            assert reply.err is not None  # a reply is either ok or an error
            raise PegbtError(f"simulator refused {key}: {reply.err.payload.to_string()}", field=key)
        return json.loads(reply.ok.payload.to_bytes())

    def deliver(self, key: str, tag: Tag, payload: bytes) -> None:
        """Hand a message of `key` that came bundled in another to every inlet of that key."""
        for inlet in self.inlets:
            if inlet.key == key:
                inlet.deliver(payload, tag)

    def deliver_value(self, key: str, tag: Tag, value: Callable[[], Any]) -> None:
        """Hand every inlet of `key` a message whose value `value()` gives (called on first read)."""
        received = Received(b"", lambda _: value(), tag, time.monotonic())
        for inlet in self.inlets:
            if inlet.key == key:
                inlet.take(received)

    def close(self) -> None:
        """Undeclare everything opened here; close the session if this link opened it."""
        for inlet in self.inlets:
            inlet.close()
        for outlet in self._outlets:
            outlet.close()
        self.inlets.clear()
        self._outlets.clear()
        if self._owns_session:
            self.session.close()

    def __enter__(self) -> Link:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def connect(endpoints: Sequence[str] = (DEFAULT_ENDPOINT,), namespace: str = "") -> Link:
    """Open a peer session to `endpoints` (loopback port 7447 by default) and wrap it in a `Link`."""
    check_namespace(namespace)  # before a session is opened that a refused namespace would leave open
    return Link(open_session(client_settings(endpoints)), namespace, owns_session=True)
