"""pegbt's Zivid client (`pegbt run --interface dvrk --camera zivid`) end to end with the simulator's Zivid over
zenoh on loopback: a capture calls `/capture`, takes the cloud that comes, thins it on its grid to what
perception registers the board on; a capture that fails (refused, nobody serving, no response, no cloud) is an
error naming the service or topic."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import zenoh
from zivid_helpers import ZividSim, zivid_camera

from pegbt.behaviours.actions.placing import board_points
from pegbt.perception.blocks import locate_blocks
from pegbt.perception.board import PegboardRegistration
from pegbt.sim.camera import RED
from pegbt.sim.process import free_port
from pegbt.sim.world import World
from pegbt.transport import codec
from pegbt.transport.ros2 import BridgeWire
from pegbt.transport.ros2_service import ServiceFailed, ServiceRequest
from pegbt.transport.session import client_settings, endpoint_settings, open_session
from pegbt.transport.zivid_camera import CAPTURE, CLOUD_GRACE_S, ZividCamera

CAPTURE_WAIT_S = 60.0


@pytest.fixture
def sim(tmp_path: Path) -> Iterator[ZividSim]:
    running = ZividSim(tmp_path / "sim.jsonl", zivid_camera())
    yield running
    running.close()


@pytest.fixture
def client_wire(sim: ZividSim) -> Iterator[BridgeWire]:
    session = open_session(client_settings([sim.address]))
    wire = BridgeWire(session)
    yield wire
    wire.close()
    session.close()


def test_a_capture_is_the_called_cloud_thinned_and_perception_registers_the_board_on_it(
    sim: ZividSim, client_wire: BridgeWire
) -> None:
    # the simulator casts a frame's 2.3 M rays within a share of each of its control periods, in this process:
    # a capture's wall time grows with the load, which this test does not measure (the perception bench does)
    camera = ZividCamera(client_wire, stride=2, timeout=CAPTURE_WAIT_S)
    time.sleep(0.5)
    asked = time.time()
    capture = camera.capture_async()
    cloud = capture.result(CAPTURE_WAIT_S)
    assert capture.ready and capture.sent and capture.stamp is not None and capture.stamp > asked
    points = cloud.points
    assert np.isfinite(points).all() and points.dtype == np.float32
    assert cloud.grid.shape == (1200, 1944, 3) and len(cloud) == 1944 * 1200  # the whole image, as sent
    assert sim.endpoint.world is not None  # the arms stood still: the world is as the frame saw it
    full, colours = zivid_camera().capture_coloured(sim.endpoint.world)  # every valid pixel of the frame
    assert 0.2 < len(points) / len(full) < 0.3  # every 2nd row and column: a quarter
    assert cloud.rgba is not None and cloud.rgba.shape == (1200, 1944) and not cloud.rgba.flags.owndata
    valid = np.isfinite(cloud.grid).all(axis=-1)
    np.testing.assert_array_equal(cloud.rgba[valid], colours)  # each pixel the colour of what its ray met
    assert (cloud.rgba[~valid] == 0).all()
    board = PegboardRegistration(World(0).cell).fit(cloud)  # read as an array: the thinned points
    assert board.ok, board.reason
    cell = World(0).cell
    kept = board_points(cloud, board, cell, {})  # the look's points: the red ones
    assert len(kept) == np.count_nonzero(colours == RED)
    blocks = [estimate.position[:2] for estimate in locate_blocks(cloud, board) if estimate.ok]
    axes = np.vstack([*blocks, cell.pegs.positions])
    nearest = np.linalg.norm(kept[:, None, :2] - axes[None], axis=2).min(axis=1)
    assert nearest.max() < cell.block.corner_distance + 0.002  # on a block or a peg, none on the bare board
    assert len(blocks) == 6  # every pixel near a block, from the image
    second = camera.capture()  # each capture calls again and gets its own cloud
    assert len(second.points) == pytest.approx(len(points), rel=0.05)


class FakeDriver:
    """A capture service that answers as told (a stand-in for a driver that fails), on a bridge's key."""

    def __init__(self, answer: tuple[bool, str] | None) -> None:
        self.address = f"tcp/127.0.0.1:{free_port()}"
        self.session = open_session(endpoint_settings([self.address]))
        self.answer = answer
        self.requests: list[ServiceRequest] = []
        self.server = BridgeWire(self.session).serve(CAPTURE, self._received)

    def _received(self, request: ServiceRequest) -> None:
        self.requests.append(request)
        if self.answer is not None:
            request.reply(codec.encode_trigger_response(*self.answer))

    def close(self) -> None:
        self.server.close()
        self.session.close()


