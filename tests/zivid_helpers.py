"""The simulator's dVRK interface with its Zivid camera, served in-process on loopback for tests, and what an
independent peer needs to call its capture service: raw zenoh queries and rosbags' own typestore (std_srvs'
Trigger from ros2/common_interfaces `std_srvs/srv/Trigger.srv`), no pegbt client code."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import zenoh
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from pegbt.sim.camera import DepthCamera
from pegbt.sim.dvrk_endpoint import DvrkEndpoint, DvrkEndpointConfig
from pegbt.sim.process import free_port
from pegbt.sim.world import World
from pegbt.sim.zivid import zivid2_model
from pegbt.transport.ros2 import BridgeWire, Ros2Wire, Topic, TopicPublisher
from pegbt.transport.session import endpoint_settings, open_session

STORE = get_typestore(Stores.ROS2_HUMBLE)
STORE.register(get_types_from_msg("bool success\nstring message\n", "std_srvs/srv/Trigger_Response"))
TRIGGER_RESPONSE = "std_srvs/srv/msg/Trigger_Response"  # rosbags' name for a type read from .srv text
TRIGGER_REQUEST_CDR = b"\x00\x01\x00\x00\x00"  # little-endian CDR header, the placeholder uint8 0


def zivid_camera(seed: int = 0) -> DepthCamera:
    """The simulator's Zivid 2: every pixel of its 1944 × 1200 image."""
    model = zivid2_model(World(seed).cell.camera)
    return DepthCamera(seed=seed, model=model, full_frame=True)


class CountingWire(BridgeWire):
    """The bridge's wire, counting what each publisher sends (to see what is sent to topics nobody reads)."""

    def __init__(self, session: zenoh.Session) -> None:
        super().__init__(session)
        self.sent: dict[str, int] = {}

    def publisher(self, topic: Topic) -> TopicPublisher:
        publisher = super().publisher(topic)
        self.sent[topic.name] = 0
        wire = self

        class Counted:
            @property
            def matched(self) -> bool:
                return publisher.matched

            def put(self, payload: bytes) -> None:
                wire.sent[topic.name] += 1
                publisher.put(payload)

            def close(self) -> None:
                publisher.close()

        return Counted()


class ZividSim:
    """A `DvrkEndpoint` with the Zivid camera (`--camera zivid`) on a free loopback port, from its own thread."""

    def __init__(
        self, log_path: Path, camera: DepthCamera, wire_kind: type[BridgeWire] = CountingWire
    ) -> None:
        self.address = f"tcp/127.0.0.1:{free_port()}"
        self.log_path = log_path
        self.session = open_session(endpoint_settings([self.address]))
        self.wire: Ros2Wire = wire_kind(self.session)
        config = DvrkEndpointConfig(log_path=log_path, camera="zivid")
        self.endpoint = DvrkEndpoint(self.wire, config, world=World(0), camera=camera)
        self.thread = threading.Thread(target=self.endpoint.run, name="dvrk-sim", daemon=True)
        self.thread.start()

    def close(self) -> None:
        self.endpoint.stop()
        self.thread.join(timeout=20)
        self.endpoint.close()
        self.session.close()


def call_capture(session: zenoh.Session, key: str = "capture", timeout: float = 20.0) -> list[Any]:
    """Call the capture service as a zenoh query through a bridge would come: the decoded responses."""
    replies = session.get(key, payload=TRIGGER_REQUEST_CDR, timeout=timeout)
    return [
        STORE.deserialize_cdr(reply.ok.payload.to_bytes(), TRIGGER_RESPONSE)
        for reply in replies
        if reply.ok is not None
    ]
