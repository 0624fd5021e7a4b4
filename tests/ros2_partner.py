"""A ROS 2 node written with zenoh-ros2-sdk (ROBOTIS's rmw_zenoh client, not pegbt's code), run as a
separate process by the rmw_zenoh tests: its session is a process-wide singleton configured from the
environment, so each role gets a process of its own.

    python ros2_partner.py MESSAGES_DIR ROUTER_PORT sub TOPIC TYPE COUNT TIMEOUT
    python ros2_partner.py MESSAGES_DIR ROUTER_PORT pub TOPIC TYPE JSON_FIELDS RATE SECONDS
    python ros2_partner.py MESSAGES_DIR ROUTER_PORT info TOPIC...
    python ros2_partner.py MESSAGES_DIR ROUTER_PORT drive ARM DELTA TIMEOUT
    python ros2_partner.py MESSAGES_DIR ROUTER_PORT capture SERVICE CLOUD_TOPIC TIMEOUT
    python ros2_partner.py MESSAGES_DIR ROUTER_PORT serve SERVICE MESSAGE SECONDS

Every result is one JSON line on standard output.
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time
from typing import Any

import numpy as np
from zenoh_ros2_sdk import (
    ROS2Publisher,
    ROS2ServiceClient,
    ROS2ServiceServer,
    ROS2Subscriber,
    get_message_class,
    get_registry,
)
from zenoh_ros2_sdk.discovery import get_topic_info


def _plain(message: Any) -> Any:
    if hasattr(message, "__dataclass_fields__") or hasattr(message, "__slots__"):
        names = getattr(message, "__dataclass_fields__", None) or message.__slots__
        return {name: _plain(getattr(message, name)) for name in names}
    if hasattr(message, "tolist"):
        return message.tolist()
    if isinstance(message, (list, tuple)):
        return [_plain(item) for item in message]
    return message


def _subscribe(port: int, topic: str, typename: str, count: int, timeout: float) -> None:
    got: list[Any] = []
    done = threading.Event()

    def on_message(message: Any) -> None:
        got.append(_plain(message))
        if len(got) >= count:
            done.set()

    subscriber = ROS2Subscriber(topic, typename, on_message, router_port=port, node_name="sdk_listener")
    print(json.dumps({"ready": True}), flush=True)
    done.wait(timeout)
    print(json.dumps({"messages": got[:count]}), flush=True)  # more may come while it prints
    subscriber.close()


def _fields(values: dict[str, Any]) -> dict[str, Any]:
    """Message fields from JSON: a stamped header of now, lists of numbers as float64 arrays."""
    now = time.time()
    header = get_message_class("std_msgs/msg/Header")(
        stamp=get_message_class("builtin_interfaces/msg/Time")(sec=int(now), nanosec=int(now % 1 * 1e9)),
        frame_id="",
    )
    fields: dict[str, Any] = {"header": header}
    for name, value in values.items():
        is_numbers = isinstance(value, list) and all(isinstance(v, (int, float)) for v in value)
        fields[name] = np.asarray(value, dtype=np.float64) if is_numbers else value
    return fields


def _publish(port: int, topic: str, typename: str, fields: str, rate: float, seconds: float) -> None:
    publisher = ROS2Publisher(topic, typename, router_port=port, node_name="sdk_talker")
    values = json.loads(fields)
    print(json.dumps({"ready": True}), flush=True)
    sent = 0
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        publisher.publish(**_fields(values))
        sent += 1
        time.sleep(1.0 / rate)
    print(json.dumps({"sent": sent}), flush=True)
    publisher.close()


def _info(port: int, topics: list[str]) -> None:
    """`ros2 topic info -v` of each topic, asked again until every one is known (tokens take a moment
    to reach a newly joined node) or 10 s pass."""
    deadline = time.monotonic() + 10.0
    while True:
        infos = {
            topic: get_topic_info(topic, router_port=port, timeout=1.0, verbose=True) for topic in topics
        }
        if all(infos.values()) or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    answer = {}
    for topic, info in infos.items():
        answer[topic] = (
            None
            if info is None
            else {
                "types": info.topic_types,
                "publishers": [(e.node_name, e.topic_type, e.type_hash, e.qos) for e in info.publishers],
                "subscribers": [(e.node_name, e.topic_type, e.type_hash, e.qos) for e in info.subscribers],
            }
        )
    print(json.dumps(answer), flush=True)


def _drive(port: int, arm: str, delta: float, timeout: float) -> None:
    """Enable and home `arm` with CRTK `state_command`s, then servo its first joint by `delta`: what a
    ROS 2 operator's node does first; reports the states seen and the joint before and after."""
    states: list[dict[str, Any]] = []
    positions: list[list[float]] = []
    ROS2Subscriber(
        f"/{arm}/operating_state",
        "crtk_msgs/msg/OperatingState",
        lambda m: states.append({"state": m.state, "is_homed": bool(m.is_homed), "is_busy": bool(m.is_busy)}),
        router_port=port,
        node_name="sdk_operator",
    )
    ROS2Subscriber(
        f"/{arm}/measured_js",
        "sensor_msgs/msg/JointState",
        lambda m: positions.append([float(v) for v in m.position]),
        router_port=port,
        node_name="sdk_operator",
    )
    command = ROS2Publisher(f"/{arm}/state_command", "crtk_msgs/msg/StringStamped", router_port=port)
    servo = ROS2Publisher(f"/{arm}/servo_jp", "sensor_msgs/msg/JointState", router_port=port)
    deadline = time.monotonic() + timeout

    def wait(condition: Any) -> bool:
        while time.monotonic() < deadline:
            if condition():
                return True
            time.sleep(0.05)
        return False

    wait(lambda: positions)
    for word, reached in (
        ("enable", lambda: any(s["state"] == "ENABLED" for s in states)),
        ("home", lambda: any(s["state"] == "ENABLED" and s["is_homed"] and not s["is_busy"] for s in states)),
    ):
        # sent again every second until the arm answers: the first may precede the simulator's route
        end = min(deadline, time.monotonic() + 10.0)
        while time.monotonic() < end and not reached():
            command.publish(**_fields({"string": word}))
            pause = time.monotonic() + 1.0
            while time.monotonic() < pause and not reached():
                time.sleep(0.05)
    before = positions[-1] if positions else None
    moved = None
    if before is not None:
        goal = list(before)
        goal[0] += delta
        for _ in range(100):  # 1 s of set-points at 100 Hz, as a teleoperation node streams them
            servo.publish(**_fields({"name": [], "position": goal, "velocity": [], "effort": []}))
            time.sleep(0.01)
        wait(lambda: abs(positions[-1][0] - goal[0]) < 0.2 * abs(delta))
        moved = positions[-1]
    print(json.dumps({"states": states, "before": before, "after": moved}), flush=True)
    os._exit(0)  # the SDK's shared session keeps threads that would hold the interpreter open


