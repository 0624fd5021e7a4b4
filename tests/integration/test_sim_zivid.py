"""`pegbt sim --interface dvrk --camera zivid` serves the camera as zivid-ros's `zivid_camera` node behind
zenoh-bridge-ros2dds does, checked by an independent peer (raw zenoh queries and subscribers, rosbags' own
typestore): a cloud only when `/capture` is called, organised at full resolution with NaN for the pixels that
see nothing, 16 bytes a point, and nothing on a topic nobody subscribes to."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import zenoh
from dvrk_peer import STORE, Received, wait_for
from zivid_helpers import CountingWire, ZividSim, call_capture, zivid_camera

from pegbt.sim.camera import BOARD_GREY, RED, TOOL_GREY, DepthCamera
from pegbt.transport.session import client_settings, open_session

POINT_CLOUD = "sensor_msgs/msg/PointCloud2"


@pytest.fixture(scope="module")
def camera() -> DepthCamera:
    return zivid_camera()


@pytest.fixture
def sim(tmp_path: Path, camera: DepthCamera) -> Iterator[ZividSim]:
    running = ZividSim(tmp_path / "sim.jsonl", camera)
    yield running
    running.close()


@pytest.fixture
def peer(sim: ZividSim) -> Iterator[zenoh.Session]:
    session = open_session(client_settings([sim.address]))
    yield session
    session.close()


def _organised(message: object) -> np.ndarray:
    """The (height, width, 3) x, y, z of a PointCloud2 with 16-byte points, read by its fields."""
    offsets = {field.name: field.offset for field in message.fields}  # type: ignore[attr-defined]
    shape = (message.height, message.width, message.point_step)  # type: ignore[attr-defined]
    raw = np.asarray(message.data, dtype=np.uint8).reshape(shape)  # type: ignore[attr-defined]
    return np.stack(
        [raw[..., offsets[a] : offsets[a] + 4].copy().view("<f4")[..., 0] for a in "xyz"], axis=-1
    )


def test_a_call_publishes_one_organised_full_resolution_cloud_with_nans(
    sim: ZividSim, peer: zenoh.Session
) -> None:
    clouds = Received()
    subscriber = peer.declare_subscriber("points/xyzrgba", clouds)
    time.sleep(0.5)  # the subscriber is matched before the call
    asked = time.time()
    responses = call_capture(peer)
    assert [(r.success, r.message) for r in responses] == [(True, "")]
    assert wait_for(lambda: clouds.all(), timeout=5.0), "the cloud is published before the response"
    time.sleep(0.5)
    (message,) = [STORE.deserialize_cdr(s.payload, POINT_CLOUD) for s in clouds.all()]
    subscriber.undeclare()
    assert (message.height, message.width) == (1200, 1944)  # Zivid 2: 2.3 M points
    assert message.point_step == 16 and message.row_step == 16 * 1944 and not message.is_dense
    assert [(f.name, f.offset, f.datatype) for f in message.fields] == [
        ("x", 0, 7),
        ("y", 4, 7),
        ("z", 8, 7),
        ("rgba", 12, 6),
    ]
    assert message.header.frame_id == "zivid_optical_frame"
    assert message.header.stamp.sec + message.header.stamp.nanosec * 1e-9 > asked
    points = _organised(message)
    valid = np.isfinite(points).all(axis=-1)
    assert 50_000 < valid.sum() < valid.size / 2  # the board and blocks, and around them nothing (NaN)
    assert np.isnan(points[~valid]).all()  # an invalid pixel is NaN in x, y and z
    assert np.all((points[valid][:, 2] > 0.3) & (points[valid][:, 2] < 0.8))  # metres, in front of the camera
    raw = np.asarray(message.data, dtype=np.uint8).reshape(1200, 1944, 16)
    rgba = raw[..., 12:].copy().view("<u4")[..., 0]  # a pixel's colour: what its ray met, none if nothing
    assert (rgba[~valid] == 0).all() and set(np.unique(rgba[valid])) == {RED, BOARD_GREY, TOOL_GREY}
    assert 15_000 < np.count_nonzero(rgba == RED) < valid.sum() / 2  # the blocks and the pegs
    assert np.count_nonzero(rgba == TOOL_GREY) > 1_000  # the tools at their start, at the image's edge


def test_no_cloud_without_a_call(sim: ZividSim, peer: zenoh.Session) -> None:
    """Nothing in 3 s (a camera that streamed would render and send a frame in less), then one cloud on each
    topic for the call: counted where it is sent, which is done before the call is answered."""
    assert isinstance(sim.wire, CountingWire)
    clouds, plain = Received(), Received()
    peer.declare_subscriber("points/xyzrgba", clouds)
    peer.declare_subscriber("points/xyz", plain)
    time.sleep(3.0)
    assert clouds.all() == [] and plain.all() == []
    assert (sim.wire.sent["/points/xyzrgba"], sim.wire.sent["/points/xyz"]) == (0, 0)
    responses = call_capture(peer)
    assert [r.success for r in responses] == [True]
    assert (sim.wire.sent["/points/xyzrgba"], sim.wire.sent["/points/xyz"]) == (1, 1)
    assert wait_for(lambda: clouds.all() and plain.all(), timeout=5.0)
    assert (len(clouds.all()), len(plain.all())) == (1, 1)  # one capture, one cloud on each


def test_nothing_is_published_on_a_topic_nobody_subscribes_to(sim: ZividSim, peer: zenoh.Session) -> None:
    assert isinstance(sim.wire, CountingWire)
    responses = call_capture(peer)  # nobody subscribes: the capture succeeds, nothing is sent
    assert [r.success for r in responses] == [True]
    assert sim.wire.sent == {"/points/xyzrgba": 0, "/points/xyz": 0} | {
        name: count for name, count in sim.wire.sent.items() if not name.startswith("/points/")
    }
    plain = Received()
    peer.declare_subscriber("points/xyz", plain)
    time.sleep(0.5)
    assert [r.success for r in call_capture(peer)] == [True]
    assert wait_for(lambda: plain.all(), timeout=5.0)
    assert (sim.wire.sent["/points/xyzrgba"], sim.wire.sent["/points/xyz"]) == (0, 1)
    (message,) = [STORE.deserialize_cdr(s.payload, POINT_CLOUD) for s in plain.all()]
    assert [f.name for f in message.fields] == ["x", "y", "z"] and message.point_step == 16  # XYZW, padded


def test_the_sim_command_refuses_a_zivid_on_pegbts_interface(pegbt_cli: object, tmp_path: Path) -> None:
    result = pegbt_cli("sim", "--camera", "zivid", "--no-world", cwd=tmp_path)  # type: ignore[operator]
    assert result.returncode == 2
    assert "--camera zivid is a ROS 2 camera driver's: add --interface dvrk" in result.stderr
