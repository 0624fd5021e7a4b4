"""A world and a camera plugged into the endpoint through its protocols (test-only fakes; the real
pegboard world and depth camera plug in the same way)."""

from __future__ import annotations

import json
import threading
import time as wall

import numpy as np
import pytest

from pegbt.motion.kinematics import forward_kinematics
from pegbt.sim.endpoint import EndpointConfig, SimEndpoint
from pegbt.sim.fault_plan import FaultPlan, ScheduledFault
from pegbt.sim.plugins import ToolState
from pegbt.sim.process import free_port
from pegbt.transport import ArmClient, CameraClient, SimClock, codec, connect, endpoint_settings, open_session
from pegbt.transport.keys import SimKeys

BOARD_FROM_BASE = np.array([[-1.0, 0, 0, 0.19], [0, 1, 0, -0.03], [0, 0, -1, -0.17], [0, 0, 0, 1]])


class FakeWorld:
    """Records what it is given; reports a 'contact' event whenever the PSM1 jaw is closed past 0.3 rad."""

    def __init__(self) -> None:
        self.updates: list[tuple[float, dict[str, ToolState]]] = []
        self.faults: list[tuple[str, dict, float]] = []

    def board_from_base(self, arm: str) -> np.ndarray:
        return BOARD_FROM_BASE

    def update(self, time: float, tools):
        self.updates.append((time, dict(tools)))
        return [{"kind": "contact", "arm": "PSM1"}] if tools["PSM1"].jaw > 0.3 else []

    def inject_fault(self, kind: str, params, time: float) -> None:
        self.faults.append((kind, dict(params), time))


class FakeCamera:
    def __init__(self) -> None:
        self.cloud = np.random.default_rng(1).normal(size=(100, 3)).astype(np.float32)

    def capture(self, time: float) -> np.ndarray:
        return self.cloud + np.float32(time)


@pytest.fixture()
def plugged():
    world, camera = FakeWorld(), FakeCamera()
    endpoint_address = f"tcp/127.0.0.1:{free_port()}"
    session = open_session(endpoint_settings([endpoint_address]))
    plan = FaultPlan(scheduled=(ScheduledFault(0.05, "world", "slip", {"arm": "PSM1"}),))
    endpoint = SimEndpoint(session, EndpointConfig(lockstep=True, physics="dvrk-real", faults=plan), world=world, camera=camera)
    thread = threading.Thread(target=endpoint.run, daemon=True)
    thread.start()
    link = connect([endpoint_address])
    yield endpoint, world, camera, link
    link.close()
    endpoint.stop()
    thread.join(timeout=5)
    endpoint.close()
    session.close()


def test_world_sees_tools_from_physical_joints_and_its_events_are_logged_and_published(plugged):
    endpoint, world, _, link = plugged
    events = []
    link.session.declare_subscriber(SimKeys().events, lambda sample: events.append(json.loads(codec.decode_string(sample.payload.to_bytes()))))
    clock = SimClock(link)
    psm1 = ArmClient(link, "PSM1", clock=clock)
    psm1.wait_until_ready()
    grip = psm1.jaw.move_jp(0.5)
    while grip.busy:
        clock.wait(0.01)
    clock.wait(0.02)

    time, tools = world.updates[-1]
    assert time == pytest.approx(clock.now())
    physical = psm1.fiducial_js.position
    assert not np.allclose(physical, psm1.measured_js.position, atol=0.01)  # dvrk-real: they differ
    assert np.allclose(tools["PSM1"].tip, BOARD_FROM_BASE @ forward_kinematics(physical), atol=1e-9)
    assert tools["PSM1"].jaw == pytest.approx(psm1.jaw.measured_js.position[0], abs=1e-12)
    assert np.allclose(tools["PSM1"].shaft[0], BOARD_FROM_BASE[:3, 3])  # the shaft starts at the RCM

    assert world.faults == [("slip", {"arm": "PSM1"}, pytest.approx(0.05))]
    kinds = [entry["kind"] for entry in endpoint.log.entries]
    assert "contact" in kinds and {"kind": "fault", "fault": "slip"}.items() <= next(
        e for e in endpoint.log.entries if e.get("fault") == "slip"
    ).items()
    deadline = wall.monotonic() + 2.0
    while not any(event["kind"] == "contact" for event in events) and wall.monotonic() < deadline:
        wall.sleep(0.01)
    assert any(event["kind"] == "contact" for event in events)


def test_camera_capture_returns_the_cloud_taken_at_the_request(plugged):
    _, _, camera, link = plugged
    clock = SimClock(link)
    clock.wait(0.1)
    cameras = CameraClient(link, clock=clock)
    handle = cameras.capture_async()
    points = handle.result(timeout=5.0)
    assert handle.stamp == pytest.approx(clock.now())
    assert np.array_equal(points, camera.capture(clock.now()))