def _client(address: str, timeout: float, grace: float = CLOUD_GRACE_S) -> tuple[zenoh.Session, ZividCamera]:
    session = open_session(client_settings([address]))
    camera = ZividCamera(BridgeWire(session), timeout=timeout, grace=grace)
    time.sleep(0.5)
    return session, camera


def _failure(camera: ZividCamera, wait: float) -> ServiceFailed:
    capture = camera.capture_async()
    deadline = time.monotonic() + wait
    while not capture.ready and time.monotonic() < deadline:
        time.sleep(0.05)
    with pytest.raises(ServiceFailed) as raised:
        capture.result(0.0)
    return raised.value


def test_a_refused_capture_says_what_the_driver_said() -> None:
    driver = FakeDriver((False, "Unable to capture since the camera is not connected."))
    session, camera = _client(driver.address, timeout=5.0)
    try:
        error = _failure(camera, wait=5.0)
    finally:
        session.close()
        driver.close()
    assert error.field == "/capture" and error.exit_status == 3
    assert "service /capture said: Unable to capture since the camera is not connected." in error.message


def test_a_capture_nobody_serves_fails_at_once_naming_the_service() -> None:
    address = f"tcp/127.0.0.1:{free_port()}"
    listener = open_session(endpoint_settings([address]))  # a bridge with no Zivid behind it
    session, camera = _client(address, timeout=5.0)
    try:
        started = time.monotonic()
        error = _failure(camera, wait=5.0)
        took = time.monotonic() - started
    finally:
        session.close()
        listener.close()
    assert took < 2.0
    assert error.field == "/capture" and "no server answered" in error.message


def test_a_capture_without_a_response_times_out_naming_the_service() -> None:
    driver = FakeDriver(None)  # takes the request and never answers
    session, camera = _client(driver.address, timeout=1.0)
    try:
        capture = camera.capture_async()
        assert not capture.sent
        with pytest.raises(ServiceFailed) as raised:
            capture.result(3.0)
    finally:
        session.close()
        driver.close()
    assert raised.value.field == "/capture" and "no response within 1 s" in raised.value.message
    assert len(driver.requests) == 1


def test_a_response_without_a_cloud_is_an_error_naming_the_topic() -> None:
    driver = FakeDriver((True, ""))  # responds, publishes nothing
    session, camera = _client(driver.address, timeout=5.0)
    try:
        error = _failure(camera, wait=5.0)
    finally:
        session.close()
        driver.close()
    assert error.field == "/points/xyzrgba"
    assert (
        f"service /capture responded, but no cloud came on /points/xyzrgba within {CLOUD_GRACE_S:g} s"
        in error.message
    )


def test_a_cloud_late_after_the_response_is_taken_within_the_runs_allowance() -> None:
    driver = FakeDriver((True, ""))  # responds at once; its cloud comes 3 s later (a stalled machine)
    session, camera = _client(driver.address, timeout=10.0, grace=5.0)
    publisher = BridgeWire(driver.session).publisher(camera.topic)
    cloud = np.full((2, 2, 3), np.nan, dtype=np.float32)
    cloud[0, 0] = (0.01, 0.02, 0.5)
    try:
        capture = camera.capture_async()
        time.sleep(3.0)
        assert capture.sent and not capture.ready  # answered, still waiting: 3 s > 2 s, < 5 s
        publisher.put(codec.encode_organised_cloud(time.time(), cloud, "zivid_optical_frame"))
        points = capture.result(5.0).points
    finally:
        session.close()
        driver.close()
    np.testing.assert_array_equal(points, np.array([[0.01, 0.02, 0.5]], dtype=np.float32))


def test_a_capture_waits_for_a_slow_driver() -> None:
    driver = FakeDriver(None)
    session, camera = _client(driver.address, timeout=5.0)
    publisher = BridgeWire(driver.session).publisher(camera.topic)
    cloud = np.full((4, 6, 3), np.nan, dtype=np.float32)
    cloud[2, 4] = (0.01, 0.02, 0.5)  # on the thinned grid (every 2nd row and column)
    cloud[1, 3] = (0.03, 0.04, 0.5)  # off it

    def answer_later() -> None:
        time.sleep(1.0)
        publisher.put(codec.encode_organised_cloud(time.time(), cloud, "zivid_optical_frame"))
        driver.requests[0].reply(codec.encode_trigger_response(True))

    try:
        capture = camera.capture_async()
        threading.Thread(target=answer_later).start()
        points = capture.result(5.0).points
    finally:
        session.close()
        driver.close()
    np.testing.assert_array_equal(points, np.array([[0.01, 0.02, 0.5]], dtype=np.float32))
