"""The paper's spline optimisation (its Alg. 2): four joint waypoints joined by cubic Hermite segments.

The grasp and the place start and end at rest. At the two middle waypoints (lifted above the start peg,
above the goal peg) the joint velocity is fixed in direction, the joint motion that moves the tip
straight up (resp. down) along the peg axis with the orientation held, `J⁻¹·(±up, 0)`, and free in
magnitude. For given magnitudes each segment gets the shortest duration its velocity and acceleration
limits allow; the magnitudes are chosen, by a coarse-to-fine grid over both, to minimise the total time.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.motion.jacobian import jacobian
from pegbt.motion.limits import ArmSettings
from pegbt.motion.trajectory import HermitePath, segment_extremes

_GRID_POINTS = 16  # log-spaced durations tried where a velocity limit binds, before bisection
_BISECTIONS = 11  # each halves the gap between grid points (a factor 1.6 at most): 0.03 % at the end
_LONGEST_SEGMENT = 20.0  # s
_MAGNITUDE_GRID = 7
_REFINEMENTS = 4


def joint_direction(q: ArrayLike, tip_direction: ArrayLike) -> NDArray[np.float64]:
    """Joint velocity (6,) moving the tip at unit speed along `tip_direction` without rotating it."""
    twist = np.concatenate([np.asarray(tip_direction, dtype=float), np.zeros(3)])
    J = jacobian(q)
    if np.linalg.cond(J) > 1e8:
        raise PegbtError("the arm is at a singular configuration here", field="waypoint")
    return np.linalg.solve(J, twist)


def shortest_segment_times(
    delta: NDArray[np.float64], v0: NDArray[np.float64], v1: NDArray[np.float64], settings: ArmSettings
) -> NDArray[np.float64]:
    """Shortest duration (N,) of each cubic Hermite segment (rows of the (N, 6) arrays) within the
    planner's velocity and acceleration limits, and at least one control period; inf where none works.

    The acceleration of a cubic is linear, so it peaks at an end, where it is (±6Δ − k·h)/h² with
    k = 4v0 + 2v1 (start) or 2v0 + 4v1 (end). Each |6Δ − k·h| ≤ a_max·h² fails exactly between the
    roots of a quadratic in h, so the shortest duration meeting the acceleration limits is the control
    period or the upper end of one of those gaps, whichever comes first outside all of them. Velocity
    limits rarely bind; where one does there, a grid and bisection above it find the shortest."""
    vmax, amax = settings.planner_velocity, settings.planner_acceleration
    six_delta, start, end = 6 * delta, 4 * v0 + 2 * v1, 2 * v0 + 4 * v1
    gap_low, gap_high = [], []
    for p, q in ((start, -six_delta), (end, -six_delta), (-start, six_delta), (-end, six_delta)):
        discriminant = p * p - 4 * amax * q
        root = np.sqrt(np.maximum(discriminant, 0.0))
        gap_low.append(np.where(discriminant > 0, (-p - root) / (2 * amax), 0.0))
        gap_high.append(np.where(discriminant > 0, (-p + root) / (2 * amax), 0.0))
    low, high = np.concatenate(gap_low, axis=1), np.concatenate(gap_high, axis=1)  # (N, 24) gaps
    candidates = np.concatenate(
        [np.full((len(delta), 1), settings.control_period), np.maximum(high, settings.control_period)], axis=1
    )
    inside = (low[:, None, :] < candidates[:, :, None]) & (candidates[:, :, None] < high[:, None, :])
    shortest = np.min(np.where(inside.any(axis=2), np.inf, candidates), axis=1)

    def feasible(h: NDArray[np.float64], rows: NDArray[np.int64]) -> NDArray[np.bool_]:
        peak_v, peak_a = segment_extremes(delta[rows], v0[rows], v1[rows], h[..., None])
        return np.all((peak_v <= vmax * (1 + 1e-9)) & (peak_a <= amax * (1 + 1e-9)), axis=-1)

    slow = np.flatnonzero(~feasible(shortest, np.arange(len(delta))))
    if slow.size:
        shortest[slow] = _shortest_above(shortest[slow], lambda h: feasible(h, slow))
    return shortest


def _shortest_above(
    low: NDArray[np.float64], feasible: Callable[[NDArray[np.float64]], NDArray[np.bool_]]
) -> NDArray[np.float64]:
    """The shortest feasible durations above the infeasible `low` ones: the first feasible point of a
    log grid up to the longest segment, bisected against the point before it; inf where none is."""
    grid = np.geomspace(low, _LONGEST_SEGMENT, _GRID_POINTS)  # (points, rows)
    ok = feasible(grid)
    first = np.argmax(ok, axis=0)
    columns = np.arange(len(low))
    found = ok[first, columns]
    high, low = grid[first, columns], grid[np.maximum(first - 1, 0), columns]
    for _ in range(_BISECTIONS):
        middle = 0.5 * (low + high)
        good = feasible(middle)
        high, low = np.where(good, middle, high), np.where(good, low, middle)
    return np.where(found, high, np.inf)


def plan_spline(
    waypoints: ArrayLike, lift_direction: ArrayLike, lower_direction: ArrayLike, settings: ArmSettings
) -> HermitePath:
    """Time-minimal cubic spline through four joint `waypoints` (4, 6), passing the middle two with joint
    velocities along `lift_direction` and `lower_direction` (6,) respectively."""
    q = np.asarray(waypoints, dtype=float)
    if q.shape != (4, 6):
        raise PegbtError(f"the spline needs 4 joint waypoints (4, 6), got {q.shape}", field="waypoints")
    directions = np.stack([np.asarray(lift_direction, dtype=float), np.asarray(lower_direction, dtype=float)])
    delta = np.diff(q, axis=0)
    with np.errstate(divide="ignore"):
        top_speed = np.min(settings.planner_velocity / np.abs(directions), axis=1)  # per middle waypoint
    low, high = np.zeros(2), top_speed
    g = _MAGNITUDE_GRID
    best = (np.inf, 0.0, 0.0, (np.inf,) * 3)
    for _ in range(_REFINEMENTS):
        s1 = np.linspace(low[0], high[0], g)
        s2 = np.linspace(low[1], high[1], g)
        v1, v2 = s1[:, None] * directions[0], s2[:, None] * directions[1]
        # One batch: first segments (rest → v1), last (v2 → rest), middle (every v1 → v2 pair).
        starts = np.concatenate([np.zeros((g, 6)), v2, np.repeat(v1, g, axis=0)])
        ends = np.concatenate([v1, np.zeros((g, 6)), np.tile(v2, (g, 1))])
        deltas = np.concatenate(
            [
                np.repeat(delta[[0]], g, axis=0),
                np.repeat(delta[[2]], g, axis=0),
                np.repeat(delta[[1]], g * g, axis=0),
            ]
        )
        durations = shortest_segment_times(deltas, starts, ends, settings)
        first, last, middle = durations[:g], durations[g : 2 * g], durations[2 * g :].reshape(g, g)
        total = first[:, None] + middle + last[None, :]
        i, j = np.unravel_index(np.argmin(total), total.shape)
        if total[i, j] < best[0]:
            best = (total[i, j], s1[i], s2[j], (first[i], middle[i, j], last[j]))
        step = (high - low) / (g - 1)
        low = np.maximum(np.array([best[1], best[2]]) - step, 0.0)
        high = np.minimum(np.array([best[1], best[2]]) + step, top_speed)
    if not np.isfinite(best[0]):
        raise PegbtError(
            "no spline through the transfer waypoints respects the planner limits", field="planner"
        )
    _, speed1, speed2, segment_durations = best
    velocities = np.stack([np.zeros(6), speed1 * directions[0], speed2 * directions[1], np.zeros(6)])
    return HermitePath(np.concatenate([[0.0], np.cumsum(segment_durations)]), q, velocities)
