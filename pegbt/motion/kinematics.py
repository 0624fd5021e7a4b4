"""PSM forward kinematics on the reference paper's modified Denavit–Hartenberg chain.

Joints: q1 yaw, q2 pitch (rad), q3 insertion (m), q4 roll, q5 wrist pitch, q6 wrist yaw (rad).
Each link is `RotX(α)·TransX(a)·RotZ(θ)·TransZ(d)` (Craig's convention). Everything is vectorised
over a leading batch dimension so the simulator, the planner and calibration share one implementation;
`shaft_end_and_tip` walks the same chain for one configuration on Python floats, for the simulator's
every tick, where numpy's per-call overhead would dominate.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

L1 = 0.4318  # remote centre of motion to the tool's base (m)
L2 = 0.4162  # tool shaft (m)
L3 = 0.0091  # wrist pitch axis to wrist yaw axis (m)
L4 = 0.0095  # wrist yaw axis to the tool tip (m)

N_JOINTS = 6

Joint = TypeVar("Joint", float, NDArray[np.float64])


def _dh_table(q: Sequence[Joint], zero: Joint) -> list[tuple[float, float, Joint, Joint]]:
    """(a, α, d, θ) per link; d and θ are floats for one configuration, arrays for a batch (`zero` says which)."""
    q1, q2, q3, q4, q5, q6 = q
    half_pi = np.pi / 2
    return [
        (0.0, half_pi, zero, q1 + half_pi),
        (0.0, -half_pi, zero, q2 - half_pi),
        (0.0, half_pi, q3 - L1 + L2, zero),
        (0.0, 0.0, zero, q4),
        (0.0, -half_pi, zero, q5 - half_pi),
        (L3, -half_pi, zero, q6 - half_pi),
        (0.0, -half_pi, zero + L4, zero),
        (0.0, np.pi, zero, zero + np.pi),
    ]


_ALPHA_TRIG = [(math.cos(alpha), math.sin(alpha)) for _, alpha, _, _ in _dh_table([0.0] * N_JOINTS, zero=0.0)]


def _dh_rows(q: NDArray[np.float64]) -> list[tuple[float, float, NDArray[np.float64], NDArray[np.float64]]]:
    """(a, α, d, θ) per link for joint batch `q` (..., 6); d and θ are arrays."""
    return _dh_table([q[..., i] for i in range(N_JOINTS)], zero=np.zeros(q.shape[:-1]))


def _link(a: float, alpha: float, d: NDArray[np.float64], theta: NDArray[np.float64]) -> NDArray[np.float64]:
    """Homogeneous transform of one modified-DH link, batched over the shape of `theta`."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    T = np.zeros(theta.shape + (4, 4))
    T[..., 0, 0] = ct
    T[..., 0, 1] = -st
    T[..., 0, 3] = a
    T[..., 1, 0] = st * ca
    T[..., 1, 1] = ct * ca
    T[..., 1, 2] = -sa
    T[..., 1, 3] = -sa * d
    T[..., 2, 0] = st * sa
    T[..., 2, 1] = ct * sa
    T[..., 2, 2] = ca
    T[..., 2, 3] = ca * d
    T[..., 3, 3] = 1.0
    return T


def link_frames(q: ArrayLike) -> list[NDArray[np.float64]]:
    """Base-frame pose of every link frame (8 of them, the last is the tool tip), each (..., 4, 4)."""
    q = np.asarray(q, dtype=float)
    if q.shape[-1] != N_JOINTS:
        raise ValueError(f"expected joint vectors of length {N_JOINTS}, got shape {q.shape}")
    frames = []
    T = np.broadcast_to(np.eye(4), q.shape[:-1] + (4, 4))
    for a, alpha, d, theta in _dh_rows(q):
        T = T @ _link(a, alpha, d, theta)
        frames.append(T)
    return frames


def forward_kinematics(q: ArrayLike) -> NDArray[np.float64]:
    """Tool-tip pose in the arm's base frame, (..., 4, 4), for joints `q` (..., 6)."""
    return link_frames(q)[-1]


def tip_position(q: ArrayLike) -> NDArray[np.float64]:
    """Tool-tip position (..., 3) in metres."""
    return forward_kinematics(q)[..., :3, 3]


def shaft_end_and_tip(q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """For one configuration `q` (6,): the end of the shaft (3,), at the wrist pitch axis, and the
    tool-tip pose (4, 4), both in the base frame; the same chain as `link_frames`, on floats."""
    cos, sin = math.cos, math.sin
    xx, xy, xz, yx, yy, yz, zx, zy, zz = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0  # frame axes (columns)
    px = py = pz = 0.0  # frame origin
    shaft_end = (0.0, 0.0, 0.0)
    table = _dh_table(np.asarray(q, dtype=float).tolist(), zero=0.0)
    for link, ((a, _, d, theta), (ca, sa)) in enumerate(zip(table, _ALPHA_TRIG)):
        ct, st = cos(theta), sin(theta)
        px, py, pz = px + a * xx, py + a * xy, pz + a * xz  # TransX(a)
        yx, yy, yz, zx, zy, zz = (  # RotX(α)
            ca * yx + sa * zx,
            ca * yy + sa * zy,
            ca * yz + sa * zz,
            ca * zx - sa * yx,
            ca * zy - sa * yy,
            ca * zz - sa * yz,
        )
        xx, xy, xz, yx, yy, yz = (  # RotZ(θ)
            ct * xx + st * yx,
            ct * xy + st * yy,
            ct * xz + st * yz,
            ct * yx - st * xx,
            ct * yy - st * xy,
            ct * yz - st * xz,
        )
        px, py, pz = px + d * zx, py + d * zy, pz + d * zz  # TransZ(d)
        if link == 2:  # the insertion joint's frame: where the shaft ends
            shaft_end = (px, py, pz)
    tip = np.array([[xx, yx, zx, px], [xy, yy, zy, py], [xz, yz, zz, pz], [0.0, 0.0, 0.0, 1.0]])
    return np.array(shaft_end), tip
