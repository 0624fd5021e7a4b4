"""The Zivid's wire formats, checked against independent producers and readers: rosbags' own typestore for
the organised PointCloud2 and the Trigger messages, zenoh-ros2-sdk for the service's RIHS01 type hash."""

from __future__ import annotations

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from zenoh_ros2_sdk.utils import compute_service_type_hash

from pegbt.transport import codec
from pegbt.transport.rmw_zenoh import dds_type_name, type_hash
from pegbt.transport.ros2_service import bridge_service_key
from pegbt.transport.zivid_camera import CAPTURE, organised_cloud

STORE = get_typestore(Stores.ROS2_HUMBLE)
STORE.register(get_types_from_msg("bool success\nstring message\n", "std_srvs/srv/Trigger_Response"))


def _pcl_cloud(points: np.ndarray, axes: str = "xyz") -> bytes:
    """An organised cloud as PCL's PointXYZ pads it (32 bytes a point, rows padded by 8 bytes), its first three
    words the axes in the order `axes`, serialised by rosbags: another producer's layout than the Zivid's."""
    height, width = points.shape[:2]
    raw = np.zeros((height, width * 8 + 2), dtype="<f4")
    raw[:, : width * 8].reshape(height, width, 8)[..., :3] = points[..., ["xyz".index(a) for a in axes]]
    field = STORE.types["sensor_msgs/msg/PointField"]
    time = STORE.types["builtin_interfaces/msg/Time"](sec=12, nanosec=500_000_000)
    message = STORE.types["sensor_msgs/msg/PointCloud2"](
        header=STORE.types["std_msgs/msg/Header"](stamp=time, frame_id="camera"),
        height=height,
        width=width,
        fields=[field(name=a, offset=4 * i, datatype=7, count=1) for i, a in enumerate(axes)],
        is_bigendian=False,
        point_step=32,
        row_step=raw.shape[1] * 4,
        data=raw.view(np.uint8).reshape(-1),
        is_dense=False,
    )
    return bytes(STORE.serialize_cdr(message, "sensor_msgs/msg/PointCloud2"))


def test_an_organised_cloud_reads_as_rosbags_reads_it() -> None:
    rng = np.random.default_rng(0)
    points = rng.uniform(-1, 1, (6, 9, 3)).astype(np.float32)
    points[2, 3] = np.nan
    rgba = np.full((6, 9), 0xFF102030, dtype=np.uint32)
    message = STORE.deserialize_cdr(
        codec.encode_organised_cloud(5.25, points, "zivid_optical_frame", rgba), "sensor_msgs/msg/PointCloud2"
    )
    raw = np.asarray(message.data, dtype=np.uint8).reshape(6, 9, 16)
    np.testing.assert_array_equal(raw[..., :12].copy().view("<f4"), points)
    assert (raw[..., 12:].copy().view("<u4")[..., 0] == 0xFF102030).all()
    assert (message.header.stamp.sec, message.header.stamp.nanosec) == (5, 250_000_000)
    assert [(f.name, f.offset, f.datatype) for f in message.fields][-1] == ("rgba", 12, 6)


def test_another_producers_organised_cloud_is_thinned_on_its_grid() -> None:
    points = np.arange(5 * 7 * 3, dtype=np.float32).reshape(5, 7, 3)
    points[0, 0] = np.nan
    stamp, grid = codec.decode_organised_cloud(_pcl_cloud(points), stride=2)
    assert stamp == 12.5
    np.testing.assert_array_equal(grid, points[::2, ::2])
    _, reordered = codec.decode_organised_cloud(_pcl_cloud(points, axes="zxy"), stride=2)
    np.testing.assert_array_equal(reordered, points[::2, ::2])
    cloud = organised_cloud(_pcl_cloud(points), stride=3)
    np.testing.assert_array_equal(cloud.grid, points)  # the whole image, for block search
    assert len(cloud) == 5 * 7
    thinned = cloud.points
    np.testing.assert_array_equal(thinned, points[::3, ::3].reshape(-1, 3)[1:])  # the NaN pixel dropped
    assert np.asarray(cloud) is thinned and np.asarray(cloud, dtype=np.float64).dtype == np.float64
    np.array(cloud)[0] = -1.0  # a copy asked for is one
    assert thinned[0, 0] != -1.0


def test_a_clouds_colours_are_a_view_of_the_message_beside_its_image() -> None:
    """zivid-ros's points/xyzrgba (`makePointCloud2Msg`): a UINT32 rgba at offset 12 of each 16-byte point,
    read as the (H, W) words of the image's pixels without a copy; a cloud without colour has none."""
    points = np.arange(4 * 5 * 3, dtype=np.float32).reshape(4, 5, 3)
    points[1, 2] = np.nan
    rgba = (0xFF000000 + np.arange(20, dtype=np.uint32) * 0x010203).reshape(4, 5)
    rgba[1, 2] = 0
    payload = codec.encode_organised_cloud(1.5, points, "zivid_optical_frame", rgba)
    cloud = organised_cloud(payload)
    assert cloud.rgba is not None and cloud.rgba.dtype == np.uint32
    np.testing.assert_array_equal(cloud.rgba, rgba)
    np.testing.assert_array_equal(cloud.grid, points)
    assert np.shares_memory(cloud.rgba, np.frombuffer(payload, dtype=np.uint8))  # not copied out
    assert organised_cloud(codec.encode_organised_cloud(1.5, points, "zivid_optical_frame")).rgba is None


def test_the_trigger_messages_and_the_services_keys() -> None:
    assert codec.encode_trigger_request() == b"\x00\x01\x00\x00\x00"  # CDR header, the placeholder uint8
    response = STORE.types["std_srvs/srv/msg/Trigger_Response"](success=False, message="not connected")
    theirs = bytes(STORE.serialize_cdr(response, "std_srvs/srv/msg/Trigger_Response"))
    assert codec.decode_trigger_response(theirs) == (False, "not connected")
    assert codec.encode_trigger_response(False, "not connected") == theirs
    sdk = compute_service_type_hash(
        "std_srvs/srv/Trigger", "uint8 structure_needs_at_least_one_member", "bool success\nstring message"
    )
    assert type_hash(codec.TRIGGER) == sdk
    assert dds_type_name(codec.TRIGGER) == "std_srvs::srv::dds_::Trigger_"
    assert (
        bridge_service_key("lab", CAPTURE) == "lab/capture" and bridge_service_key("", CAPTURE) == "capture"
    )
