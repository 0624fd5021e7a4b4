"""The bridge wire carries a topic as zenoh-bridge-ros2dds does: plain CDR bytes, no attachment, and a
latched topic served to a subscriber that joins after it was published (route_publisher.rs)."""

from __future__ import annotations

import threading
import time

import pytest
import zenoh

from pegbt.sim.process import free_port
from pegbt.transport.ros2 import BridgeWire, Topic
from pegbt.transport.session import client_settings, endpoint_settings, open_session


def _wait_for(condition, timeout: float = 20.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.01)
    return condition()


def test_a_latched_topic_reaches_a_subscriber_that_joins_later_and_a_plain_one_does_not() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with (
        open_session(endpoint_settings([endpoint])) as robot,
        open_session(client_settings([endpoint])) as client,
    ):
        latched = Topic("/PSM1/operating_state", "crtk_msgs/msg/OperatingState", latched=True)
        plain = Topic("/PSM1/warning", "std_msgs/msg/String")
        robot_wire, client_wire = BridgeWire(robot, "lab"), BridgeWire(client, "lab")
        state, warning = robot_wire.publisher(latched), robot_wire.publisher(plain)
        time.sleep(0.2)
        state.put(b"ENABLED")
        warning.put(b"arm not ready")
        time.sleep(0.3)

        raw: list[zenoh.Sample] = []
        tap = client.declare_subscriber("lab/PSM1/**", raw.append)
        got_state: list[bytes] = []
        got_warning: list[bytes] = []
        client_wire.subscriber(latched, got_state.append)
        client_wire.subscriber(plain, got_warning.append)
        assert _wait_for(lambda: got_state == [b"ENABLED"])
        assert got_warning == []

        state.put(b"FAULT")
        assert _wait_for(lambda: got_state == [b"ENABLED", b"FAULT"])
        assert _wait_for(lambda: any(s.payload.to_bytes() == b"FAULT" for s in raw))
        assert {str(s.key_expr) for s in raw} == {"lab/PSM1/operating_state"}
        assert all(s.attachment is None for s in raw)
        tap.undeclare()


def test_a_command_blocks_under_congestion_and_a_set_point_stream_drops() -> None:
    """Every dVRK command topic pegbt publishes blocks rather than be lost (zenoh-plugin-ros2dds routes a
    RELIABLE writer with BLOCK, `route_publisher.rs`); the servo streams drop, as rmw_zenoh's KEEP_LAST
    publishers do (`rmw_publisher_data.cpp`): the next set-point replaces a late one."""
    from pegbt.transport.dvrk_topics import PsmTopics
    from pegbt.transport.ros2 import declare_publisher

    topics = PsmTopics("PSM1")
    with open_session(endpoint_settings([f"tcp/127.0.0.1:{free_port()}"])) as session:
        for topic, congestion in [
            (topics.hold, zenoh.CongestionControl.BLOCK),
            (topics.move_jp, zenoh.CongestionControl.BLOCK),
            (topics.jaw_move_jp, zenoh.CongestionControl.BLOCK),
            (topics.state_command, zenoh.CongestionControl.BLOCK),
            (topics.servo_jp, zenoh.CongestionControl.DROP),
            (topics.jaw_servo_jp, zenoh.CongestionControl.DROP),
        ]:
            publisher = declare_publisher(session, topic.name.lstrip("/"), topic)
            assert publisher.congestion_control == congestion, topic.name
            publisher.undeclare()


def test_a_slow_reader_gets_a_camera_streams_newest_cloud_and_a_command_topics_every_message() -> None:
    """A reader that takes longer than the stream's period: the point-cloud subscriber keeps the newest
    message only (KEEP_LAST 1, rmw_zenoh_cpp `rmw_subscription_data.cpp`), so what it reads next is the
    latest and its lag does not grow; a topic without `keep_last` still delivers every message in order."""
    from pegbt.transport.dvrk_topics import PsmTopics, point_cloud_topic

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with (
        open_session(endpoint_settings([endpoint])) as camera,
        open_session(client_settings([endpoint])) as client,
    ):
        camera_wire, client_wire = BridgeWire(camera), BridgeWire(client)
        # a command topic's publisher blocks rather than drop: whatever does not arrive is the subscriber's
        clouds, commands = point_cloud_topic(), PsmTopics("PSM1").move_jp
        cloud_out, command_out = camera_wire.publisher(clouds), camera_wire.publisher(commands)
        got_clouds: list[bytes] = []
        got_commands: list[bytes] = []

        released = threading.Event()

        def slow(payload: bytes) -> None:  # busy with the first cloud until all are sent, however loaded
            got_clouds.append(payload)
            released.wait(10.0)

        # a camera stream's publisher may drop under load: the newest cloud is the newest that reached us
        arrived: list[zenoh.Sample] = []
        tap = client.declare_subscriber(client_wire.key(clouds), arrived.append)
        client_wire.subscriber(clouds, slow)
        client_wire.subscriber(commands, got_commands.append)
        assert _wait_for(lambda: cloud_out.matched and command_out.matched)
        sent = [str(i).encode() for i in range(60)]
        for payload in sent:
            cloud_out.put(payload)
            command_out.put(payload)
            time.sleep(0.002)
        assert _wait_for(lambda: got_commands == sent)
        released.set()
        newest = arrived[-1].payload.to_bytes()
        assert _wait_for(lambda: got_clouds[-1:] == [newest])
        time.sleep(0.2)
        assert len(got_clouds) < len(sent) / 2, got_clouds  # the stale ones were dropped, not queued
        assert got_clouds == sorted(got_clouds, key=int)  # and what came is in order
        tap.undeclare()
        client_wire.close()
        camera_wire.close()


def test_a_camera_streams_reader_that_raises_gets_the_next_cloud(caplog: pytest.LogCaptureFixture) -> None:
    """As zenoh does for a callback: one reading that fails is reported, and the stream goes on."""
    from pegbt.transport.dvrk_topics import point_cloud_topic

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with (
        open_session(endpoint_settings([endpoint])) as camera,
        open_session(client_settings([endpoint])) as client,
    ):
        camera_wire, client_wire = BridgeWire(camera), BridgeWire(client)
        cloud_out = camera_wire.publisher(point_cloud_topic())
        got: list[bytes] = []

        def fails_once(payload: bytes) -> None:
            got.append(payload)
            if len(got) == 1:
                raise ValueError("an unreadable cloud")

        client_wire.subscriber(point_cloud_topic(), fails_once)
        assert _wait_for(lambda: cloud_out.matched)
        cloud_out.put(b"first")
        assert _wait_for(lambda: got == [b"first"])
        cloud_out.put(b"second")
        assert _wait_for(lambda: got == [b"first", b"second"])
        assert "the reader of a sample failed" in caplog.text
        client_wire.close()
        camera_wire.close()
