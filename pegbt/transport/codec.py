"""CDR payloads: ROS 2 messages serialised by `rosbags`' typestore, so a zenoh–ROS 2 bridge carries them as is.

Standard types come from the typestore's ROS 2 Humble set; `crtk_msgs` types and the service
`std_srvs/srv/Trigger` (with the event type ROS 2 Iron and later describe every service by, so that its
RIHS01 hash is the one rmw_zenoh keys by) are registered from their definitions' text. Each function
turns one message into plain Python/numpy values or back; nothing here knows the wire format itself.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from pegbt.errors import PegbtError
from pegbt.frames import rigid_transform

CRTK_MSGS = {
    "crtk_msgs/msg/OperatingState": "std_msgs/Header header\nstring state\nbool is_homed\nbool is_busy\n",
    "crtk_msgs/msg/StringStamped": "std_msgs/Header header\nstring string\n",
}

# std_srvs/srv/Trigger.srv and service_msgs/msg/ServiceEventInfo.msg (ros2/common_interfaces, ros2/rcl_interfaces);
# a service is described as a message of its request, response and event (rosidl_generator_type_description),
# and a .msg `char` is IDL's uint8 (rosidl_adapter)
TRIGGER = "std_srvs/srv/Trigger"
SERVICE_DEFINITIONS = {
    "service_msgs/msg/ServiceEventInfo": (
        "uint8 REQUEST_SENT = 0\nuint8 REQUEST_RECEIVED = 1\nuint8 RESPONSE_SENT = 2\n"
        "uint8 RESPONSE_RECEIVED = 3\nuint8 event_type\nbuiltin_interfaces/Time stamp\n"
        "uint8[16] client_gid\nint64 sequence_number\n"
    ),
    f"{TRIGGER}_Request": "uint8 structure_needs_at_least_one_member\n",
    f"{TRIGGER}_Response": "bool success\nstring message\n",
    f"{TRIGGER}_Event": (
        f"service_msgs/ServiceEventInfo info\n{TRIGGER}_Request[<=1] request\n{TRIGGER}_Response[<=1] response\n"
    ),
    TRIGGER: (
        f"{TRIGGER}_Request request_message\n{TRIGGER}_Response response_message\n"
        f"{TRIGGER}_Event event_message\n"
    ),
}

JOINT_STATE = "sensor_msgs/msg/JointState"
OPERATING_STATE = "crtk_msgs/msg/OperatingState"
STRING_STAMPED = "crtk_msgs/msg/StringStamped"
STRING = "std_msgs/msg/String"
EMPTY = "std_msgs/msg/Empty"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
JOY = "sensor_msgs/msg/Joy"
FLOAT64 = "std_msgs/msg/Float64"
POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"


@lru_cache(maxsize=1)
def typestore() -> Any:
    """The one typestore: ROS 2 Humble types plus crtk_msgs."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in CRTK_MSGS.items():
        store.register(get_types_from_msg(text, name))
    services: dict[str, Any] = {}
    for name, text in SERVICE_DEFINITIONS.items():
        services.update(get_types_from_msg(text, name))
    store.register({_srv_name(name): _srv_name(definition) for name, definition in services.items()})
    return store


def _srv_name(value: Any) -> Any:
    """`value` with rosbags' `pkg/srv/msg/Type` (how it names a type read from .msg text) as `pkg/srv/Type`."""
    if isinstance(value, str):
        return value.replace("/srv/msg/", "/srv/")
    if isinstance(value, (tuple, list)):
        return type(value)(_srv_name(item) for item in value)
    return value


def serialize(message: Any) -> bytes:
    """CDR bytes of a typestore message object."""
    return bytes(typestore().serialize_cdr(message, message.__msgtype__))


def deserialize(data: bytes | memoryview, typename: str) -> Any:
    """A typestore message from CDR bytes; a `PegbtError` naming the type if the payload is not one."""
    try:
        return typestore().deserialize_cdr(data, typename)
    except Exception as error:  # rosbags raises assorted errors on truncated or foreign payloads
        raise PegbtError(f"payload is not a valid CDR {typename}: {error}", field=typename) from None


def _type(name: str) -> Any:
    return typestore().types[name]


def _header(stamp: float, frame_id: str = "") -> Any:
    if not math.isfinite(stamp) or stamp < 0:
        raise PegbtError(f"stamp must be a finite time >= 0, got {stamp}", field="stamp")
    sec, nanosec = seconds_parts(stamp)
    time = _type("builtin_interfaces/msg/Time")(sec=sec, nanosec=nanosec)
    return _type("std_msgs/msg/Header")(stamp=time, frame_id=frame_id)


