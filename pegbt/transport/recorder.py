"""Record what crosses the wire to one MCAP file, as rosbag2 writes it: ROS 2 schemas (`ros2msg`), CDR messages.

`WireRecorder.attach(link)` taps a client's `Link` (`listen(wire, topics)` subscribes to a CRTK robot's topics instead): every message its inlets take (on their topics, or bundled in a
lockstep step's reply, where a re-stamped joint state becomes the last full one with the new stamp) and
every payload its outlets put, each on its ROS 2 topic (`/PSM1/measured_js`) with its ROS 2 type and the
same CDR bytes (a note is encoded as the simulator encodes the full state). Camera clouds keep every `cloud_step`-th point (1: as received). Beside them, JSON as
`std_msgs/msg/String`: `/pegbt/ticks` (the tick log's status changes, from `tick_record`) and
`/pegbt/events` (the simulator's faults and world events from `sim/events`). The simulator records its
side through the same methods (`SimEndpoint.record`).

Log times are the run's clock (simulated seconds in lockstep; the file's `pegbt` metadata says which):
a stamped message's header stamp, else the clock when it crossed. The `mcap` library writes the file in
chunks, finished at least every `FLUSH_S` of wall time, so a file cut by a crash reads up to its last chunk.
"""

from __future__ import annotations

import json
import struct
import threading
import time
from collections.abc import Callable, Iterable
from functools import cache, partial
from pathlib import Path
from typing import Any

import numpy as np
import zenoh
from mcap.writer import CompressionType, Writer
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2.metadata import dump_qos_v8

from pegbt import __version__
from pegbt.errors import PegbtError
from pegbt.transport import codec
from pegbt.transport.dvrk_topics import PsmTopics
from pegbt.transport.keys import SimKeys
from pegbt.transport.link import Link
from pegbt.transport.ros2 import Ros2Wire, Topic
from pegbt.transport.sequencing import Received

FLUSH_S = 1.0
# s the recording stays open after it is told to close, while it listens to a wire: what the run's last
# commands set off (a hold, the endpoint's answer to it) is still on its way then, on loopback a few ms
DRAIN_S = 0.25
CHUNK_BYTES = 1 << 20
STRING = "std_msgs/msg/String"
POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
TICKS_TOPIC, EVENTS_TOPIC = "/pegbt/ticks", "/pegbt/events"
# a CRTK key's last part(s) -> its ROS 2 type (README: the simulator's topics)
ROS2_TYPES = {
    "measured_js": "sensor_msgs/msg/JointState",
    "setpoint_js": "sensor_msgs/msg/JointState",
    "fiducial_js": "sensor_msgs/msg/JointState",
    "servo_jp": "sensor_msgs/msg/JointState",
    "move_jp": "sensor_msgs/msg/JointState",
    "measured_cp": "geometry_msgs/msg/PoseStamped",
    "operating_state": "crtk_msgs/msg/OperatingState",
    "error": STRING,
    "follow_jt": "trajectory_msgs/msg/JointTrajectory",
    "state_command": "crtk_msgs/msg/StringStamped",
    "depth/points": POINT_CLOUD2,
    "trigger": "std_msgs/msg/Empty",
}
_STAMP = struct.Struct("<iI")  # a Header's stamp, right after the 4-byte CDR encapsulation
# QoS the dVRK's bridge offers (cisst-ros `cisst_ros_bridge/include/cisst_ros_bridge/mtsROSBridge.h`:
# `AddPublisherFromCommandRead` and `AddPublisherFromEventWrite` keep the last 100, events latched;
# `cisst_ral.h` `create_publisher`: `rclcpp::QoS(queue_size)`, reliable, and `transient_local()` if latched)
QOS_DEPTH = 100
LATCHED = frozenset(topic.name.rsplit("/", 1)[-1] for topic in PsmTopics("PSM1").published() if topic.latched)


@cache
def stamped(kind: str) -> bool:
    """Whether messages of ROS 2 type `kind` open with a `std_msgs/msg/Header` (its stamp first in the CDR):
    joint states and clouds, and also a CRTK `OperatingState` or `StringStamped`."""
    fields = codec.typestore().fielddefs[kind][1]
    return bool(fields) and fields[0][1][1] == "std_msgs/msg/Header"


