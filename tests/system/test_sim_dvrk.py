"""`pegbt sim --interface dvrk` behaves, over real zenoh on loopback, as a dVRK 2.x PSM behind
zenoh-bridge-ros2dds does: checked one behaviour at a time by an independent peer (raw zenoh, rosbags'
typestore; `tests/dvrk_peer.py`), against the figures of the dVRK's own sources (`pegbt/sim/dvrk_config.py`
cites them)."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from dvrk_peer import STORE, DvrkPeer, Message, Received, empty, joint_state, state_command, wait_for
from numpy.typing import NDArray

from pegbt.cli import main
from pegbt.sim import dvrk_config as dvrk
from pegbt.sim.dvrk_endpoint import DvrkEndpoint, DvrkEndpointConfig, OverrunWatch
from pegbt.sim.log import SimLog
from pegbt.sim.process import SimProcess, free_port
from pegbt.transport.dvrk_topics import PsmTopics
from pegbt.transport.ros2 import BridgeWire
from pegbt.transport.session import endpoint_settings, open_session

OPERATING_STATE = "crtk_msgs/msg/OperatingState"
JOINT_STATE = "sensor_msgs/msg/JointState"
POINT_CLOUD = "sensor_msgs/msg/PointCloud2"
STRING = "std_msgs/msg/String"


class Running:
    """A `DvrkEndpoint` serving on a free loopback port from its own thread, logging to `log_path`."""

    def __init__(self, log_path: Path, world: object = None, camera: object = None, **config: object) -> None:
        self.address = f"tcp/127.0.0.1:{free_port()}"
        self.log_path = log_path
        self.session = open_session(endpoint_settings([self.address]))
        settings = DvrkEndpointConfig(log_path=log_path, **config)  # type: ignore[arg-type]
        self.endpoint = DvrkEndpoint(BridgeWire(self.session), settings, world=world, camera=camera)  # type: ignore[arg-type]
        self.thread = threading.Thread(target=self.endpoint.run, name="dvrk-sim", daemon=True)
        self.thread.start()

    def log(self, kind: str) -> list[dict]:
        lines = self.log_path.read_text().splitlines()
        return [entry for entry in map(json.loads, lines) if entry["kind"] == kind]

    def close(self) -> None:
        self.endpoint.stop()
        self.thread.join(timeout=10)
        self.endpoint.close()
        self.session.close()


@pytest.fixture
def sim(tmp_path: Path) -> Iterator[Running]:
    running = Running(tmp_path / "sim.jsonl")
    yield running
    running.close()


@pytest.fixture
def peer(sim: Running) -> Iterator[DvrkPeer]:
    client = DvrkPeer(sim.address)
    yield client
    client.close()


def _state(received: Received) -> object | None:
    decoded = received.decoded(OPERATING_STATE)
    return decoded[-1] if decoded else None


def _texts(received: Received) -> list[str]:
    return [message.data for message in received.decoded(STRING)]


def _last_position(received: Received) -> np.ndarray | None:
    decoded = received.decoded(JOINT_STATE)
    return np.asarray(decoded[-1].position) if decoded else None


def _homed(peer: DvrkPeer, arm: str = "PSM1") -> Received:
    """Enable and home `arm`; its operating state, as a latched subscriber sees it."""
    states = peer.subscribe_latched(f"{arm}/operating_state")
    assert wait_for(lambda: _state(states) is not None)
    peer.put(f"{arm}/state_command", state_command("enable"))
    peer.put(f"{arm}/state_command", state_command("home"))
    assert wait_for(lambda: (s := _state(states)) and s.is_homed and not s.is_busy, timeout=20)
    return states


def test_no_attachment_and_no_key_beyond_the_dvrk_topics(sim: Running, peer: DvrkPeer) -> None:
    tap = peer.subscribe("**")
    assert wait_for(lambda: len(tap.all()) > 50)
    peer.put("PSM1/servo_jp", joint_state([0.1, 0, 0.12, 0, 0, 0]))  # to a disabled arm: a warning
    peer.put("PSM2/state_command", state_command("enable"))  # status messages, a new operating state
    peer.put("PSM2/hold", empty())
    assert wait_for(lambda: {"PSM1/warning", "PSM2/status"} <= {str(s.key_expr) for s in tap.all()})
    time.sleep(0.3)
    allowed = {
        topic.name.lstrip("/")
        for arm in ("PSM1", "PSM2")
        for topic in (*PsmTopics(arm).published(), *PsmTopics(arm).subscribed())
    }
    samples = tap.all()
    keys = {str(sample.key_expr) for sample in samples}
    assert keys <= allowed, keys - allowed
    assert {"PSM1/measured_js", "PSM1/setpoint_cp", "PSM2/jaw/measured_js", "PSM2/operating_state"} <= keys
    assert all(sample.attachment is None for sample in samples)


def test_a_late_joiner_gets_the_latched_operating_state(sim: Running, peer: DvrkPeer) -> None:
    # the state is published at start, before the first joint states, and not again until it changes
    measured = peer.subscribe("PSM1/measured_js")
    assert wait_for(lambda: measured.all())
    plain = peer.subscribe("PSM1/operating_state")
    latched = peer.subscribe_latched("PSM1/operating_state")
    state = wait_for(lambda: _state(latched))
    assert (state.state, state.is_homed, state.is_busy) == ("DISABLED", False, False)
    time.sleep(0.3)
    assert plain.all() == []


def test_a_command_to_a_disabled_arm_is_warned_once_and_not_applied(sim: Running, peer: DvrkPeer) -> None:
    warnings = peer.subscribe("PSM1/warning")
    setpoints = peer.subscribe("PSM1/setpoint_js")
    assert wait_for(lambda: _last_position(setpoints) is not None)
    for _ in range(3):
        peer.put("PSM1/servo_jp", joint_state([0.3, 0.0, 0.12, 0.0, 0.0, 0.0]))
    assert wait_for(lambda: _texts(warnings)) == ["PSM1: servo_jp, arm not ready"]
    time.sleep(0.5)
    assert _texts(warnings) == ["PSM1: servo_jp, arm not ready"]  # throttled: one per 2 s
    assert _last_position(setpoints)[0] == pytest.approx(0.0)
    dropped = [e for e in sim.log("safety") if e["event"] == "not_ready"]
    assert dropped and dropped[0]["arm"] == "PSM1" and dropped[0]["state"] == "DISABLED"


@pytest.mark.slow
def test_enable_then_home_takes_seconds_then_the_arm_is_homed(sim: Running, peer: DvrkPeer) -> None:
    states = peer.subscribe_latched("PSM1/operating_state")
    status = peer.subscribe("PSM1/status")
    assert wait_for(lambda: _state(states) is not None)
    peer.put("PSM1/state_command", state_command("enable"))
    assert wait_for(lambda: (s := _state(states)) and s.state == "ENABLED" and not s.is_busy)
    assert not _state(states).is_homed
    asked = time.monotonic()
    peer.put("PSM1/state_command", state_command("home"))
    assert wait_for(lambda: _state(states).is_homed, timeout=20)
    assert time.monotonic() - asked >= dvrk.ENCODER_BIAS_TIME  # encoders biased from the pots first
    seen = [(s.state, s.is_homed, s.is_busy) for s in states.decoded(OPERATING_STATE)]
    assert ("ENABLED", False, True) in seen  # busy while homing
    assert seen[-1] == ("ENABLED", True, False)
    assert wait_for(lambda: "PSM1: current state HOMED" in _texts(status))


@pytest.mark.slow
def test_an_out_of_limit_command_is_clipped_to_the_dvrk_limit_and_logged(
    sim: Running, peer: DvrkPeer
) -> None:
    states = _homed(peer)
    setpoints = peer.subscribe("PSM1/setpoint_js")
    # insertion 0.3 m: beyond the dVRK's 0.24 m (share/kinematic/PSM.json)
    peer.put("PSM1/move_jp", joint_state([0.0, 0.0, 0.30, 0.0, 0.0, 0.0]))
    assert wait_for(lambda: _state(states).is_busy)
    assert wait_for(lambda: not _state(states).is_busy, timeout=15)
    # the set-point the move ended on (a loaded machine may deliver the last messages late)
    assert wait_for(lambda: _last_position(setpoints)[2] == pytest.approx(0.24))
    (clip,) = [e for e in sim.log("safety") if e["event"] == "clip"]
    assert (clip["arm"], clip["command"], clip["joints"]) == ("PSM1", "move_jp", ["insertion"])
    assert clip["requested"][2] == 0.30 and clip["clipped"][2] == pytest.approx(0.24)


@pytest.mark.slow
def test_a_move_is_busy_then_not_reaching_its_goal(sim: Running, peer: DvrkPeer) -> None:
    states = _homed(peer)
    measured = peer.subscribe("PSM1/measured_js")
    goal = [0.5, -0.2, 0.15, 0.3, 0.2, -0.1]
    sent = time.monotonic()
    peer.put("PSM1/move_jp", joint_state(goal))
    assert wait_for(lambda: _state(states).is_busy)
    assert wait_for(lambda: not _state(states).is_busy, timeout=15)
    # yaw 0.5 rad at 90 deg/s and 90 deg/s^2 (mtsIntuitiveResearchKitPSM.cpp) needs 2 sqrt(0.5 / (pi/2)) s
    assert time.monotonic() - sent >= 2 * np.sqrt(0.5 / (np.pi / 2)) - 0.05
    assert wait_for(lambda: np.allclose(_last_position(measured), goal, atol=1e-3))
    assert not [e for e in sim.log("safety") if e["event"] == "clip"]


@pytest.mark.slow
def test_hold_stops_a_move_where_it_is(sim: Running, peer: DvrkPeer) -> None:
    states = _homed(peer)
    setpoints = peer.subscribe("PSM1/setpoint_js")
    # a 1.8 s move (yaw 1.3 rad at 90 deg/s and 90 deg/s^2), held early: a loaded machine may deliver the
    # hold late, yet well before the move would have ended
    peer.put("PSM1/move_jp", joint_state([1.3, 0.0, 0.12, 0.0, 0.0, 0.0]))
    assert wait_for(lambda: (q := _last_position(setpoints)) is not None and q[0] > 0.05)
    seen = _last_position(setpoints)[0]
    peer.put("PSM1/hold", empty())
    assert wait_for(lambda: not _state(states).is_busy)
    time.sleep(0.3)
    held = _last_position(setpoints)[0]
    time.sleep(0.3)
    assert seen <= held < 1.25  # where it was when the hold came, short of the goal
    assert _last_position(setpoints)[0] == pytest.approx(held)


@pytest.mark.slow
def test_a_jump_beyond_the_tracking_tolerance_faults_the_arm_until_it_is_enabled_again(
    sim: Running, peer: DvrkPeer
) -> None:
    states = _homed(peer)
    errors = peer.subscribe("PSM1/error")
    warnings = peer.subscribe("PSM1/warning")
    setpoints = peer.subscribe("PSM1/setpoint_js")
    measured = peer.subscribe("PSM1/measured_js")
    time.sleep(0.2)
    for yaw in (0.8, 0.0) * 4:  # each a jump of 0.8 rad > 0.5
        peer.put("PSM1/servo_jp", joint_state([yaw, 0.0, 0.12, 0.0, 0.0, 0.0]))
        # a simulator that ran late at that moment excuses tracking for 0.1 s (a loaded machine): jump again
        if wait_for(lambda: _state(states).state == "FAULT", timeout=5) or not sim.log("tracking_excused"):
            break
    assert wait_for(lambda: _state(states).state == "FAULT")  # a loaded machine may say so late
    assert wait_for(lambda: any("tracking error" in text for text in _texts(errors)))
    (fault,) = [e for e in sim.log("safety") if e["event"] == "tracking_error"]
    assert abs(fault["actuator_errors"][0]) > dvrk.ACTUATOR_TOLERANCE[0]  # the jump that faulted: up or back

    peer.put("PSM1/servo_jp", joint_state([0.05, 0.0, 0.12, 0.0, 0.0, 0.0]))
    peer.put("PSM1/state_command", state_command("enable"))  # not from FAULT (prmOperatingState.cpp)
    assert wait_for(lambda: len(_texts(warnings)) >= 2)
    assert sorted(_texts(warnings)) == [  # zenoh, as DDS, orders messages per topic, not across topics
        'PSM1: command "enable" is not supported in state "FAULT" (FAULT)',
        "PSM1: servo_jp, arm not ready",
    ]
    # in FAULT the PID is off: the set-point is where the arm is measured, not the refused servo_jp's 0.05
    held = lambda: abs(_last_position(setpoints)[0] - _last_position(measured)[0]) < 1e-3  # noqa: E731
    assert wait_for(held) and abs(_last_position(setpoints)[0] - 0.05) > 1e-3

    peer.put("PSM1/state_command", state_command("disable"))
    assert wait_for(lambda: _state(states).state == "DISABLED")
    status = peer.subscribe("PSM1/status")
    time.sleep(0.2)
    peer.put("PSM1/state_command", state_command("home"))
    # ENABLED, homed and idle is also what the arm says once powered, before it homes (Arm.cpp
    # `EnterEnabled`): ready is the HOMED state reached, and that state published
    homed = lambda: "PSM1: current state HOMED" in _texts(status)  # noqa: E731
    ready = lambda: (s := _state(states)) and s.state == "ENABLED" and s.is_homed and not s.is_busy  # noqa: E731
    assert wait_for(homed, timeout=20) and wait_for(ready)
    start = _last_position(setpoints)[0]
    peer.put("PSM1/servo_jp", joint_state([start + 0.05, 0.0, 0.12, 0.0, 0.0, 0.0]))
    assert wait_for(lambda: _last_position(setpoints)[0] == pytest.approx(start + 0.05))


def _stamps(samples: list[Message], message_type: str) -> NDArray[np.float64]:
    messages = [STORE.deserialize_cdr(sample.payload, message_type) for sample in samples]
    return np.array([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in messages])


def _last_two_one_period_apart(received: Received, message_type: str, period: float) -> bool:
    """The last two messages stamped exactly `period` apart: the stream's cadence when nothing was late."""
    last = received.all()[-2:]
    return len(last) == 2 and abs(float(np.diff(_stamps(last, message_type))[0]) - period) < 1e-5


