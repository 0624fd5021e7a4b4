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
from dvrk_peer import DvrkPeer, Received, empty, joint_state, state_command, wait_for

from pegbt.cli import main
from pegbt.sim.dvrk_endpoint import DvrkEndpoint, DvrkEndpointConfig, OverrunWatch
from pegbt.sim.log import SimLog
from pegbt.sim.process import free_port
from pegbt.transport.dvrk_topics import PsmTopics
from pegbt.transport.ros2 import BridgeWire
from pegbt.transport.session import endpoint_settings, open_session

OPERATING_STATE = "crtk_msgs/msg/OperatingState"
JOINT_STATE = "sensor_msgs/msg/JointState"
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