def seconds_parts(seconds: float) -> tuple[int, int]:
    """Whole seconds and nanoseconds, as builtin_interfaces Time and Duration hold them."""
    sec = int(math.floor(seconds))
    return sec, min(int(round((seconds - sec) * 1e9)), 999_999_999)


def _stamp(header: Any) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def _floats(values: ArrayLike) -> NDArray[np.float64]:
    return np.ascontiguousarray(values, dtype=np.float64).reshape(-1)


# ----------------------------------------------------------------------------- JointState
@dataclass(frozen=True)
class JointSample:
    """One sensor_msgs/JointState: positions (rad, m), velocities, efforts; empty arrays when absent."""

    stamp: float
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    effort: NDArray[np.float64]
    name: tuple[str, ...] = ()


def encode_joint_state(
    stamp: float,
    position: ArrayLike,
    velocity: ArrayLike = (),
    effort: ArrayLike = (),
    names: tuple[str, ...] = (),
) -> bytes:
    message = _type(JOINT_STATE)(
        header=_header(stamp),
        name=list(names),
        position=_floats(position),
        velocity=_floats(velocity),
        effort=_floats(effort),
    )
    return serialize(message)


def decode_joint_state(data: bytes) -> JointSample:
    message = deserialize(data, JOINT_STATE)
    return JointSample(
        stamp=_stamp(message.header),
        position=np.asarray(message.position, dtype=float),
        velocity=np.asarray(message.velocity, dtype=float),
        effort=np.asarray(message.effort, dtype=float),
        name=tuple(message.name),
    )


# ----------------------------------------------------------------------------- crtk operating state
@dataclass(frozen=True)
class OperatingState:
    """crtk_msgs/OperatingState: `state` is DISABLED, ENABLED, PAUSED or FAULT."""

    stamp: float
    state: str
    is_homed: bool
    is_busy: bool


def encode_operating_state(state: OperatingState) -> bytes:
    message = _type(OPERATING_STATE)(
        header=_header(state.stamp), state=state.state, is_homed=state.is_homed, is_busy=state.is_busy
    )
    return serialize(message)


def decode_operating_state(data: bytes) -> OperatingState:
    message = deserialize(data, OPERATING_STATE)
    return OperatingState(
        _stamp(message.header), message.state, bool(message.is_homed), bool(message.is_busy)
    )


# ----------------------------------------------------------------------------- strings and triggers
def encode_string_stamped(stamp: float, text: str) -> bytes:
    return serialize(_type(STRING_STAMPED)(header=_header(stamp), string=text))


def decode_string_stamped(data: bytes) -> tuple[float, str]:
    message = deserialize(data, STRING_STAMPED)
    return _stamp(message.header), message.string


def encode_string(text: str) -> bytes:
    return serialize(_type(STRING)(data=text))


def decode_string(data: bytes) -> str:
    return deserialize(data, STRING).data


def encode_float64(value: float) -> bytes:
    return serialize(_type(FLOAT64)(data=float(value)))


def decode_float64(data: bytes) -> float:
    return float(deserialize(data, FLOAT64).data)


def encode_empty() -> bytes:
    return serialize(_type(EMPTY)())


def encode_button(stamp: float, pressed: bool) -> bytes:
    """A button event as the dVRK's bridge writes one (cisst-ros `cisst_ros_bridge/src/mtsCISSTToROS.cpp`,
    prmEventButton to sensor_msgs/Joy): one button, 1 pressed, 0 released."""
    message = _type(JOY)(
        header=_header(stamp), axes=np.zeros(0, dtype=np.float32), buttons=np.array([int(pressed)], np.int32)
    )
    return serialize(message)


def decode_button(data: bytes) -> bool:
    """Whether a sensor_msgs/Joy button event says pressed (its first button is 1)."""
    buttons = deserialize(data, JOY).buttons
    if len(buttons) < 1:
        raise PegbtError("a button event needs one button (1 pressed, 0 released)", field="buttons")
    return bool(buttons[0] == 1)


