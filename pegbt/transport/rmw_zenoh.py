"""ROS 2 topics as rmw_zenoh carries them, so pegbt joins a ROS 2 graph with no ROS installation.

What a ROS 2 node running `rmw_zenoh_cpp` expects of a peer, from ros2/rmw_zenoh:
- data keys `<domain>/<topic without outer slashes>/<DDS type name>/<RIHS01 type hash>`
  (`rmw_zenoh_cpp/src/detail/liveliness_utils.cpp`, `TopicInfo`);
- on every sample an attachment of the publication's sequence number, source timestamp (ns) and the
  publisher's 16-byte GID, serialised positionally with zenoh's serializer: int64, int64, then the GID as
  a length-prefixed buffer (`rmw_zenoh_cpp/src/detail/attachment_helpers.cpp`, since ros2/rmw_zenoh#601);
  a subscription drops a sample without one;
- a liveliness token per node (`NN`) and per publisher (`MP`) and subscription (`MS`):
  `@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<kind>/<enclave>/<namespace>/<node>[/<topic>/<type>/<hash>/<qos>]`,
  names with `/` written as `%`, QoS as `reliability:durability:history,depth:deadline:lifespan:liveliness`
  with the fields equal to rmw_zenoh's default left empty (`liveliness_utils.cpp`, `qos_to_keyexpr`);
  an entity's GID is the XXH3-128 hash of its token (low 64 bits first);
- TRANSIENT_LOCAL topics through zenoh-ext advanced publishers (a cache) and subscribers (history with
  late-publisher detection) (`docs/design.md`, "Quality of Service");
- a service keyed as a topic of its type, served by a complete queryable with a token `SS`, called by
  queries with a token `SC`; a request's attachment is the client's (sequence number, timestamp, GID), a
  reply's the same sequence number and client GID with the server's timestamp, and a server drops a request
  without one (`rmw_service_data.cpp`, `rmw_client_data.cpp`; see `pegbt.transport.ros2_service`).
"""

from __future__ import annotations

import itertools
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import xxhash
import zenoh
import zenoh.ext

from pegbt.errors import PegbtError
from pegbt.transport.codec import typestore
from pegbt.transport.ros2 import (
    Publisher,
    Subscriber,
    Topic,
    TopicPublisher,
    TopicSubscriber,
    declare_publisher,
    declare_subscriber,
    matched,
)
from pegbt.transport.ros2_service import (
    SERVICE_DEPTH,
    QueryRequest,
    ServedQueryable,
    Service,
    ServiceCall,
    ServiceRequest,
    ServiceServer,
)

ADMIN_SPACE = "@ros2_lv"
GID_SIZE = 16
# The attachment's one encoding: two int64 (8 bytes each), the GID's length as a LEB128 varint (one byte,
# 16) and its 16 bytes (rmw_zenoh_cpp/src/detail/attachment_helpers.cpp, zenoh-ext's serializer).
ATTACHMENT_SIZE = 8 + 8 + 1 + GID_SIZE
# rmw_zenoh's default QoS (`rmw_zenoh_cpp/src/detail/qos.cpp`): RELIABLE, VOLATILE, KEEP_LAST with depth 42
_DEFAULT_DEPTH = 42
_RELIABLE, _TRANSIENT_LOCAL, _KEEP_ALL = 1, 1, 2  # rmw/types.h's enum values


def domain_id(value: int | None = None) -> int:
    """The ROS 2 domain: `value`, else `ROS_DOMAIN_ID`, else 0; a `PegbtError` if it is not 0-232."""
    text = str(value) if value is not None else os.environ.get("ROS_DOMAIN_ID", "0") or "0"
    if not text.isdigit() or not 0 <= int(text) <= 232:
        raise PegbtError(f"ROS 2 domain id must be an integer 0-232, got {text!r}", field="ROS_DOMAIN_ID")
    return int(text)


def dds_type_name(typename: str) -> str:
    """`sensor_msgs/msg/JointState` → `sensor_msgs::msg::dds_::JointState_`, the name rmw_zenoh keys by."""
    package, kind, name = typename.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def type_hash(typename: str) -> str:
    """The type's RIHS01 hash (REP 2011), computed by rosbags from the message definitions."""
    return str(typestore().hash_rihs01(typename))


def mangle(name: str) -> str:
    """A ROS 2 name as one key chunk: every `/` becomes `%` (`liveliness_utils.cpp`, `mangle_name`)."""
    return name.replace("/", "%")


