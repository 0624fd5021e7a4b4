"""What the planners produce: a piecewise-cubic joint path (`HermitePath`) and, sampled from it at the
control period, a time-stamped `Trajectory` ready to stream.

A `Trajectory` is plain arrays: `t` (N,) from 0 in steps of the control period, and `q`, `qd`, `qdd`
(N, 6) in the joint order yaw, pitch, insertion, roll, wrist pitch, wrist yaw (SI units). It starts
and ends at rest. `ArmClient.move_jp` sends it whole, as a trajectory_msgs/JointTrajectory on
`follow_jt`, and the simulator plays it back point by point. It is the one trajectory type: the
transport encodes anything with `t` and `q` (and `qd`, `qdd`), and decodes into unchecked plain points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError

N_JOINTS = 6


@dataclass(frozen=True)
class Trajectory:
    """Joint set-points at a fixed period: `t` (N,), `q`, `qd`, `qdd` (N, 6)."""

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    qd: NDArray[np.float64]
    qdd: NDArray[np.float64]

    def __post_init__(self) -> None:
        n = len(self.t)
        if n < 2 or any(a.shape != (n, N_JOINTS) for a in (self.q, self.qd, self.qdd)):
            raise PegbtError(
                f"a trajectory needs N >= 2 times and (N, {N_JOINTS}) joint arrays", field="trajectory"
            )
        if not np.all(np.diff(self.t) > 0):
            raise PegbtError("trajectory times must increase", field="trajectory.t")

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def period(self) -> float:
        return float(self.t[1] - self.t[0])

    def __len__(self) -> int:
        return len(self.t)


def concatenate(trajectories: list[Trajectory]) -> Trajectory:
    """Play trajectories one after the other; each must start where (and at the rate) the previous ended."""
    first = trajectories[0]
    parts_t, parts = [first.t], [(first.q, first.qd, first.qdd)]
    end = first.t[-1]
    for index, following in enumerate(trajectories[1:], start=1):
        if not np.allclose(following.q[0], parts[-1][0][-1], atol=1e-9) or not np.isclose(
            following.period, first.period
        ):
            raise PegbtError(
                "does not start where the previous trajectory ends", field=f"trajectories[{index}]"
            )
        parts_t.append(following.t[1:] - following.t[0] + end)
        parts.append((following.q[1:], following.qd[1:], following.qdd[1:]))
        end = parts_t[-1][-1]
    q, qd, qdd = (np.concatenate([p[i] for p in parts]) for i in range(3))
    return Trajectory(np.concatenate(parts_t), q, qd, qdd)


@dataclass(frozen=True)
class HermitePath:
    """A C1 joint path: cubic Hermite segments between knots at `times` (K+1,) with `positions` and
    `velocities` (K+1, 6). Planners build it; `sample()` turns it into a streamable `Trajectory`."""

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    def retimed(self, factor: float) -> HermitePath:
        """The same path played `factor` times slower (velocities ÷ factor, accelerations ÷ factor²)."""
        return HermitePath(
            self.times[0] + (self.times - self.times[0]) * factor, self.positions, self.velocities / factor
        )

    def evaluate(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Position, velocity and acceleration (len(t), 6) at times `t` (clamped to the path)."""
        ts = np.clip(np.asarray(t, dtype=np.float64), self.times[0], self.times[-1])
        i = np.clip(np.searchsorted(self.times, ts, side="right") - 1, 0, len(self.times) - 2)
        h = (self.times[i + 1] - self.times[i])[:, None]
        s = (ts - self.times[i])[:, None] / h
        q0, q1 = self.positions[i], self.positions[i + 1]
        m0, m1 = self.velocities[i] * h, self.velocities[i + 1] * h
        delta = q1 - q0
        # Cubic q(s) = q0 + m0 s + c2 s² + c3 s³ on s ∈ [0, 1].
        c2 = 3 * delta - 2 * m0 - m1
        c3 = -2 * delta + m0 + m1
        q = q0 + s * (m0 + s * (c2 + s * c3))
        qd = (m0 + s * (2 * c2 + 3 * s * c3)) / h
        qdd = (2 * c2 + 6 * s * c3) / h**2
        return q, qd, qdd

    def sample(self, period: float) -> Trajectory:
        """The path sampled every `period` s; stretched (never sped up) so it lasts whole periods."""
        steps = max(1, int(np.ceil(self.duration / period - 1e-9)))
        path = self.retimed(steps * period / self.duration)
        t = np.arange(steps + 1, dtype=np.float64) * period
        q, qd, qdd = path.evaluate(t + path.times[0])
        return Trajectory(t, q, qd, qdd)


def segment_extremes(
    delta: NDArray[np.float64], v0: NDArray[np.float64], v1: NDArray[np.float64], h: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Largest |velocity| and |acceleration| per joint of cubic Hermite segments of duration `h`
    (broadcast) joining velocities `v0`, `v1` over a displacement `delta`.

    The acceleration of a cubic is linear, so it peaks at an end; the velocity peaks at an end or at the
    vertex of its parabola."""
    a0 = (6 * delta - h * (4 * v0 + 2 * v1)) / h**2
    a1 = (-6 * delta + h * (2 * v0 + 4 * v1)) / h**2
    peak_v = np.maximum(np.abs(v0), np.abs(v1))
    slope = a1 - a0
    with np.errstate(divide="ignore", invalid="ignore"):
        vertex_time = -a0 * h / slope
        inside = (vertex_time > 0) & (vertex_time < h)
        vertex_v = v0 - a0**2 * h / (2 * slope)
    peak_v = np.where(inside, np.maximum(peak_v, np.abs(vertex_v)), peak_v)
    return peak_v, np.maximum(np.abs(a0), np.abs(a1))


def limit_factor(
    path: HermitePath, velocity: NDArray[np.float64], acceleration: NDArray[np.float64]
) -> float:
    """How many times slower `path` must play for its peak velocity and acceleration (exact, from the
    segments' extremes) to just meet `velocity` and `acceleration`; below 1 it could play faster."""
    h = np.diff(path.times)[:, None]
    peak_v, peak_a = segment_extremes(
        np.diff(path.positions, axis=0), path.velocities[:-1], path.velocities[1:], h
    )
    return max(float(np.max(peak_v / velocity)), float(np.sqrt(np.max(peak_a / acceleration))))


def fit_to_limits(
    path: HermitePath,
    velocity: NDArray[np.float64],
    acceleration: NDArray[np.float64],
    *,
    speed_up: bool = False,
) -> HermitePath:
    """`path` retimed uniformly to just meet the limits: slowed down if it exceeds them, and sped up
    until they bind if `speed_up`; otherwise returned unchanged when within them."""
    factor = limit_factor(path, velocity, acceleration)
    if factor <= 1.0 and not speed_up:
        return path
    return path.retimed(factor * (1 + 1e-9))
