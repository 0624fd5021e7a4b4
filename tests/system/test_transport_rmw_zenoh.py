"""pegbt as a node of a ROS 2 graph on rmw_zenoh, tested against zenoh-ros2-sdk (ROBOTIS's rmw_zenoh
client): it receives what pegbt publishes, pegbt receives what it publishes, and its discovery lists
pegbt's publishers and subscribers. A zenoh session in router mode on 127.0.0.1 stands in for
rmw_zenohd; every session stays on loopback."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator

import numpy as np
import pytest
from rmw_zenoh_helpers import await_ready, lines, partner
from zenoh_ros2_sdk.qos import QosHistoryKind, QosProfile

from pegbt.transport.codec import JOINT_STATE, OPERATING_STATE, decode_joint_state, encode_joint_state
from pegbt.transport.rmw_zenoh import RmwZenohWire, type_hash
from pegbt.transport.ros2 import Topic
from pegbt.transport.session import open_session, ros2_graph_settings

MEASURED = Topic("/PSM1/measured_js", JOINT_STATE)


@pytest.fixture
def pegbt_node(router: int) -> Iterator[RmwZenohWire]:
    with open_session(ros2_graph_settings([f"tcp/127.0.0.1:{router}"])) as session:
        wire = RmwZenohWire(session, node_name="pegbt_test")
        yield wire
        wire.close()


@pytest.mark.slow
def test_a_ros2_subscriber_receives_what_pegbt_publishes(messages_dir, router, pegbt_node) -> None:
    listener = partner(messages_dir, router, "sub", "/PSM1/measured_js", JOINT_STATE, "3", "20")
    await_ready(listener)
    publisher = pegbt_node.publisher(MEASURED)
    q = np.array([0.1, -0.2, 0.15, 0.3, -0.4, 0.5])
    deadline = time.monotonic() + 20
    while listener.poll() is None and time.monotonic() < deadline:
        publisher.put(encode_joint_state(time.time(), q))
        time.sleep(0.05)
    messages = lines(listener)[-1]["messages"]
    assert len(messages) >= 3
    assert np.allclose(messages[0]["position"], q)


@pytest.mark.slow
def test_pegbt_receives_a_ros2_publisher_and_drops_samples_without_the_attachment(
    messages_dir, router, pegbt_node
) -> None:
    got: list[bytes] = []
    pegbt_node.subscriber(MEASURED, got.append)
    talker = partner(
        messages_dir,
        router,
        "pub",
        "/PSM1/measured_js",
        JOINT_STATE,
        json.dumps({"name": [], "position": [0.5] * 6, "velocity": [], "effort": []}),
        "20",
        "3",
    )
    lines(talker)
    assert got, "nothing reached pegbt's subscriber"
    assert np.allclose(decode_joint_state(got[-1]).position, [0.5] * 6)
    with open_session(ros2_graph_settings([f"tcp/127.0.0.1:{router}"])) as stranger:
        deadline = time.monotonic() + 10.0  # a new session's first puts may precede its routes
        while pegbt_node.dropped == 0 and time.monotonic() < deadline:
            stranger.put(pegbt_node.key(MEASURED), encode_joint_state(0.0, np.zeros(6)))
            time.sleep(0.05)
    assert pegbt_node.dropped >= 1
    assert all(np.allclose(decode_joint_state(p).position, 0.5) for p in got)


@pytest.mark.slow
def test_ros2_discovery_lists_pegbt_publishers_and_subscribers_with_their_types(
    messages_dir, router, pegbt_node
) -> None:
    pegbt_node.publisher(MEASURED)
    pegbt_node.publisher(Topic("/PSM1/operating_state", OPERATING_STATE, latched=True))
    pegbt_node.subscriber(Topic("/PSM1/servo_jp", JOINT_STATE), lambda payload: None)
    move = Topic("/PSM1/move_jp", JOINT_STATE, command=True)
    pegbt_node.publisher(move)
    pegbt_node.subscriber(move, lambda payload: None)
    time.sleep(0.3)
    topics = ("/PSM1/measured_js", "/PSM1/operating_state", "/PSM1/servo_jp", "/PSM1/move_jp")
    info = lines(partner(messages_dir, router, "info", *topics))[-1]
    measured, state, servo = info["/PSM1/measured_js"], info["/PSM1/operating_state"], info["/PSM1/servo_jp"]
    commands = info["/PSM1/move_jp"]
    # a command's publisher says the history it acts on (it blocks, as rmw_zenoh does for KEEP_ALL); a
    # stream's says KEEP_LAST, as does every subscriber
    assert QosProfile.decode(commands["publishers"][0][3]).history_kind is QosHistoryKind.KEEP_ALL
    assert QosProfile.decode(commands["subscribers"][0][3]).history_kind is QosHistoryKind.KEEP_LAST
    assert QosProfile.decode(measured["publishers"][0][3]).history_kind is QosHistoryKind.KEEP_LAST
    assert measured["types"] == [JOINT_STATE] and servo["types"] == [JOINT_STATE]
    assert state["types"] == [OPERATING_STATE]
    assert [p[0] for p in measured["publishers"]] == ["pegbt_test"]
    assert [s[0] for s in servo["subscribers"]] == ["pegbt_test"]
    assert measured["publishers"][0][2] == type_hash(JOINT_STATE)
    assert state["publishers"][0][3].split(":")[1] == "1"  # TRANSIENT_LOCAL
