"""CDR payloads: ROS 2 messages serialised by `rosbags`' typestore, so a zenoh–ROS 2 bridge carries them as is.

Standard types come from the typestore's ROS 2 Humble set; `crtk_msgs` types are registered from their
`.msg` text. Each function turns one message into plain Python/numpy values or back; nothing here
knows the wire format itself.
"""

from __future__ import annotations

import math
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

JOINT_STATE = "sensor_msgs/msg/JointState"
OPERATING_STATE = "crtk_msgs/msg/OperatingState"
STRING_STAMPED = "crtk_msgs/msg/StringStamped"
STRING = "std_msgs/msg/String"
EMPTY = "std_msgs/msg/Empty"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
JOY = "sensor_msgs/msg/Joy"
POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
JOINT_TRAJECTORY = "trajectory_msgs/msg/JointTrajectory"


@lru_cache(maxsize=1)
def typestore() -> Any:
    """The one typestore: ROS 2 Humble types plus crtk_msgs."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in CRTK_MSGS.items():
        store.register(get_types_from_msg(text, name))
    return store


def serialize(message: Any) -> bytes:
    """CDR bytes of a typestore message object."""
    return bytes(typestore().serialize_cdr(message, message.__msgtype__))


def deserialize(data: bytes, typename: str) -> Any:
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
def encode_point_cloud(stamp: float, points: ArrayLike, frame_id: str = "camera") -> bytes:
    """Points in metres as a sensor_msgs/PointCloud2 of float32 x, y, z: (N, 3) unorganised, or (H, W, 3)
    organised as an image's pixels, row by row, NaN marking the invalid ones (then not dense)."""
    points = np.ascontiguousarray(points, dtype="<f4")
    if points.ndim not in (2, 3) or points.shape[-1] != 3:
        raise PegbtError(f"point cloud must be N×3 or H×W×3, got shape {points.shape}", field="points")
    height, width = points.shape[:2] if points.ndim == 3 else (1, len(points))
    points = points.reshape(-1, 3)
    field_type = _type("sensor_msgs/msg/PointField")
    fields = [
        field_type(name=axis, offset=4 * i, datatype=field_type.FLOAT32, count=1)
        for i, axis in enumerate("xyz")
    ]
    message = _type(POINT_CLOUD2)(
        header=_header(stamp, frame_id),
        height=height,
        width=width,
        fields=fields,
        is_bigendian=False,
        point_step=12,
        row_step=12 * width,
        data=points.view(np.uint8).reshape(-1),
        is_dense=bool(np.isfinite(points).all()),
    )
    return serialize(message)


def decode_point_cloud(data: bytes) -> tuple[float, NDArray[np.float32]]:
    """(stamp, (N, 3) float32 points) from a PointCloud2 with float32 x, y, z fields at any offsets."""
    message = deserialize(data, POINT_CLOUD2)
    offsets = {f.name: f.offset for f in message.fields if f.datatype == 7 and f.count == 1}
    if not {"x", "y", "z"} <= offsets.keys() or message.is_bigendian:
        raise PegbtError("point cloud needs little-endian float32 x, y, z fields", field="fields")
    count = message.width * message.height
    raw = np.asarray(message.data, dtype=np.uint8)[: count * message.point_step].reshape(
        count, message.point_step
    )
    columns = [raw[:, offsets[axis] : offsets[axis] + 4].copy().view("<f4").reshape(-1) for axis in "xyz"]
    return _stamp(message.header), np.column_stack(columns).astype(np.float32)


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