@cache
def offered_qos(topic: str) -> str:
    """The `offered_qos_profiles` MCAP's ros2 profile requires of a channel, in rosbag2's YAML (by rosbags):
    the dVRK bridge's QoS for every topic, transient local for its events (`operating_state`, `error`, ...)."""
    latched = topic.rsplit("/", 1)[-1] in LATCHED
    unset = QosTime(0, 0)  # deadline, lifespan and lease left to the middleware's defaults
    profile = Qos(
        QosHistory.KEEP_LAST,
        QOS_DEPTH,
        QosReliability.RELIABLE,
        QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
        unset,
        unset,
        QosLiveliness.AUTOMATIC,
        unset,
        False,
    )
    return dump_qos_v8([profile])


def ros2_type(key: str) -> str | None:
    """The ROS 2 type of a CRTK key, None for keys that are not ROS 2 topics."""
    parts = key.split("/")
    return ROS2_TYPES.get("/".join(parts[-2:])) or ROS2_TYPES.get(parts[-1])


class WireRecorder:
    """One MCAP file of a run's traffic; `attach` links, give `tick_record` to the tick log, then `close`.

    Its methods never raise into the client that calls them (a zenoh callback): a write that fails stops
    the recording, and `close` reports it."""

    def __init__(
        self,
        path: str | Path,
        now: Callable[[], float],
        *,
        simulated: bool,
        clock_kind: str,
        cloud_step: int = 10,
    ) -> None:
        """`now` is the run's clock (seconds; `simulated`: since the simulator started, else the Unix epoch)."""
        if cloud_step < 1:
            raise PegbtError(f"the cloud step must be at least 1, got {cloud_step}", field="cloud_step")
        self.path = Path(path)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = self.path.open("wb")
        except OSError as error:
            raise PegbtError(f"cannot write the recording: {error.strerror}", file=self.path) from None
        self._now = now
        self._simulated = simulated
        self._cloud_step = cloud_step
        self._lock = threading.Lock()
        self._writer = Writer(self._file, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._writer.start(profile="ros2", library=f"pegbt {__version__}")
        self._writer.add_metadata(
            "pegbt",
            {
                "clock": clock_kind,
                "log_time": "ns of simulated time since the simulator started"
                if simulated
                else "ns since the Unix epoch (wall clock)",
            },
        )
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._paths: dict[int, str] = {}
        self._subscribers: list[zenoh.Subscriber] = []
        self._listening = False  # taps a wire, so messages may still be on their way at `close`
        self._flushed = time.monotonic()
        self._closed = False
        self._failure: OSError | None = None

    # ------------------------------------------------------------------------------------------ inputs
    def attach(self, link: Link) -> None:
        """Record what `link`'s clients receive and send, and the simulator's events if one is there."""
        link.tap(self.received, self.sent)
        self._listening = True
        events = SimKeys(link.namespace).events
        self._subscribers.append(link.session.declare_subscriber(events, self._event))

    def listen(self, wire: Ros2Wire, topics: Iterable[Topic]) -> None:
        """Record `topics` as they cross `wire` (a CRTK robot's: no `Link` to tap), whoever sends them: the
        robot's states, the executive's commands, its servo streamer's set-points, the camera's clouds."""
        for topic in topics:
            wire.subscriber(topic, partial(self._typed, topic.name, topic.typename))
        self._listening = True

    def received(self, key: str, message: Received[Any]) -> None:
        payload = message.payload
        if not payload:  # a step reply's note: the clock's last full state of `key`, stamped anew
            try:
                state = message.value
            except PegbtError:
                return  # whoever reads it gets the error; the recording goes on
            payload = codec.encode_joint_state(
                state.stamp, state.position, state.velocity, state.effort, state.name
            )
        self._message(key, payload)

    def sent(self, key: str, payload: bytes) -> None:
        self._message(key, payload)

    def tick_record(self, record: dict[str, Any]) -> None:
        """A tick-log record (`TickLogWriter` listener): status changes go to `/pegbt/ticks`."""
        if record["type"] == "header":
            self._paths = {node["id"]: node["path"] for node in record["nodes"]}
            return
        changes = [
            {"node": self._paths.get(node, str(node)), "from": before, "to": after, "feedback": feedback}
            for node, before, after, feedback in record.get("changes", [])
        ]
        if changes or record["type"] != "tick":
            entry = {key: record[key] for key in ("type", "n", "t", "reason", "outcome") if key in record}
            self._string(TICKS_TOPIC, {**entry, "changes": changes}, self._now())

    def event(self, line: str) -> None:
        """A line of the simulator's log (JSON: a world event or a fault, with its `time`) to `/pegbt/events`:
        at its `time` on a simulated clock, where that is the run's clock; on the wall clock (its `time`
        counts from the simulator's start, not the Unix epoch) when it crossed."""
        try:
            entry = json.loads(line)
        except ValueError:
            return
        when = entry.get("time") if isinstance(entry, dict) and self._simulated else None
        self._string(EVENTS_TOPIC, entry, float(when) if isinstance(when, (int, float)) else self._now())

    def _event(self, sample: zenoh.Sample) -> None:
        try:
            self.event(codec.decode_string(sample.payload.to_bytes()))
        except PegbtError:
            return

    # ------------------------------------------------------------------------------------------ writing
    def _message(self, key: str, payload: bytes) -> None:
        kind = ros2_type(key)
        if kind is not None:
            self._typed("/" + key, kind, payload)

    def _typed(self, topic: str, kind: str, payload: bytes) -> None:
        if kind == POINT_CLOUD2 and self._cloud_step > 1:
            try:
                payload = _thinned(payload, self._cloud_step)
            except PegbtError:
                pass  # not a cloud to thin: recorded as it came
        when = self._now()
        if stamped(kind) and len(payload) >= 12:
            sec, nanosec = _STAMP.unpack_from(payload, 4)
            when = sec + nanosec * 1e-9 or when
        self._write(topic, kind, payload, when)

    def _string(self, topic: str, data: Any, when: float) -> None:
        self._write(topic, STRING, codec.encode_string(json.dumps(data, separators=(",", ":"))), when)

    def _write(self, topic: str, kind: str, payload: bytes, when: float) -> None:
        stamp = max(0, round(when * 1e9))
        with self._lock:
            if self._closed:
                return
            channel = self._channels.get(topic)
            if channel is None:
                schema = self._schemas.get(kind)
                if schema is None:
                    text = codec.typestore().generate_msgdef(kind, ros_version=2)[0]
                    schema = self._schemas[kind] = self._writer.register_schema(
                        kind, "ros2msg", text.encode()
                    )
                channel = self._channels[topic] = self._writer.register_channel(
                    topic, "cdr", schema, metadata={"offered_qos_profiles": offered_qos(topic)}
                )
            try:
                self._writer.add_message(channel, log_time=stamp, data=payload, publish_time=stamp)
                if time.monotonic() - self._flushed >= FLUSH_S:
                    self._writer.flush()
                    self._flushed = time.monotonic()
            except OSError as error:  # a full disk stops the recording, never the run: `close` says so
                self._failure, self._closed = error, True

    def close(self) -> None:
        """Finish the file (its summary and index), `DRAIN_S` after what was sent before has come if it
        listens to a wire: a reader can then seek in it."""
        if self._listening:
            time.sleep(DRAIN_S)
        for subscriber in self._subscribers:
            subscriber.undeclare()
        self._subscribers.clear()
        with self._lock:
            if not self._closed:
                self._closed = True
                try:
                    self._writer.finish()
                except OSError as error:
                    self._failure = error
            try:
                self._file.close()
            except OSError as error:  # what was buffered could not be written either
                self._failure = self._failure or error
        if self._failure is not None:
            raise PegbtError(f"the recording stopped: {self._failure.strerror}", file=self.path)


def _thinned(payload: bytes, step: int) -> bytes:
    """A PointCloud2 with every `step`-th point of an unorganised cloud (re-encoded; the rest as received)."""
    message = codec.deserialize(payload, POINT_CLOUD2)
    count = message.width * message.height
    rows = np.asarray(message.data, dtype=np.uint8)[: count * message.point_step].reshape(
        count, message.point_step
    )
    kept = np.ascontiguousarray(rows[::step])
    message.height, message.width = 1, len(kept)
    message.row_step = message.point_step * len(kept)
    message.data = kept.reshape(-1)
    return codec.serialize(message)
