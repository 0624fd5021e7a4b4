"""One joint's time-optimal motions under velocity and acceleration limits (infinite jerk, as ruckig's with
`max_jerk` infinite): from rest, and between moving states, alone or at their least over intervals of start
velocity, end velocity and distance. `pegbt.bench.limit_bound` and `pegbt.bench.limit_axis` relax an arm's
motion to its joints, each with these times."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


def rest_to_rest_1d(
    distance: NDArray[np.float64], vmax: NDArray[np.float64], amax: NDArray[np.float64]
) -> NDArray[np.float64]:
    """One joint's time-optimal rest-to-rest duration over `distance` ≥ 0 (bang-coast-bang)."""
    short = distance <= vmax**2 / amax
    return np.where(short, 2.0 * np.sqrt(distance / amax), distance / vmax + vmax / amax)


def reach_s(
    distance: NDArray[np.float64],
    velocity: NDArray[np.float64],
    vmax: NDArray[np.float64],
    amax: NDArray[np.float64],
) -> NDArray[np.float64]:
    """One joint's least time from rest to `distance` away, arriving with `velocity` (|velocity| ≤ vmax):
    accelerate and brake (coasting at vmax if it gets there), overshoot and come back to arrive moving
    backwards, or back up first to arrive faster than accelerating all the way allows."""
    flip = distance < 0
    d, v = np.where(flip, -distance, distance), np.where(flip, -velocity, velocity)
    backwards = rest_to_rest_1d(d + v**2 / (2 * amax), vmax, amax) + np.abs(v) / amax
    run_up = rest_to_rest_1d(np.maximum(v**2 / (2 * amax) - d, 0.0), vmax, amax) + np.abs(v) / amax
    peak = np.sqrt(amax * d + v**2 / 2)
    braked = np.where(
        peak <= vmax,
        (2 * peak - v) / amax,
        (2 * vmax - v) / amax + (d - (2 * vmax**2 - v**2) / (2 * amax)) / vmax,
    )
    return np.where(v < 0, backwards, np.where(v**2 <= 2 * amax * d, braked, run_up))


def between_s(distance: Array, start: Array, end: Array, vmax: Array, amax: Array) -> Array:
    """One joint's least time from moving at `start` to `distance` away moving at `end` (|start|, |end| ≤
    vmax): accelerate then brake (a peak, coasting at vmax if it gets there), or brake then accelerate (a
    trough, above zero or through it, coasting at -vmax if it gets there), whichever is possible and quicker."""
    flip = distance < 0
    d = np.abs(distance)
    u, v = np.where(flip, -start, start), np.where(flip, -end, end)
    squares = (u**2 + v**2) / 2
    peak = np.sqrt(amax * d + squares)
    rise = np.where(
        peak <= vmax,
        (2 * peak - u - v) / amax,
        (2 * vmax - u - v) / amax + (d - (2 * vmax**2 - 2 * squares) / (2 * amax)) / vmax,
    )
    rise = np.where(peak >= np.maximum(u, v) - 1e-12, rise, np.inf)
    trough2 = squares - amax * d
    trough = np.sqrt(np.maximum(trough2, 0.0))
    possible = trough2 >= 0
    above = np.where(possible & (trough <= np.minimum(u, v) + 1e-12), (u + v - 2 * trough) / amax, np.inf)
    through_zero = np.where(
        trough <= vmax,
        (u + v + 2 * trough) / amax,
        (u + v + 2 * vmax) / amax + (trough2 - vmax**2) / (amax * vmax),
    )
    below = np.where(possible & (-trough <= np.minimum(u, v) + 1e-12), through_zero, np.inf)
    return np.minimum(rise, np.minimum(above, below))


def _turning(other: Array, distance: Array, amax: Array) -> list[Array]:
    """The velocities at which a joint's least time between moving states, with the other velocity
    `other` and `distance` fixed, changes how it moves (peak or trough meeting a velocity, trough at
    zero): between them each way of moving takes longer monotonically (`least_between`)."""
    reach = 2 * amax * np.abs(distance)
    roots = [np.sqrt(other**2 + reach), np.sqrt(np.maximum(other**2 - reach, 0.0))]
    roots.append(np.sqrt(np.maximum(reach - other**2, 0.0)))
    return [sign * root for root in roots for sign in (-1.0, 1.0)]


def _least_at(
    starts: tuple[Array, Array], ends: tuple[Array, Array], distance: Array, vmax: Array, amax: Array
) -> Array:
    """The least `between_s` over a box of start and end velocities at one distance."""
    (u_lo, u_hi), (v_lo, v_hi) = starts, ends
    times = []
    for u in (u_lo, u_hi):
        for v in (v_lo, v_hi, *_turning(u, distance, amax)):
            times.append(between_s(distance, u, np.clip(v, v_lo, v_hi), vmax, amax))
    for v in (v_lo, v_hi):
        for u in _turning(v, distance, amax):
            times.append(between_s(distance, np.clip(u, u_lo, u_hi), v, vmax, amax))
    still, zero = np.sqrt(2 * amax * np.abs(distance)), np.zeros_like(distance)
    for u, v in ((zero, still), (zero, -still), (still, zero), (-still, zero)):
        times.append(between_s(distance, np.clip(u, u_lo, u_hi), np.clip(v, v_lo, v_hi), vmax, amax))
    return np.min(times, axis=0)


def least_between(
    starts: tuple[Array, Array],
    ends: tuple[Array, Array],
    distances: tuple[Array, Array],
    vmax: Array,
    amax: Array,
) -> Array:
    """The least `between_s` over start velocities, end velocities and distances each in an interval (lo,
    hi). Each way of moving (a peak, a trough above zero, a trough through zero, with or without coasting)
    takes a time monotone in each of the three where it is possible, so the least is on the box's faces
    or where one way gives way to another: the box's faces at the ends of the distances and at zero, each
    searched along its edges at the velocities where the way changes (`_turning`); inside, at the
    distances where it changes for the box's corners and the velocities nearest zero
    (`tests/unit/test_limit_axis.py` checks it against dense sampling)."""
    (u_lo, u_hi), (v_lo, v_hi), (d_lo, d_hi) = starts, ends, distances
    times = [_least_at(starts, ends, d, vmax, amax) for d in (d_lo, d_hi, np.clip(0.0, d_lo, d_hi))]
    zero_u, zero_v = np.clip(0.0, u_lo, u_hi), np.clip(0.0, v_lo, v_hi)
    points = [(u, v) for u in (u_lo, u_hi, zero_u) for v in (v_lo, v_hi, zero_v)]
    for u, v in points:
        for d in (
            (u + v) * np.abs(v - u) / (2 * amax),
            (u**2 - v**2) / (2 * amax),
            (u**2 + v**2) / (2 * amax),
        ):
            for signed in (d, -d):
                times.append(between_s(np.clip(signed, d_lo, d_hi), u, v, vmax, amax))
    return np.min(times, axis=0)