def _capture(port: int, service: str, topic: str, timeout: float) -> None:
    """Subscribe to a Zivid's cloud topic, listen 2 s (no cloud comes unasked), call its Trigger service, and
    report the response, the service's type hash as the SDK computes it and the clouds' shapes. The request's
    definition is given: an empty ROS 2 structure holds one placeholder field (rosidl), which the SDK's
    reading of an empty .srv section does not add."""
    clouds: list[dict[str, Any]] = []

    def on_cloud(message: Any) -> None:
        data = np.frombuffer(bytes(message.data), dtype="<f4").reshape(message.height, message.width, -1)
        clouds.append(
            {
                "height": int(message.height),
                "width": int(message.width),
                "point_step": int(message.point_step),
                "frame_id": message.header.frame_id,
                "valid": int(np.isfinite(data[..., 2]).sum()),
                "since_call": time.monotonic() - called[0] if called else None,
            }
        )

    called: list[float] = []
    ROS2Subscriber(
        topic, "sensor_msgs/msg/PointCloud2", on_cloud, router_port=port, node_name="sdk_camera_user"
    )
    client = ROS2ServiceClient(
        service,
        "std_srvs/srv/Trigger",
        request_definition="uint8 structure_needs_at_least_one_member",
        response_definition="bool success\nstring message",
        router_port=port,
        node_name="sdk_camera_user",
        timeout=timeout,
    )
    time.sleep(2.0)
    unasked = len(clouds)
    called.append(time.monotonic())
    response = client.call()
    end = time.monotonic() + 5.0
    while not clouds and time.monotonic() < end:
        time.sleep(0.05)
    answer = None if response is None else {"success": bool(response.success), "message": response.message}
    print(
        json.dumps({"unasked": unasked, "response": answer, "hash": client.type_hash, "clouds": clouds}),
        flush=True,
    )
    os._exit(0)  # the SDK's shared session keeps threads that would hold the interpreter open


def _serve(port: int, service: str, message: str, seconds: float) -> None:
    """Serve a Trigger service that answers `success` false with `message` (a camera that cannot capture),
    for `seconds`; report how many requests came."""
    served: list[int] = []

    def answer(request: Any) -> Any:
        served.append(1)
        return server.response_msg_class(success=False, message=message)

    server = ROS2ServiceServer(
        service,
        "std_srvs/srv/Trigger",
        answer,
        request_definition="uint8 structure_needs_at_least_one_member",
        response_definition="bool success\nstring message",
        router_port=port,
        node_name="sdk_camera",
    )
    print(json.dumps({"ready": True}), flush=True)
    time.sleep(seconds)
    print(json.dumps({"served": len(served)}), flush=True)
    os._exit(0)


def main(argv: list[str]) -> None:
    messages_dir, port, role, *rest = argv
    get_registry(messages_dir)
    if role == "sub":
        _subscribe(int(port), rest[0], rest[1], int(rest[2]), float(rest[3]))
    elif role == "pub":
        _publish(int(port), rest[0], rest[1], rest[2], float(rest[3]), float(rest[4]))
    elif role == "drive":
        _drive(int(port), rest[0], float(rest[1]), float(rest[2]))
    elif role == "capture":
        _capture(int(port), rest[0], rest[1], float(rest[2]))
    elif role == "serve":
        _serve(int(port), rest[0], rest[1], float(rest[2]))
    else:
        _info(int(port), rest)


if __name__ == "__main__":
    main(sys.argv[1:])