# ----------------------------------------------------------------------------- poses
def encode_pose_stamped(stamp: float, transform: ArrayLike, frame_id: str = "") -> bytes:
    """A 4×4 homogeneous transform as geometry_msgs/PoseStamped (quaternion x, y, z, w)."""
    from scipy.spatial.transform import Rotation

    transform = np.asarray(transform, dtype=float)
    x, y, z, w = Rotation.from_matrix(transform[:3, :3]).as_quat()
    pose = _type("geometry_msgs/msg/Pose")(
        position=_type("geometry_msgs/msg/Point")(*map(float, transform[:3, 3])),
        orientation=_type("geometry_msgs/msg/Quaternion")(x=x, y=y, z=z, w=w),
    )
    return serialize(_type(POSE_STAMPED)(header=_header(stamp, frame_id), pose=pose))


def decode_pose_stamped(data: bytes) -> tuple[float, NDArray[np.float64]]:
    from scipy.spatial.transform import Rotation

    message = deserialize(data, POSE_STAMPED)
    p, o = message.pose.position, message.pose.orientation
    return _stamp(message.header), rigid_transform(
        Rotation.from_quat([o.x, o.y, o.z, o.w]).as_matrix(), (p.x, p.y, p.z)
    )


# ----------------------------------------------------------------------------- point clouds
ORGANISED_POINT_STEP = 16  # bytes: x, y, z float32 and rgba (or padding), as the Zivid driver sends
_FLOAT32, _UINT32 = 7, 6  # sensor_msgs/PointField datatypes
_XYZ_FIELDS = (("x", _FLOAT32), ("y", _FLOAT32), ("z", _FLOAT32))


def encode_point_cloud(
    stamp: float, points: ArrayLike, frame_id: str = "camera", rgba: ArrayLike | None = None
) -> bytes:
    """Points in metres as a sensor_msgs/PointCloud2 of float32 x, y, z: (N, 3) unorganised, or (H, W, 3)
    organised as an image's pixels, row by row, NaN marking the invalid ones (then not dense); given `rgba`
    (one word a point, `0xAARRGGBB`), a UINT32 rgba field after them, as zivid-ros's points/xyzrgba."""
    points = np.ascontiguousarray(points, dtype="<f4")
    if points.ndim not in (2, 3) or points.shape[-1] != 3:
        raise PegbtError(f"point cloud must be N×3 or H×W×3, got shape {points.shape}", field="points")
    grid = points if points.ndim == 3 else points[None]
    dense = bool(np.isfinite(points).all())
    if rgba is None:
        return _point_cloud2(stamp, frame_id, grid, _XYZ_FIELDS, is_dense=dense)
    words = np.asarray(rgba, dtype="<u4").reshape(grid.shape[:2])
    packed = np.concatenate([grid, words.view("<f4")[..., None]], axis=-1)
    return _point_cloud2(stamp, frame_id, packed, (*_XYZ_FIELDS, ("rgba", _UINT32)), is_dense=dense)


def decode_coloured_cloud(data: bytes) -> tuple[float, NDArray[np.float32], NDArray[np.uint32] | None]:
    """(stamp, (N, 3) float32 points, (N,) rgba words or None) from a PointCloud2 with float32 x, y, z
    fields at any offsets and, if it has one, a 4-byte colour: `rgba` (zivid-ros, UINT32 or FLOAT32) or
    `rgb` (PCL's packed float, realsense-ros), each the word `0xAARRGGBB`."""
    message = deserialize(data, POINT_CLOUD2)
    offsets = {f.name: f.offset for f in message.fields if f.datatype == _FLOAT32 and f.count == 1}
    if not {"x", "y", "z"} <= offsets.keys() or message.is_bigendian:
        raise PegbtError("point cloud needs little-endian float32 x, y, z fields", field="fields")
    count = message.width * message.height
    raw = np.asarray(message.data, dtype=np.uint8)[: count * message.point_step].reshape(
        count, message.point_step
    )

    def word(offset: int, dtype: str) -> NDArray[Any]:
        return raw[:, offset : offset + 4].copy().view(dtype).reshape(-1)

    points = np.column_stack([word(offsets[axis], "<f4") for axis in "xyz"]).astype(np.float32)
    colour = _colour_offset(message.fields)
    return _stamp(message.header), points, None if colour is None else word(colour, "<u4")


def _colour_offset(fields: Sequence[Any]) -> int | None:
    """The offset of a PointCloud2's 4-byte colour word (`rgba`, else `rgb`; UINT32 or FLOAT32), if any."""
    return next(
        (
            f.offset
            for name in ("rgba", "rgb")
            for f in fields
            if f.name == name and f.datatype in (_FLOAT32, _UINT32) and f.count == 1
        ),
        None,
    )