@pytest.mark.slow
def test_the_simulator_process_streams_clouds_and_states_at_the_rates_asked(tmp_path: Path) -> None:
    """The cadence is read from the stamps the simulator put on its messages, which a busy machine cannot
    shorten; how many of them a starved subscriber receives (a 2 MB cloud is dropped, not queued, when the
    receiver falls behind, as a bridge does with sensor data) only bounds the rate from above."""
    from pegbt.sim.camera import DepthCamera

    topic = "/rs/camera/depth/color/points"
    log = tmp_path / "sim.jsonl"
    args = ["--camera-topic", topic, "--camera-rate", "5", "--state-rate", "50", "--log", str(log)]
    with SimProcess(args, interface="dvrk") as sim:
        client = DvrkPeer(sim.endpoint)
        try:
            tap = client.subscribe("**")
            clouds = client.subscribe(topic.lstrip("/"))
            states = client.subscribe("PSM2/fiducial_js")  # stamped; the arm's joints are 0 until homed
            assert wait_for(lambda: clouds.all() and states.all(), timeout=20)
            first, clouds_before, states_before = time.monotonic(), len(clouds.all()), len(states.all())
            time.sleep(3.0)
            seconds = time.monotonic() - first
            cloud_rate = (len(clouds.all()) - clouds_before) / seconds
            state_rate = (len(states.all()) - states_before) / seconds
            assert wait_for(lambda: _last_two_one_period_apart(clouds, POINT_CLOUD, 0.2), timeout=20)
            samples = tap.all()
            assert 0 < cloud_rate <= 1.1 * 5 and 0 < state_rate <= 1.1 * 50, (cloud_rate, state_rate)
            # never more often than asked
            assert np.diff(_stamps(clouds.all(), POINT_CLOUD)).min() > 0.2 - 0.005
            gaps = np.diff(_stamps(states.all(), JOINT_STATE))
            # every 20 ms of the 10 ms clock
            assert gaps.min() > 0.02 - 1e-6 and np.any(np.abs(gaps - 0.02) < 1e-6)
            cloud = STORE.deserialize_cdr(clouds.all()[-1].payload, POINT_CLOUD)
            assert [(f.name, f.offset, f.datatype) for f in cloud.fields] == [
                ("x", 0, 7),
                ("y", 4, 7),
                ("z", 8, 7),
                ("rgba", 12, 6),  # zivid-ros's layout of a colour
            ]
            # organised: the camera's pixels, by row
            assert (cloud.height, cloud.width) == DepthCamera().image_shape
            words = np.frombuffer(bytes(cloud.data), dtype="<f4").reshape(cloud.height, cloud.width, 4)
            xyz, rgba = words[..., :3], words[..., 3].view("<u4")
            seen = np.isfinite(xyz).all(axis=2)
            assert not cloud.is_dense and 0.5 < seen.mean() < 1.0  # pixels that see nothing are NaN
            # and have no colour; the others, what their ray met
            np.testing.assert_array_equal(rgba != 0, seen)
            assert np.all(xyz[seen][:, 2] > 0.1)  # in front of the camera, metres
            allowed = {topic.lstrip("/")} | {
                t.name.lstrip("/") for arm in ("PSM1", "PSM2") for t in PsmTopics(arm).published()
            }
            assert {str(sample.key_expr) for sample in samples} <= allowed
            assert all(sample.attachment is None for sample in samples)
            start = json.loads(log.read_text().splitlines()[0])
            assert (start["kind"], start["interface"], start["camera_period"]) == ("start", "dvrk", 0.2)
        finally:
            client.close()