def qos_token(topic: Topic, publisher: bool = False) -> str:
    """The QoS chunk of an endpoint's token: only what differs from rmw_zenoh's default is written. A
    publisher of commands says KEEP_ALL, the history for which rmw_zenoh blocks under congestion
    (`rmw_publisher_data.cpp`), as `declare_publisher` does for it."""
    durability = str(_TRANSIENT_LOCAL) if topic.latched else ""
    if publisher and topic.command:
        return f":{durability}:{_KEEP_ALL},0:,:,:,,"
    depth = "" if topic.depth == _DEFAULT_DEPTH else str(topic.depth)
    return f":{durability}:,{depth}:,:,:,,"


def encode_attachment(sequence_number: int, source_timestamp_ns: int, gid: bytes) -> bytes:
    """rmw_zenoh's attachment of one sample: int64 sequence number, int64 timestamp, GID buffer."""
    serialized = zenoh.ext.z_serialize(
        (zenoh.ext.Int64(sequence_number), zenoh.ext.Int64(source_timestamp_ns), bytes(gid))
    )
    return serialized.to_bytes()


@dataclass(frozen=True)
class Attachment:
    """What rmw_zenoh attaches to a sample."""

    sequence_number: int
    source_timestamp_ns: int
    gid: bytes


def decode_attachment(raw: zenoh.ZBytes | bytes | None) -> Attachment | None:
    """The attachment of a sample, or None when it is absent or not rmw_zenoh's (such samples are dropped)."""
    if raw is None:
        return None
    data = bytes(raw)
    if len(data) != ATTACHMENT_SIZE or data[16] != GID_SIZE:
        return None  # zenoh's deserializer allocates what a length prefix claims: terabytes abort the process
    try:
        sequence, stamp, gid = zenoh.ext.z_deserialize(
            tuple[zenoh.ext.Int64, zenoh.ext.Int64, bytes], zenoh.ZBytes(data)
        )
    except (zenoh.ext.ZDeserializeError, ValueError, TypeError):
        return None
    if len(gid) != GID_SIZE:
        return None
    return Attachment(int(sequence), int(stamp), bytes(gid))


def gid_of(token: str) -> bytes:
    """An entity's GID: the XXH3-128 hash of its liveliness token, low 64 bits first (`Entity::Entity`)."""
    digest = xxhash.xxh3_128_intdigest(token.encode())
    return (digest & (2**64 - 1)).to_bytes(8, "little") + (digest >> 64).to_bytes(8, "little")


class _Publisher:
    """One topic's publisher with its liveliness token; each sample carries rmw_zenoh's attachment."""

    def __init__(self, entity: Publisher, token: zenoh.LivelinessToken, gid: bytes) -> None:
        self._entity, self._token, self.gid = entity, token, gid
        self._sequence = itertools.count(1)
        self._lock = threading.Lock()
        self.closed = False

    def put(self, payload: bytes) -> None:
        with self._lock:
            attachment = encode_attachment(next(self._sequence), time.time_ns(), self.gid)
            self._entity.put(payload, attachment=attachment)

    @property
    def matched(self) -> bool:
        return matched(self._entity)

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._entity.undeclare()
            self._token.undeclare()


class _Subscriber:
    """One topic's subscriber with its liveliness token (withdrawn once: a subscriber closed by its user is
    closed again by its wire's `close()`)."""

    def __init__(self, entity: Subscriber, token: zenoh.LivelinessToken) -> None:
        self._entity, self._token = entity, token
        self.closed = False

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self._entity.undeclare()
            self._token.undeclare()


@dataclass
class _Client:
    """A service client's token, GID and request sequence numbers."""

    token: zenoh.LivelinessToken
    gid: bytes
    sequence: itertools.count[int] = field(default_factory=lambda: itertools.count(1))


def _service_topic(service: Service) -> Topic:
    """`service` named, typed and with the QoS (`rmw_qos_profile_services_default`) of its keys and tokens."""
    return Topic(service.name, service.typename, depth=SERVICE_DEPTH)


