"""`--record FILE.mcap` read back by the `mcap` library's readers and `mcap-ros2-support`'s decoder, which
know nothing of pegbt: topics, ROS 2 types, CDR payloads, log times, and a file cut short by a crash."""

from __future__ import annotations

import dataclasses
import io
import json
import struct
import time

import numpy as np
import pytest
import zenoh
from bag_helpers import read_all

from pegbt.clock import ManualClock
from pegbt.transport import codec, recorder
from pegbt.transport.recorder import WireRecorder
from pegbt.transport.sequencing import Received

mcap_reader = pytest.importorskip("mcap.reader")
from mcap.exceptions import McapError
from mcap.records import Message
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory

JOINT_STATE = "sensor_msgs/msg/JointState"


def test_a_file_cut_short_reads_up_to_the_cut(tmp_path, monkeypatch):
    monkeypatch.setattr(recorder, "FLUSH_S", 0.0)  # a chunk per message: what a long run does every second
    clock = ManualClock()
    path = tmp_path / "cut.mcap"
    wire = WireRecorder(path, clock.now, simulated=False, clock_kind="manual", cloud_step=1)
    for i in range(40):
        clock.advance(0.01)
        wire.sent("PSM1/servo_jp", codec.encode_joint_state(clock.now(), np.full(6, i * 0.01)))
    data = path.read_bytes()  # the process dies here: no summary, no footer
    cut = data[: len(data) * 6 // 10]  # and a chunk was half written
    decoder = DecoderFactory()
    positions = []
    stream = StreamReader(io.BytesIO(cut))
    schema = None
    try:
        for record in stream.records:
            if isinstance(record, Message):
                decoded = decoder.decoder_for("cdr", schema)(record.data)
                positions.append(decoded.position[0])
            elif type(record).__name__ == "Schema":
                schema = record
    except (McapError, EOFError, struct.error):
        pass  # the stream ends at the cut
    assert 15 <= len(positions) < 40
    np.testing.assert_allclose(positions, np.arange(len(positions)) * 0.01)
    wire.close()
    assert len(read_all(path)) == 40  # closed properly, the seeking reader finds all of them


def test_a_step_replys_restamp_note_records_the_last_state_with_its_new_stamp(tmp_path):
    clock = ManualClock()
    path = tmp_path / "notes.mcap"
    wire = WireRecorder(path, clock.now, simulated=False, clock_kind="manual")
    base = codec.encode_joint_state(
        1.25, [0.1, 0.2, 0.1, 0.3, 0.4, 0.5], names=("a", "b", "c", "d", "e", "f")
    )
    wire.received("PSM1/measured_js", Received(base, codec.decode_joint_state, None, 0.0))
    # as SimClock delivers a note: its last full state of the key, with the note's stamp
    again = Received(b"", lambda _: dataclasses.replace(codec.decode_joint_state(base), stamp=2.5), None, 0.0)
    wire.received("PSM1/measured_js", again)
    wire.received("sim/clock", Received(b"{}", json.loads, None, 0.0))  # not a ROS 2 topic: left out
    wire.tick_record({"type": "header", "nodes": [{"id": 0, "path": "/root"}]})
    wire.tick_record({"type": "tick", "n": 1, "t": 0.0, "changes": [[0, "INVALID", "RUNNING", ""]]})
    wire.close()
    messages = read_all(path)
    states = [decoded for topic, _, _, decoded in messages if topic == "/PSM1/measured_js"]
    assert [(s.header.stamp.sec, s.header.stamp.nanosec) for s in states] == [
        (1, 250_000_000),
        (2, 500_000_000),
    ]
    assert list(states[1].position) == [0.1, 0.2, 0.1, 0.3, 0.4, 0.5] and list(states[1].name) == list(
        "abcdef"
    )
    ticks = [json.loads(decoded.data) for topic, _, _, decoded in messages if topic == "/pegbt/ticks"]
    assert ticks == [
        {
            "type": "tick",
            "n": 1,
            "t": 0.0,
            "changes": [{"node": "/root", "from": "INVALID", "to": "RUNNING", "feedback": ""}],
        }
    ]
    assert {topic for topic, _, _, _ in messages} == {"/PSM1/measured_js", "/pegbt/ticks"}


def test_every_message_with_a_header_is_logged_at_its_stamp(tmp_path):
    """A lockstep reply bundles states the simulator stamped ahead of the client's clock: an arm that stops
    being busy at 26.0 s must not show so at 24.44 s, where the clock was when the reply came."""
    clock = ManualClock()
    clock.advance(24.44)
    path = tmp_path / "stamps.mcap"
    wire = WireRecorder(path, clock.now, simulated=True, clock_kind="manual")
    state = codec.encode_operating_state(codec.OperatingState(26.0, "ENABLED", True, False))
    wire.received("PSM1/operating_state", Received(state, codec.decode_operating_state, None, 0.0))
    wire.received("PSM1/measured_js", Received(codec.encode_joint_state(26.0, np.zeros(6)), None, None, 0.0))
    wire.sent("PSM1/state_command", codec.encode_string_stamped(25.5, "enable"))
    wire.sent("PSM1/jaw/move_jp", codec.encode_joint_state(0.0, np.zeros(1)))  # no stamp: the clock's time
    wire.close()
    messages = read_all(path)
    assert {topic for topic, _, _, _ in messages} == {
        "/PSM1/operating_state",
        "/PSM1/measured_js",
        "/PSM1/state_command",
        "/PSM1/jaw/move_jp",
    }
    for topic, _, log_time, decoded in messages:
        stamp = decoded.header.stamp.sec * 10**9 + decoded.header.stamp.nanosec
        assert log_time == (stamp or 24_440_000_000), topic


def test_every_channel_offers_the_qos_of_the_dvrks_bridge_as_the_ros2_profile_requires(tmp_path):
    """MCAP's ros2 profile requires `offered_qos_profiles` on every channel (foxglove/mcap
    `docs/specification/profiles/ros2.md`); rosbags' rosbag2 reader takes the profiles from it, and a
    player republishes the dVRK's latched operating_state to late joiners only if it says so."""
    from rosbags.interfaces import QosDurability, QosReliability
    from rosbags.rosbag2 import Reader

    clock = ManualClock()
    path = tmp_path / "qos.mcap"
    wire = WireRecorder(path, clock.now, simulated=False, clock_kind="manual")
    state = codec.encode_operating_state(codec.OperatingState(1.0, "ENABLED", True, False))
    wire.received("PSM1/operating_state", Received(state, codec.decode_operating_state, None, 0.0))
    wire.received("PSM1/measured_js", Received(codec.encode_joint_state(1.0, np.zeros(6)), None, None, 0.0))
    wire.tick_record({"type": "header", "nodes": [{"id": 0, "path": "/root"}]})
    wire.tick_record({"type": "tick", "n": 1, "t": 0.0, "changes": [[0, "INVALID", "RUNNING", ""]]})
    wire.close()
    with path.open("rb") as stream:
        channels = mcap_reader.make_reader(stream).get_summary().channels.values()
        assert all("offered_qos_profiles" in channel.metadata for channel in channels)
    reader = Reader(path)
    reader.open()
    try:
        offered = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
    finally:
        reader.close()
    assert set(offered) == {"/PSM1/operating_state", "/PSM1/measured_js", "/pegbt/ticks"}
    durability = {topic: [qos.durability for qos in profiles] for topic, profiles in offered.items()}
    assert durability == {
        "/PSM1/operating_state": [QosDurability.TRANSIENT_LOCAL],
        "/PSM1/measured_js": [QosDurability.VOLATILE],
        "/pegbt/ticks": [QosDurability.VOLATILE],
    }
    assert all(qos.reliability == QosReliability.RELIABLE and qos.depth == 100 for [qos] in offered.values())


@pytest.mark.parametrize("simulated", [True, False])
def test_a_simulator_event_is_logged_on_the_recordings_clock(tmp_path, simulated):
    """The simulator's log times count from its start: the run's clock in lockstep, not on the wall clock
    (`pegbt sim --record` in real time, `pegbt run --clock wall`), whose log times are since the Unix epoch."""
    clock = ManualClock()
    clock.advance(3.5 if simulated else 1.8e9)
    path = tmp_path / "events.mcap"
    wire = WireRecorder(path, clock.now, simulated=simulated, clock_kind="manual")
    wire.event(json.dumps({"time": 3.25, "kind": "slip", "arm": "PSM1"}))
    wire.sent("PSM1/servo_jp", codec.encode_joint_state(clock.now(), np.zeros(6)))
    wire.close()
    times = {topic: log_time for topic, _, log_time, _ in read_all(path)}
    assert times["/pegbt/events"] == (3_250_000_000 if simulated else times["/PSM1/servo_jp"])


def test_a_failing_disk_stops_the_recording_not_the_run(monkeypatch):
    from pegbt.errors import PegbtError

    monkeypatch.setattr(recorder, "FLUSH_S", 0.0)
    clock = ManualClock()
    wire = WireRecorder("/dev/full", clock.now, simulated=False, clock_kind="manual")
    for i in range(3):  # each write fails underneath; none raises into the caller
        wire.sent("PSM1/servo_jp", codec.encode_joint_state(float(i), np.zeros(6)))
    with pytest.raises(PegbtError, match="the recording stopped: No space left on device"):
        wire.close()


def test_what_was_sent_before_the_recording_closes_is_in_it(tmp_path, monkeypatch):
    """A burst a robot publishes just before the run ends (its answer to the last hold) reaches the file,
    though it is still crossing the wire when the recording is told to close (with no drain, the last
    of these 300 never do; the drain is lengthened here for a loaded machine)."""
    monkeypatch.setattr(recorder, "DRAIN_S", 1.0)
    from pegbt.sim.process import free_port
    from pegbt.transport.ros2 import BridgeWire, Topic
    from pegbt.transport.session import client_settings, endpoint_settings, open_session

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    topic = Topic("/PSM1/measured_js", JOINT_STATE)
    path = tmp_path / "tail.mcap"
    with (
        open_session(endpoint_settings([endpoint])) as robot,
        open_session(client_settings([endpoint])) as client,
    ):
        wire = WireRecorder(path, ManualClock().now, simulated=False, clock_kind="manual")
        wire.listen(BridgeWire(client, "lab"), [topic])
        publisher = robot.declare_publisher(
            "lab/PSM1/measured_js", congestion_control=zenoh.CongestionControl.BLOCK
        )
        time.sleep(0.5)  # the subscriber's declaration reaches the robot
        payloads = [codec.encode_joint_state(1.0 + k, [0.01 * k] * 6) for k in range(300)]
        for payload in payloads:
            publisher.put(payload)
        wire.close()
    stamps = [log_time for topic_name, _, log_time, _ in read_all(path) if topic_name == topic.name]
    assert stamps == [round((1.0 + k) * 1e9) for k in range(300)]