class _CountingCamera:
    """A depth camera that counts the frames the simulator exposes (each one costs a ray cast)."""

    def __init__(self) -> None:
        from pegbt.sim.camera import DepthCamera

        self.camera = DepthCamera(seed=0)
        self.image_shape = self.camera.image_shape
        self.exposed = 0

    def expose(self, world: object, elapsed: float) -> object:
        self.exposed += 1
        return self.camera.expose(world, elapsed)  # type: ignore[arg-type]


def test_no_frame_is_rendered_while_nobody_listens_and_one_comes_when_someone_does(tmp_path: Path) -> None:
    """Rendering is the simulator's cost, not the camera's: a frame nobody would receive is not exposed,
    and a subscriber that joins gets frames at the rate asked."""
    from pegbt.sim.world import World

    camera = _CountingCamera()
    running = Running(tmp_path / "sim.jsonl", world=World(0), camera=camera, camera_period=0.2)
    client = DvrkPeer(running.address)
    try:
        states = client.subscribe("PSM1/measured_js")
        assert wait_for(lambda: len(states.all()) > 20, timeout=20)
        time.sleep(1.0)
        assert camera.exposed == 0
        clouds = client.subscribe(running.endpoint.config.camera_topic.lstrip("/"))
        assert wait_for(lambda: len(clouds.all()) >= 3, timeout=20)
    finally:
        client.close()
        running.close()
    stamps = _stamps(clouds.all(), POINT_CLOUD)
    assert np.diff(stamps).min() > 0.2 - 0.005 and camera.exposed >= 3


def test_lockstep_is_refused_with_the_dvrk_interface(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "--interface", "dvrk", "--lockstep", "--no-world"]) == 2
    err = capsys.readouterr().err
    assert "real time only" in err and "--lockstep" in err and "Traceback" not in err


def test_late_control_periods_are_logged_once_per_run_of_them(tmp_path: Path) -> None:
    log = SimLog(tmp_path / "sim.jsonl")
    watch = OverrunWatch(0.01, log)
    due = 100.0
    for now in (
        100.001,
        100.025,
        100.032,
        100.035,
        100.3,
        100.301,
    ):  # on time, 2 late, on time, far behind, ...
        due = watch.check(now, due, due - 100.0) + 0.01
    log.close()
    entries = [json.loads(line) for line in (tmp_path / "sim.jsonl").read_text().splitlines()]
    assert [(e["kind"], e["time"], e["periods"], e["skipped"]) for e in entries] == [
        ("overrun", 0.01, 2, 0),
        ("overrun", 0.04, 1, 25),
    ]
    assert entries[0]["worst_late"] == pytest.approx(0.015)
