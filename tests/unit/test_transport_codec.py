"""CDR payloads against rosbags' own serialisation, session defaults, key names, and command guards."""

from __future__ import annotations

import json

import numpy as np
import pytest
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from pegbt.errors import PegbtError
from pegbt.motion.limits import arm_settings
from pegbt.transport import codec, guards
from pegbt.transport.keys import ArmKeys, CameraKeys
from pegbt.transport.sequencing import Tag
from pegbt.transport.session import DEFAULT_ENDPOINT, SessionSettings, client_settings, endpoint_settings

# An independent typestore, as a ROS 2 node (or the bridge) would have it.
REFERENCE = get_typestore(Stores.ROS2_HUMBLE)
REFERENCE.register(
    get_types_from_msg(
        "std_msgs/Header header\nstring state\nbool is_homed\nbool is_busy\n", "crtk_msgs/msg/OperatingState"
    )
)
T = REFERENCE.types


def header(sec: int, nanosec: int, frame: str = "") -> object:
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame
    )


def reference_bytes(message: object) -> bytes:
    return bytes(REFERENCE.serialize_cdr(message, message.__msgtype__))


def test_joint_state_round_trips_byte_for_byte():
    q = np.array([0.1, -0.2, 0.15, 0.3, -0.4, 0.5])
    direct = reference_bytes(
        T["sensor_msgs/msg/JointState"](
            header=header(12, 500_000_000),
            name=["a", "b", "c", "d", "e", "f"],
            position=q,
            velocity=-q,
            effort=np.zeros(0),
        )
    )
    sample = codec.decode_joint_state(direct)
    assert sample.stamp == pytest.approx(12.5) and np.array_equal(sample.position, q)
    ours = codec.encode_joint_state(
        sample.stamp, sample.position, sample.velocity, sample.effort, sample.name
    )
    assert ours == direct


def test_operating_state_from_msg_text_matches_rosbags():
    direct = reference_bytes(
        T["crtk_msgs/msg/OperatingState"](header=header(3, 250), state="ENABLED", is_homed=True, is_busy=True)
    )
    state = codec.decode_operating_state(direct)
    assert (state.state, state.is_homed, state.is_busy) == ("ENABLED", True, True)
    assert codec.encode_operating_state(state) == direct


def test_point_cloud_and_trajectory_round_trip():
    points = np.random.default_rng(0).normal(size=(50, 3)).astype(np.float32)
    stamp, decoded, _ = codec.decode_coloured_cloud(codec.encode_point_cloud(7.25, points))
    assert stamp == 7.25 and np.array_equal(decoded, points)

    t = np.array([0.0, 0.01, 1.5])
    q = np.arange(18.0).reshape(3, 6)
    direct = reference_bytes(
        T["trajectory_msgs/msg/JointTrajectory"](
            header=header(1, 0),
            joint_names=[],
            points=[
                T["trajectory_msgs/msg/JointTrajectoryPoint"](
                    positions=q[i],
                    velocities=np.zeros(0),
                    accelerations=np.zeros(0),
                    effort=np.zeros(0),
                    time_from_start=T["builtin_interfaces/msg/Duration"](
                        sec=int(t[i]), nanosec=int(round(t[i] % 1 * 1e9))
                    ),
                )
                for i in range(3)
            ],
        )
    )
    stamp, trajectory = codec.decode_trajectory(direct)
    assert np.allclose(trajectory.t, t) and np.array_equal(trajectory.q, q) and trajectory.qd is None
    assert codec.encode_trajectory(stamp, trajectory) == direct


def test_a_coloured_cloud_round_trips_as_zivid_ros_lays_it_out():
    points = np.random.default_rng(0).normal(size=(4, 3)).astype(np.float32)
    rgba = np.array([0xFFC8281E, 0xFFB9B9B4, 0, 0xFF3C3C40], dtype=np.uint32)
    encoded = codec.encode_point_cloud(1.5, points, "zivid_optical_frame", rgba=rgba)
    message = REFERENCE.deserialize_cdr(encoded, "sensor_msgs/msg/PointCloud2")
    # zivid-ros `makePointCloud2Msg`: x, y, z FLOAT32 at 0, 4, 8, rgba UINT32 at 12, 16 bytes a point
    assert [(f.name, f.offset, f.datatype) for f in message.fields] == [
        ("x", 0, 7),
        ("y", 4, 7),
        ("z", 8, 7),
        ("rgba", 12, 6),
    ]
    assert message.point_step == 16 and bytes(message.data[12:16]) == bytes([0x1E, 0x28, 0xC8, 0xFF])  # BGRA
    stamp, decoded, colours = codec.decode_coloured_cloud(encoded)
    assert stamp == 1.5 and np.array_equal(decoded, points) and np.array_equal(colours, rgba)


def test_a_cloud_with_pcl_s_packed_float_rgb_decodes_its_colours():
    """realsense-ros and PCL pack a colour as a FLOAT32 `rgb` field (bytes B, G, R, 0), here after padding."""
    data = np.zeros((2, 8), dtype="<f4")
    data[:, :3] = [[0.1, 0.2, 0.5], [0.3, 0.4, 0.6]]
    data[:, 4] = np.array([0x00C8281E, 0x003C3C40], dtype="<u4").view("<f4")
    fields = [
        T["sensor_msgs/msg/PointField"](name=name, offset=offset, datatype=7, count=1)
        for name, offset in (("x", 0), ("y", 4), ("z", 8), ("rgb", 16))
    ]
    message = T["sensor_msgs/msg/PointCloud2"](
        header=header(3, 0),
        height=1,
        width=2,
        fields=fields,
        is_bigendian=False,
        point_step=32,
        row_step=64,
        data=data.view(np.uint8).reshape(-1),
        is_dense=True,
    )
    _, points, colours = codec.decode_coloured_cloud(reference_bytes(message))
    assert np.allclose(points, data[:, :3]) and list(colours) == [0x00C8281E, 0x003C3C40]
    assert codec.decode_coloured_cloud(codec.encode_point_cloud(0.0, points))[2] is None


