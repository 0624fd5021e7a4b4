"""ROS 2 services over zenoh: a server is a queryable, a call is a query whose one reply is the response.

zenoh-bridge-ros2dds (`zenoh-plugin-ros2dds/src/route_service_srv.rs`, `route_service_cli.rs`) serves a ROS 2
service server as a queryable on the service's name without its leading `/` under the bridge's namespace,
the same key a topic of that name would have. A query's payload is the request as CDR with its 4-byte
encapsulation header; the bridge inserts the DDS request id itself (from the query's attachment when another
bridge sent one, else its own), and a reply's payload is the response as CDR, the request id stripped again.
A query without a reply is never answered: the caller's timeout is the only end.

rmw_zenoh (`rmw_zenoh_cpp/src/detail/rmw_service_data.cpp`, `rmw_client_data.cpp`) keys a service as it keys
a topic (`<domain>/<name>/<type>/<RIHS01 hash>`, the type named without `_Request`/`_Response`), its
queryable complete; a request carries the client's attachment (sequence number, timestamp, GID) and the
reply carries the same sequence number and client GID with the server's timestamp. Those wires live in
`pegbt.transport.rmw_zenoh`; what both share is here.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import zenoh

from pegbt.transport.keys import scoped
from pegbt.transport.link import EndpointSilent

SERVICE_DEPTH = 10  # rmw_qos_profile_services_default: reliable, volatile, keep last 10 (rmw/qos_profiles.h)


@dataclass(frozen=True)
class Service:
    """A ROS 2 service: its name (`/capture`) and type (`std_srvs/srv/Trigger`)."""

    name: str
    typename: str


class ServiceRequest(Protocol):
    """One request a server received: its CDR payload, answered once by `reply` (from any thread)."""

    payload: bytes

    def reply(self, payload: bytes) -> None: ...


class ServiceServer(Protocol):
    """A declared service server, until closed."""

    def close(self) -> None: ...


class ServiceFailed(EndpointSilent):
    """A service call that got no response (nobody serves it, or no reply came in time), or a response that
    says the service failed."""


class ServiceCall:
    """A call in flight: `done` once the response came or the call ended without one; then `result()`."""

    def __init__(self, service: Service, timeout: float) -> None:
        self.service, self.timeout = service, timeout
        self.sent_at = time.monotonic()
        self._response: bytes | None = None
        self._error: str | None = None
        self._done = threading.Event()

    @property
    def done(self) -> bool:
        return self._done.is_set()

    def respond(self, payload: bytes) -> None:
        if not self._done.is_set():
            self._response = payload
            self._done.set()

    def fail(self, why: str) -> None:
        if not self._done.is_set():
            self._error = why
            self._done.set()

    def result(self, timeout: float = 0.0) -> bytes:
        """The response's CDR bytes, waiting up to `timeout` s; `ServiceFailed` naming the service if none."""
        if not self._done.wait(timeout):
            raise ServiceFailed(f"service {self.service.name}: no response yet", field=self.service.name)
        if self._response is None:
            raise ServiceFailed(f"service {self.service.name}: {self._error}", field=self.service.name)
        return self._response

    def on_reply(self, reply: zenoh.Reply) -> None:
        """A zenoh reply: the response, or an error (zenoh's own when the query timed out)."""
        if reply.ok is not None:
            self.respond(reply.ok.payload.to_bytes())
        elif reply.err is not None:
            text = reply.err.payload.to_bytes().decode(errors="replace")
            self.fail(
                f"no response within {self.timeout:g} s" if text == "Timeout" else f"error reply: {text}"
            )

    def on_finished(self) -> None:
        """Zenoh ended the query (every replier answered, or the timeout passed); without a response, why."""
        if time.monotonic() - self.sent_at < self.timeout / 2:
            self.fail(
                "no server answered: is the node that serves it running, and its bridge or router reachable?"
            )
        else:
            self.fail(f"no response within {self.timeout:g} s")


class QueryRequest:
    """A request that came as a zenoh query; the reply (with `attachment`, if any) goes back on the server's
    key, and the query ends with it."""

    def __init__(self, query: zenoh.Query, key: str, attachment: bytes | None = None) -> None:
        self._query: zenoh.Query | None = query
        self._key, self._attachment = key, attachment
        payload = query.payload
        self.payload = b"" if payload is None else payload.to_bytes()
        self._lock = threading.Lock()

    def reply(self, payload: bytes) -> None:
        with self._lock:
            if self._query is None:
                return
            query, self._query = self._query, None
        query.reply(self._key, payload, attachment=self._attachment)
        query.drop()  # the query is finished: the caller's get ends now, not at its timeout


class ServedQueryable:
    """A service server's queryable and the liveliness tokens that announce it."""

    def __init__(self, queryable: zenoh.Queryable[None], *tokens: zenoh.LivelinessToken) -> None:
        self._queryable, self._tokens = queryable, tokens

    def close(self) -> None:
        self._queryable.undeclare()
        for token in self._tokens:
            token.undeclare()


def bridge_service_key(namespace: str, service: Service) -> str:
    """The key zenoh-bridge-ros2dds serves `service` on (`/capture` → `capture`, under the namespace)."""
    return scoped(namespace, service.name.lstrip("/"))


def serve_on_bridge(
    session: zenoh.Session, namespace: str, service: Service, on_request: Callable[[ServiceRequest], None]
) -> ServiceServer:
    """A server of `service` as the bridge exposes a ROS 2 one: a complete queryable, plain CDR."""
    key = bridge_service_key(namespace, service)

    def received(query: zenoh.Query) -> None:
        on_request(QueryRequest(query, key))

    return ServedQueryable(session.declare_queryable(key, received, complete=True))


def call_on_bridge(
    session: zenoh.Session, namespace: str, service: Service, request: bytes, timeout: float
) -> ServiceCall:
    """Call `service` through the bridge: one query with the request's CDR, its first reply the response."""
    call = ServiceCall(service, timeout)
    session.get(
        bridge_service_key(namespace, service),
        zenoh.handlers.Callback(call.on_reply, call.on_finished),
        payload=request,
        target=zenoh.QueryTarget.ALL_COMPLETE,
        consolidation=zenoh.ConsolidationMode.NONE,
        timeout=timeout,
    )
    return call
