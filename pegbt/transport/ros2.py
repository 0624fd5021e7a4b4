"""How a ROS 2 topic becomes zenoh traffic: the wire a robot's CRTK topics travel on.

A `Ros2Wire` turns (topic, ROS 2 type, durability) into zenoh publishers and subscribers that carry the
topic's CDR bytes. Everything that speaks to a ROS 2 robot (the dVRK interface of the simulator, the
executive's CRTK client, recorders) declares its topics through a wire, never through raw zenoh keys, so
that the same code runs over zenoh-bridge-ros2dds (`BridgeWire`, here) and over rmw_zenoh (its own wire,
with rmw_zenoh's keys, attachments and liveliness tokens).

`BridgeWire` reproduces what eclipse-zenoh/zenoh-plugin-ros2dds does with a topic
(`zenoh-plugin-ros2dds/src/route_publisher.rs`, `route_subscriber.rs`): the key is the ROS 2 name without
its leading `/` under the bridge's namespace, the payload is the CDR bytes unchanged, no attachment; a
TRANSIENT_LOCAL topic (the dVRK's `operating_state`) is served to late joiners from a zenoh-ext
`AdvancedPublisher` cache with publisher detection, and read with an `AdvancedSubscriber` whose history
detects late publishers.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import zenoh
import zenoh.ext

from pegbt.transport.keys import scoped
from pegbt.transport.ros2_service import (
    Service,
    ServiceCall,
    ServiceRequest,
    ServiceServer,
    call_on_bridge,
    serve_on_bridge,
)

LOG = logging.getLogger("pegbt.transport")


@dataclass(frozen=True)
class Topic:
    """A ROS 2 topic: its name (`/PSM1/measured_js`), its type (`sensor_msgs/msg/JointState`), whether
    it is latched (TRANSIENT_LOCAL durability, the last `depth` messages kept for late joiners), whether
    it carries commands, each of which matters (not a stream whose next message replaces the last), and
    whether, not a command, each message still matters (a camera's cloud taken on request). A subscriber
    of a `keep_last` topic holds at most that many messages its reader has not taken, dropping the oldest,
    as rmw_zenoh does for a KEEP_LAST subscription (rmw_zenoh_cpp `rmw_subscription_data.cpp`,
    `add_new_message`): a reader slower than the stream then reads its newest message, never a backlog that
    grows for as long as it is slow; 0 delivers every message."""

    name: str
    typename: str
    latched: bool = False
    depth: int = 1
    command: bool = False
    reliable: bool = False
    keep_last: int = 0


class TopicPublisher(Protocol):
    """Publishes CDR bytes on one topic."""

    def put(self, payload: bytes) -> None: ...

    @property
    def matched(self) -> bool:
        """Whether any subscriber listens (a publisher may then skip work nobody would receive)."""
        ...

    def close(self) -> None: ...


class TopicSubscriber(Protocol):
    """Receives CDR bytes on one topic until closed."""

    def close(self) -> None: ...


class Ros2Wire(Protocol):
    """Declares a process's ROS 2 publishers and subscribers on one zenoh session; holds them until
    `close()` (zenoh undeclares an entity nobody holds)."""

    def publisher(self, topic: Topic) -> TopicPublisher: ...

    def subscriber(self, topic: Topic, on_payload: Callable[[bytes], None]) -> TopicSubscriber: ...

    def serve(self, service: Service, on_request: Callable[[ServiceRequest], None]) -> ServiceServer: ...

    def call(self, service: Service, request: bytes, timeout: float) -> ServiceCall: ...

    def close(self) -> None: ...


class _Closing:
    """A declared zenoh entity that `close()` undeclares (once: a subscriber closed by its user is closed
    again by its wire's `close()`)."""

    def __init__(
        self,
        entity: zenoh.Publisher
        | zenoh.Subscriber
        | zenoh.ext.AdvancedPublisher
        | zenoh.ext.AdvancedSubscriber,
    ) -> None:
        self._entity = entity
        self.closed = False

    def put(self, payload: bytes) -> None:
        self._entity.put(payload)  # type: ignore[union-attr]

    @property
    def matched(self) -> bool:
        return matched(self._entity)  # type: ignore[arg-type]

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._entity.undeclare()


class BridgeWire:
    """Topics as zenoh-bridge-ros2dds maps them: `namespace/topic` keys, plain CDR, no attachment."""

    def __init__(self, session: zenoh.Session, namespace: str = "") -> None:
        self.session = session
        self.namespace = namespace
        self._endpoints: list[_Closing] = []

    def _held(self, endpoint: _Closing) -> _Closing:
        self._endpoints = [held for held in self._endpoints if not held.closed] + [endpoint]
        return endpoint

    def close(self) -> None:
        """Undeclare every publisher and subscriber declared through this wire."""
        for endpoint in self._endpoints:
            endpoint.close()
        self._endpoints.clear()

    def key(self, topic: Topic) -> str:
        """The zenoh key of `topic` (`/PSM1/measured_js` → `PSM1/measured_js`, under the namespace)."""
        return scoped(self.namespace, topic.name.lstrip("/"))

    def publisher(self, topic: Topic) -> TopicPublisher:
        return self._held(_Closing(declare_publisher(self.session, self.key(topic), topic)))

    def subscriber(self, topic: Topic, on_payload: Callable[[bytes], None]) -> TopicSubscriber:
        def deliver(sample: zenoh.Sample) -> None:
            on_payload(sample.payload.to_bytes())

        return self._held(_Closing(declare_subscriber(self.session, self.key(topic), topic, deliver)))

    def serve(self, service: Service, on_request: Callable[[ServiceRequest], None]) -> ServiceServer:
        """A server of `service` on the bridge's key (a queryable); undeclared by its own `close()`."""
        return serve_on_bridge(self.session, self.namespace, service, on_request)

    def call(self, service: Service, request: bytes, timeout: float) -> ServiceCall:
        """Send one request to `service`; the handle has its response, or why none came."""
        return call_on_bridge(self.session, self.namespace, service, request, timeout)


Publisher = zenoh.Publisher | zenoh.ext.AdvancedPublisher
Subscriber = zenoh.Subscriber | zenoh.ext.AdvancedSubscriber


def matched(publisher: Publisher) -> bool:
    """Whether a subscriber matches `publisher`'s key (a latched publisher's cache serves late joiners, so it
    counts as matched)."""
    if isinstance(publisher, zenoh.Publisher):
        # the stub says bool; zenoh 1.10 returns a MatchingStatus, whose `matching` is the bool
        return publisher.matching_status.matching  # type: ignore[attr-defined]
    return True


def declare_publisher(session: zenoh.Session, key: str, topic: Topic) -> Publisher:
    """A publisher of `topic` on `key`: for a latched topic, a zenoh-ext advanced publisher whose cache
    serves late joiners (what a bridge and rmw_zenoh both do for TRANSIENT_LOCAL), else a plain one. A
    command blocks under congestion rather than be dropped, as the bridge routes a RELIABLE writer
    (zenoh-plugin-ros2dds `route_publisher.rs`, `reliable_routes_blocking`); a stream drops what a congested
    link cannot take, as rmw_zenoh does for KEEP_LAST (`rmw_publisher_data.cpp`); a `reliable` topic blocks
    too (a RELIABLE writer through the bridge)."""
    if topic.latched:
        return zenoh.ext.declare_advanced_publisher(
            session,
            key,
            cache=zenoh.ext.CacheConfig(max_samples=topic.depth),
            publisher_detection=True,
            reliability=zenoh.Reliability.RELIABLE,
            congestion_control=zenoh.CongestionControl.BLOCK,
        )
    congestion = (
        zenoh.CongestionControl.BLOCK if topic.command or topic.reliable else zenoh.CongestionControl.DROP
    )
    return session.declare_publisher(key, express=True, congestion_control=congestion)


def declare_subscriber(
    session: zenoh.Session, key: str, topic: Topic, deliver: Callable[[zenoh.Sample], None]
) -> Subscriber:
    """A subscriber of `topic` on `key`: for a latched topic, an advanced subscriber that asks for the
    history and detects late publishers, else a plain one."""
    if topic.latched:
        return zenoh.ext.declare_advanced_subscriber(
            session,
            key,
            deliver,
            history=zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=topic.depth),
        )
    if topic.keep_last:
        return _newest_first(session, key, topic.keep_last, deliver)
    return session.declare_subscriber(key, deliver)


def _newest_first(
    session: zenoh.Session, key: str, keep: int, deliver: Callable[[zenoh.Sample], None]
) -> zenoh.Subscriber:
    """A subscriber whose `keep` newest samples wait in a ring (older ones dropped) for a thread that
    delivers them; undeclaring it ends the thread. A reader that raises is reported and given the next
    sample, as zenoh does for a callback."""
    subscriber = session.declare_subscriber(key, zenoh.handlers.RingChannel(keep))

    def drain() -> None:
        for sample in subscriber:
            try:
                deliver(sample)
            except Exception:
                LOG.exception("%s: the reader of a sample failed; it gets the next one", key)

    threading.Thread(target=drain, name=f"{key} (newest {keep})", daemon=True).start()
    return subscriber
