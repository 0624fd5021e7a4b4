"""An independent client of `pegbt sim --interface dvrk` for tests: raw zenoh sessions and rosbags' own
typestore (crtk_msgs registered from collaborative-robotics/crtk_msgs' `.msg` text), no pegbt client code,
reading the keys as zenoh-bridge-ros2dds makes them (the topic without its leading slash)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import zenoh
import zenoh.ext
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from pegbt.transport.session import client_settings, open_session

# collaborative-robotics/crtk_msgs msg/OperatingState.msg and msg/StringStamped.msg
CRTK = {
    "crtk_msgs/msg/OperatingState": "std_msgs/Header header\nstring state\nbool is_homed\nbool is_busy\n",
    "crtk_msgs/msg/StringStamped": "std_msgs/Header header\nstring string\n",
}
STORE = get_typestore(Stores.ROS2_HUMBLE)
for _name, _text in CRTK.items():
    STORE.register(get_types_from_msg(_text, _name))


def wait_for(condition: Callable[[], Any], timeout: float = 10.0) -> Any:
    """`condition()` once it is truthy, polling; its last value after `timeout` s (generous: loaded machine)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.01)
    return condition()


@dataclass(frozen=True)
class Message:
    """What a sample carried, copied on arrival: a zenoh sample's payload may lie in buffers its session
    reuses or frees, so one read after `close()` can hold other bytes."""

    key_expr: str
    payload: bytes
    attachment: bytes | None

    @classmethod
    def of(cls, sample: zenoh.Sample) -> Message:
        attachment = sample.attachment
        return cls(
            str(sample.key_expr),
            sample.payload.to_bytes(),
            None if attachment is None else attachment.to_bytes(),
        )


class Received:
    """Messages of one key expression, kept with their arrival time."""

    def __init__(self) -> None:
        self.samples: list[tuple[float, Message]] = []
        self._lock = threading.Lock()

    def __call__(self, sample: zenoh.Sample) -> None:
        message = Message.of(sample)
        with self._lock:
            self.samples.append((time.monotonic(), message))

    def all(self) -> list[Message]:
        with self._lock:
            return [message for _, message in self.samples]

    def decoded(self, typename: str) -> list[Any]:
        return [STORE.deserialize_cdr(m.payload, typename) for m in self.all()]


class DvrkPeer:
    """A zenoh peer connected to the simulator, speaking CDR as a ROS 2 node behind the bridge would."""

    def __init__(self, endpoint: str) -> None:
        self.session = open_session(client_settings([endpoint]))
        self._held: list[Any] = []

    def subscribe(self, key: str) -> Received:
        received = Received()
        self._held.append(self.session.declare_subscriber(key, received))
        return received

    def subscribe_latched(self, key: str, depth: int = 100) -> Received:
        """As the bridge reads a TRANSIENT_LOCAL topic: an advanced subscriber asking the cache's history."""
        received = Received()
        history = zenoh.ext.HistoryConfig(detect_late_publishers=True, max_samples=depth)
        self._held.append(zenoh.ext.declare_advanced_subscriber(self.session, key, received, history=history))
        return received

    def put(self, key: str, message: Any) -> None:
        """A command, as the bridge routes a RELIABLE writer: it waits out a congested link rather than be
        dropped (a put's default), which a loaded machine's burst of commands would otherwise lose."""
        payload = bytes(STORE.serialize_cdr(message, message.__msgtype__))
        self.session.put(key, payload, congestion_control=zenoh.CongestionControl.BLOCK)

    def close(self) -> None:
        for entity in self._held:
            entity.undeclare()
        self.session.close()


def _header() -> Any:
    now = time.time()
    stamp = STORE.types["builtin_interfaces/msg/Time"](sec=int(now), nanosec=int((now % 1) * 1e9))
    return STORE.types["std_msgs/msg/Header"](stamp=stamp, frame_id="")


def joint_state(positions: list[float]) -> Any:
    empty = np.zeros(0)
    return STORE.types["sensor_msgs/msg/JointState"](
        header=_header(), name=[], position=np.asarray(positions, dtype=float), velocity=empty, effort=empty
    )


def state_command(command: str) -> Any:
    return STORE.types["crtk_msgs/msg/StringStamped"](header=_header(), string=command)


def empty() -> Any:
    return STORE.types["std_msgs/msg/Empty"]()