def test_pose_stamped_round_trip():
    transform = np.eye(4)
    transform[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    transform[:3, 3] = [0.01, -0.02, -0.15]
    stamp, decoded = codec.decode_pose_stamped(codec.encode_pose_stamped(2.0, transform, "PSM1_base"))
    assert stamp == 2.0 and np.allclose(decoded, transform)


def test_corrupt_payload_is_a_pegbt_error():
    with pytest.raises(PegbtError, match="JointState"):
        codec.decode_joint_state(b"\x00\x01\x00\x00garbage")


def test_sessions_default_to_loopback_peer_without_scouting():
    for settings in (endpoint_settings(), client_settings()):
        config = settings.config()
        assert json.loads(config.get_json("mode")) == "peer"
        assert json.loads(config.get_json("scouting/multicast/enabled")) is False
        assert json.loads(config.get_json("scouting/gossip/enabled")) is False
    assert endpoint_settings().listen == (DEFAULT_ENDPOINT,) and client_settings().connect == (
        DEFAULT_ENDPOINT,
    )
    assert DEFAULT_ENDPOINT == "tcp/127.0.0.1:7447"
    with pytest.raises(PegbtError, match="tcp/HOST:PORT"):
        SessionSettings(connect=("127.0.0.1",))
    with pytest.raises(TypeError):
        SessionSettings(mode="client")  # peer mode only: a client or router session is not offered
    with pytest.raises(PegbtError, match="not on loopback"):
        endpoint_settings(["tcp/192.168.1.10:7447"])
    with pytest.raises(PegbtError, match="any free port"):
        endpoint_settings(["tcp/[::1]:0"])
    assert endpoint_settings(["tcp/[::1]:7447", "tcp/localhost:7448"]).listen == (
        "tcp/[::1]:7447",
        "tcp/localhost:7448",
    )
    assert endpoint_settings(["tcp/0.0.0.0:7447"], allow_remote_listen=True).listen == ("tcp/0.0.0.0:7447",)
    assert client_settings(["tcp/192.168.1.10:7447"]).connect == (
        "tcp/192.168.1.10:7447",
    )  # a real dVRK elsewhere


def test_crtk_key_names_follow_dvrk_topics():
    keys = ArmKeys("PSM1")
    assert (keys.measured_js, keys.servo_jp, keys.jaw_move_jp, keys.operating_state) == (
        "PSM1/measured_js",
        "PSM1/servo_jp",
        "PSM1/jaw/move_jp",
        "PSM1/operating_state",
    )
    assert ArmKeys("PSM2", "/lab2/").setpoint_js == "lab2/PSM2/setpoint_js"
    assert CameraKeys().points == "camera/depth/points"


def test_tags_round_trip_and_foreign_attachments_are_untagged():
    tag = Tag("abc", 42, "src:PSM1/move_jp:3", "done")
    assert Tag.decode(tag.encode()) == tag
    assert Tag.decode(None) is None and Tag.decode(b"not a tag") is None


SETTINGS = arm_settings("PSM1")
HOME = np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])


@pytest.mark.parametrize(
    "q, message",
    [
        ([0.0, 0.0, 0.12, 0.0, 0.0, float("nan")], "nan"),
        ([0.0, 0.0, 0.12], "expected 6"),
        ([0.0, 0.0, 0.30, 0.0, 0.0, 0.0], "insertion"),
    ],
)
def test_guards_refuse_bad_joint_commands(q, message):
    problems = guards.joint_problems(q, SETTINGS)
    assert problems and message in " ".join(problems)
    with pytest.raises(guards.CommandRefused):
        guards.refuse_if(problems, "set-point", "PSM1/servo_jp")


def test_guards_check_velocity_of_steps_and_trajectories():
    period = SETTINGS.control_period
    fast_step = HOME + [SETTINGS.velocity[0] * period * 1.5, 0, 0, 0, 0, 0]
    assert "yaw" in " ".join(guards.step_problems(fast_step, HOME, SETTINGS, period))
    assert not guards.step_problems(
        HOME + [SETTINGS.velocity[0] * period * 0.99, 0, 0, 0, 0, 0], HOME, SETTINGS, period
    )

    t = np.arange(0, 0.5, period)
    ok = codec.TrajectoryPoints(t, HOME + np.outer(t, [0.5, 0, 0, 0, 0, 0]))
    assert not guards.trajectory_problems(ok, SETTINGS)
    too_fast = codec.TrajectoryPoints(t[:20], HOME + np.outer(t[:20], [5.0, 0, 0, 0, 0, 0]))
    assert "segment after point 0" in " ".join(guards.trajectory_problems(too_fast, SETTINGS))
    backwards = codec.TrajectoryPoints(t[::-1], ok.q)
    assert "increasing" in " ".join(guards.trajectory_problems(backwards, SETTINGS))
    assert "jaw angle" in " ".join(guards.jaw_problems(2.0, SETTINGS))