class RmwZenohWire:
    """A ROS 2 node on a zenoh session, as rmw_zenoh_cpp would declare it: keys, attachments, tokens.

    `node_name` and `namespace` name the node in the graph (`ros2 node list`); the topics, written as if
    absolute (`/PSM1/measured_js`), are placed under that namespace, as a bridge's namespace places them.
    The wire holds every endpoint it declares (zenoh undeclares a dropped token) until `close()`.
    Samples without a valid attachment are dropped, as rmw_zenoh drops them, and counted in `dropped`.
    """

    def __init__(
        self,
        session: zenoh.Session,
        node_name: str = "pegbt",
        namespace: str = "/",
        domain: int | None = None,
        enclave: str = "/",
    ) -> None:
        self.session = session
        self.domain = domain_id(domain)
        self.node_name, self.namespace, self.enclave = node_name, namespace, enclave
        self.zid = str(session.zid())
        self.node_id = 0
        self._entity_ids = itertools.count(1)
        self.dropped = 0
        self._endpoints: list[_Publisher | _Subscriber] = []
        self._clients: dict[str, _Client] = {}
        self._node_token = session.liveliness().declare_token(self._token(self.node_id, "NN"))

    def _token(self, entity_id: int, kind: str, topic: Topic | None = None) -> str:
        chunks = [
            ADMIN_SPACE,
            str(self.domain),
            self.zid,
            str(self.node_id),
            str(entity_id),
            kind,
            mangle(self.enclave),
            mangle(self.namespace),
            mangle(self.node_name),
        ]
        if topic is not None:
            chunks += [
                mangle(self.name(topic)),
                dds_type_name(topic.typename),
                type_hash(topic.typename),
                qos_token(topic, publisher=kind == "MP"),
            ]
        return "/".join(chunks)

    def name(self, topic: Topic) -> str:
        """The topic's name in the graph: under the node's namespace (`/lab2/PSM1/measured_js`)."""
        return self.namespace.rstrip("/") + "/" + topic.name.strip("/")

    def key(self, topic: Topic) -> str:
        """The data key of `topic` (`0/PSM1/measured_js/sensor_msgs::msg::dds_::JointState_/RIHS01_…`)."""
        name = self.name(topic).strip("/")
        return f"{self.domain}/{name}/{dds_type_name(topic.typename)}/{type_hash(topic.typename)}"

    def publisher(self, topic: Topic) -> TopicPublisher:
        token = self._token(next(self._entity_ids), "MP", topic)
        entity = declare_publisher(self.session, self.key(topic), topic)
        publisher = _Publisher(entity, self.session.liveliness().declare_token(token), gid_of(token))
        self._endpoints.append(publisher)
        return publisher

    def subscriber(self, topic: Topic, on_payload: Callable[[bytes], None]) -> TopicSubscriber:
        token = self._token(next(self._entity_ids), "MS", topic)

        def deliver(sample: zenoh.Sample) -> None:
            if decode_attachment(sample.attachment) is None:
                self.dropped += 1
                return
            on_payload(sample.payload.to_bytes())

        entity = declare_subscriber(self.session, self.key(topic), topic, deliver)
        subscriber = _Subscriber(entity, self.session.liveliness().declare_token(token))
        self._endpoints = [held for held in self._endpoints if not held.closed]
        self._endpoints.append(subscriber)
        return subscriber

    def serve(self, service: Service, on_request: Callable[[ServiceRequest], None]) -> ServiceServer:
        """A server of `service`: a complete queryable and its `SS` token; a request without a valid
        attachment is dropped (counted in `dropped`), a reply carries the request's sequence number and
        client GID. Undeclared by its own `close()`."""
        as_topic = _service_topic(service)
        key = self.key(as_topic)

        def received(query: zenoh.Query) -> None:
            request = decode_attachment(query.attachment)
            if request is None:
                self.dropped += 1
                return
            reply = encode_attachment(request.sequence_number, time.time_ns(), request.gid)
            on_request(QueryRequest(query, key, reply))

        token = self._token(next(self._entity_ids), "SS", as_topic)
        queryable = self.session.declare_queryable(key, received, complete=True)
        return ServedQueryable(queryable, self.session.liveliness().declare_token(token))

    def call(self, service: Service, request: bytes, timeout: float) -> ServiceCall:
        """Send one request to `service` with this client's attachment; its `SC` token is declared on the
        first call and held until `close()`."""
        as_topic = _service_topic(service)
        client = self._clients.get(service.name)
        if client is None:
            token = self._token(next(self._entity_ids), "SC", as_topic)
            client = _Client(self.session.liveliness().declare_token(token), gid_of(token))
            self._clients[service.name] = client
        call = ServiceCall(service, timeout)
        self.session.get(
            self.key(as_topic),
            zenoh.handlers.Callback(call.on_reply, call.on_finished),
            payload=request,
            attachment=encode_attachment(next(client.sequence), time.time_ns(), client.gid),
            target=zenoh.QueryTarget.ALL_COMPLETE,
            consolidation=zenoh.ConsolidationMode.NONE,
            timeout=timeout,
        )
        return call

    def close(self) -> None:
        """Withdraw the node and every endpoint it declared from the graph."""
        for endpoint in self._endpoints:
            endpoint.close()
        self._endpoints.clear()
        for client in self._clients.values():
            client.token.undeclare()
        self._clients.clear()
        self._node_token.undeclare()