def encode_organised_cloud(
    stamp: float, points: NDArray[np.float32], frame_id: str, rgba: NDArray[np.uint32] | None = None
) -> bytes:
    """An organised (H, W, 3) cloud as a PointCloud2 of 16 bytes per point: x, y, z and, given `rgba` (H, W),
    a UINT32 rgba field at offset 12, else 4 bytes of padding (zivid-ros `zivid_camera.cpp`:
    `makePointCloud2Msg` for points/xyzrgba, `publishPointCloudXYZ` with `Zivid::PointXYZW` for points/xyz).
    NaN marks the invalid pixels; the cloud is never dense."""
    if points.ndim != 3 or points.shape[-1] != 3:
        raise PegbtError(f"an organised cloud is H×W×3, got shape {points.shape}", field="points")
    packed = np.zeros((*points.shape[:2], ORGANISED_POINT_STEP // 4), dtype="<f4")
    packed[..., :3] = points
    if rgba is not None:
        packed[..., 3] = np.asarray(rgba, dtype="<u4").view("<f4")
    fields = _XYZ_FIELDS if rgba is None else (*_XYZ_FIELDS, ("rgba", _UINT32))
    return _point_cloud2(stamp, frame_id, packed, fields, is_dense=False)


def _point_cloud2(
    stamp: float,
    frame_id: str,
    packed: NDArray[np.float32],
    fields: Sequence[tuple[str, int]],
    is_dense: bool,
) -> bytes:
    """A PointCloud2 of the (H, W, words) 4-byte words `packed`, the `fields` (name, datatype) at offsets
    0, 4, 8, … and any words after them padding: the one builder of every cloud layout sent."""
    height, width, words = packed.shape
    field_type = _type("sensor_msgs/msg/PointField")
    message = _type(POINT_CLOUD2)(
        header=_header(stamp, frame_id),
        height=height,
        width=width,
        fields=[
            field_type(name=name, offset=4 * i, datatype=datatype, count=1)
            for i, (name, datatype) in enumerate(fields)
        ],
        is_bigendian=False,
        point_step=4 * words,
        row_step=4 * words * width,
        data=np.ascontiguousarray(packed, dtype="<f4").view(np.uint8).reshape(-1),
        is_dense=is_dense,
    )
    return serialize(message)


def decode_organised_cloud(data: bytes, stride: int = 1) -> tuple[float, NDArray[np.float32]]:
    """(stamp, (h, w, 3) float32) from an organised PointCloud2 with float32 x, y, z, every `stride`-th row
    and column of its grid: only those points are copied out of the message."""
    stamp, grid, _ = organised_views(data)
    return stamp, np.ascontiguousarray(grid[::stride, ::stride])


def organised_views(data: bytes) -> tuple[float, NDArray[np.float32], NDArray[np.uint32] | None]:
    """(stamp, (H, W, 3) float32, (H, W) rgba words or None) of an organised PointCloud2 with float32 x, y, z
    and maybe a colour word (`rgba` or `rgb`, as `decode_coloured_cloud` reads it): read-only views of the
    message's bytes, the grid where x, y, z lie side by side (every driver's layout), so that a part of the
    image is copied out only when taken; the grid a copy otherwise."""
    message = deserialize(memoryview(data), POINT_CLOUD2)  # rosbags slices it: a view, not a 37 MB copy
    offsets = {f.name: f.offset for f in message.fields if f.datatype == _FLOAT32 and f.count == 1}
    if not {"x", "y", "z"} <= offsets.keys() or message.is_bigendian:
        raise PegbtError("point cloud needs little-endian float32 x, y, z fields", field="fields")
    step, height, width = message.point_step, message.height, message.width
    if message.row_step < step * width or len(message.data) < message.row_step * height:
        raise PegbtError(
            f"point cloud holds {len(message.data)} bytes, not {height} rows of {message.row_step}",
            field="data",
        )
    colour = _colour_offset(message.fields)
    aligned = [offsets[a] for a in "xyz"] + ([] if colour is None else [colour])
    if step % 4 or message.row_step % 4 or any(offset % 4 for offset in aligned):
        raise PegbtError("an organised cloud's fields must be 4-byte aligned", field="point_step")
    words = np.asarray(message.data, dtype=np.uint8)[: message.row_step * height].view("<f4")
    pixels = np.lib.stride_tricks.as_strided(  # a view of the rows (padded or not) as pixels of 4-byte words
        words, shape=(height, width, step // 4), strides=(message.row_step, step, 4), writeable=False
    )
    rgba = None if colour is None else pixels.view("<u4")[..., colour // 4]
    words_xyz = [offsets[a] // 4 for a in "xyz"]
    first = words_xyz[0]
    if words_xyz == [first, first + 1, first + 2]:
        return _stamp(message.header), pixels[..., first : first + 3], rgba
    return _stamp(message.header), pixels[..., words_xyz], rgba


def encode_trigger_request() -> bytes:
    """A std_srvs/srv/Trigger request (no fields but the placeholder every empty ROS 2 structure has)."""
    return serialize(_type(f"{TRIGGER}_Request")(structure_needs_at_least_one_member=0))


def encode_trigger_response(success: bool, message: str = "") -> bytes:
    return serialize(_type(f"{TRIGGER}_Response")(success=success, message=message))


def decode_trigger_response(data: bytes) -> tuple[bool, str]:
    """(success, message) of a std_srvs/srv/Trigger response."""
    response = deserialize(data, f"{TRIGGER}_Response")
    return bool(response.success), str(response.message)


# ----------------------------------------------------------------------------- joint trajectories
@runtime_checkable
class TrajectoryLike(Protocol):
    """What travels as a JointTrajectory: times from its start `t` (N,) and positions `q` (N, J); velocities
    `qd` and accelerations `qdd` (N, J) if it has them. A planned `pegbt.motion.trajectory.Trajectory` is one."""

    @property
    def t(self) -> ArrayLike: ...

    @property
    def q(self) -> ArrayLike: ...


@dataclass(frozen=True)
class TrajectoryPoints:
    """The points of a trajectory_msgs/JointTrajectory as plain arrays: times from its start (N,), positions
    (N, J), velocities and accelerations or None. Unchecked, as any message is when it arrives (a receiver
    checks it with `guards.trajectory_problems`); also what a client sends when it has set-points at times
    rather than a planned `Trajectory` (a lone goal at the end of a straight move, a stream of commands)."""

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64] | None = None
    qdd: NDArray[np.float64] | None = None


def encode_trajectory(stamp: float, trajectory: TrajectoryLike, names: tuple[str, ...] = ()) -> bytes:
    """`trajectory` (`t`, `q` and, if it has them, `qd`, `qdd`) as trajectory_msgs/JointTrajectory."""
    point_type = _type("trajectory_msgs/msg/JointTrajectoryPoint")
    duration_type = _type("builtin_interfaces/msg/Duration")
    t = np.asarray(trajectory.t, dtype=float)
    q = np.asarray(trajectory.q, dtype=float)
    qd, qdd = getattr(trajectory, "qd", None), getattr(trajectory, "qdd", None)
    empty = np.zeros(0)
    points = []
    for i, ti in enumerate(t):
        sec, nanosec = seconds_parts(float(ti))
        points.append(
            point_type(
                positions=_floats(q[i]),
                velocities=empty if qd is None else _floats(np.asarray(qd)[i]),
                accelerations=empty if qdd is None else _floats(np.asarray(qdd)[i]),
                effort=empty,
                time_from_start=duration_type(sec=sec, nanosec=nanosec),
            )
        )
    message = _type(JOINT_TRAJECTORY)(header=_header(stamp), joint_names=list(names), points=points)
    return serialize(message)


def decode_trajectory(data: bytes) -> tuple[float, TrajectoryPoints]:
    """(stamp, points); ragged points are kept as given (validation is the receiver's job)."""
    message = deserialize(data, JOINT_TRAJECTORY)
    points = message.points
    t = np.array([p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in points])

    def stack(attribute: str) -> NDArray[np.float64] | None:
        rows = [np.asarray(getattr(p, attribute), dtype=float) for p in points]
        if not rows or any(len(row) == 0 for row in rows):
            return None
        if len({len(row) for row in rows}) != 1:
            raise PegbtError(f"trajectory points have {attribute} of different sizes", field=attribute)
        return np.stack(rows)

    q = stack("positions")
    if q is None:
        raise PegbtError("trajectory has no positions", field="positions")
    return _stamp(message.header), TrajectoryPoints(
        t=t, q=q, qd=stack("velocities"), qdd=stack("accelerations")
    )
