"""Set-point sequences the simulated controller plays back at its control period.

A goal (`move_jp`) becomes a time-optimal, velocity- and acceleration-limited profile from Ruckig (the
successor of the Reflexxes library the dVRK itself uses for `move_jp`); a jaw goal becomes a ramp at
the jaw's speed; a client's trajectory is played back as given, linearly between its samples.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from ruckig import InputParameter, Result, Ruckig, Trajectory

from pegbt.errors import PegbtError


@dataclass(frozen=True)
class Playback:
    """Positions (K, J) at times (K,) after the command was accepted; the last sample is the goal."""

    command_id: str
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    _knots: list[float] = field(
        init=False, repr=False, compare=False
    )  # `times` as floats, searched each tick

    def __post_init__(self) -> None:
        object.__setattr__(self, "_knots", np.asarray(self.times, dtype=float).tolist())

    @property
    def duration(self) -> float:
        return self._knots[-1]

    def at(self, elapsed: float) -> NDArray[np.float64]:
        """Linear interpolation between samples; the goal once `elapsed` reaches the end. The times
        increase (the guards refuse others), so a bisection of their floats finds the sample
        `np.searchsorted(side="right")` would, without a NumPy call a tick."""
        knots = self._knots
        if elapsed >= knots[-1]:
            return self.positions[-1].copy()
        i = bisect_right(knots, elapsed)
        if i == 0:
            return self.positions[0].copy()
        t0, t1 = knots[i - 1], knots[i]
        w = (elapsed - t0) / (t1 - t0)
        return (1 - w) * self.positions[i - 1] + w * self.positions[i]


def _sample_times(duration: float, period: float) -> NDArray[np.float64]:
    """Tick times k·period covering `duration`, at least one tick (a move always takes one period)."""
    count = max(1, math.ceil(duration / period - 1e-9))
    return period * np.arange(1, count + 1, dtype=np.float64)


def goal_playback(
    command_id: str,
    start: ArrayLike,
    start_velocity: ArrayLike,
    goal: ArrayLike,
    max_velocity: ArrayLike,
    max_acceleration: ArrayLike,
    period: float,
) -> Playback:
    """A synchronised, limit-respecting profile from `start` (moving at `start_velocity`) to rest at `goal`."""
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    dofs = len(start)
    parameters = InputParameter(dofs)
    parameters.current_position = start.tolist()
    parameters.current_velocity = np.asarray(start_velocity, dtype=float).tolist()
    parameters.target_position = goal.tolist()
    parameters.max_velocity = np.asarray(max_velocity, dtype=float).tolist()
    parameters.max_acceleration = np.asarray(max_acceleration, dtype=float).tolist()
    parameters.max_jerk = [math.inf] * dofs
    profile = Trajectory(dofs)
    result = Ruckig(dofs).calculate(parameters, profile)
    if result not in (Result.Working, Result.Finished):
        raise PegbtError(f"no profile from {start.tolist()} to {goal.tolist()}: {result}", field="move_jp")
    times = _sample_times(profile.duration, period)
    positions = np.array([profile.at_time(min(t, profile.duration))[0] for t in times])
    positions[-1] = goal
    return Playback(command_id, times, positions)


def ramp_playback(command_id: str, start: float, goal: float, speed: float, period: float) -> Playback:
    """A constant-speed ramp of one joint (the jaw)."""
    times = _sample_times(abs(goal - start) / speed, period)
    positions = start + np.clip(times * speed, 0, abs(goal - start)) * np.sign(goal - start)
    positions[-1] = goal
    return Playback(command_id, times, positions.reshape(-1, 1))


def trajectory_playback(
    command_id: str, setpoint: ArrayLike, t: ArrayLike, q: ArrayLike, period: float
) -> Playback:
    """A client's trajectory, timed from acceptance.

    If it starts exactly at the current set-point at time 0 it plays as given; otherwise the set-point
    is held as a first knot and a trajectory stamped from 0 is delayed by one period, so the first step
    is never a jump.
    """
    setpoint, t, q = np.asarray(setpoint, dtype=float), np.asarray(t, dtype=float), np.asarray(q, dtype=float)
    if t[0] == 0 and np.allclose(q[0], setpoint, rtol=0, atol=1e-9):
        times, positions = t, q
    else:
        shift = period if t[0] == 0 else 0.0
        times = np.concatenate([[0.0], t + shift])
        positions = np.vstack([setpoint, q])
    if len(times) == 1:  # a one-point trajectory already at the set-point: one period to report done
        times, positions = np.array([0.0, period]), np.vstack([positions, positions])
    return Playback(command_id, times, positions)
