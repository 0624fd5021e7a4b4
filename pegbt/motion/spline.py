"""The paper's spline optimisation (its Alg. 2): four joint waypoints joined by cubic Hermite segments.

The grasp and the place start and end at rest. At the two middle waypoints (lifted above the start peg,
above the goal peg) the joint velocity is fixed in direction, the joint motion that moves the tip
straight up (resp. down) along the peg axis with the orientation held, `J⁻¹·(±up, 0)`, and free in
magnitude. For given magnitudes each segment gets the shortest duration its velocity and acceleration
limits allow; the magnitudes are chosen, by a coarse-to-fine grid over both, to minimise the total time.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.motion.jacobian import jacobian
from pegbt.motion.limits import ArmSettings
from pegbt.motion.trajectory import HermitePath, segment_extremes

_GRID_POINTS = 16  # log-spaced candidate durations per segment before bisection
_BISECTIONS = 11  # each halves the gap between grid points (a factor 1.6): 0.03 % at the end
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
    planner's velocity and acceleration limits; inf where no duration works."""
    vmax, amax = settings.planner_velocity, settings.planner_acceleration

    def feasible(h: NDArray[np.float64]) -> NDArray[np.bool_]:
        peak_v, peak_a = segment_extremes(delta, v0, v1, h[..., None])
        return np.all((peak_v <= vmax * (1 + 1e-9)) & (peak_a <= amax * (1 + 1e-9)), axis=-1)

    grid = np.geomspace(settings.control_period, _LONGEST_SEGMENT, _GRID_POINTS)
    ok = feasible(np.broadcast_to(grid[:, None], (_GRID_POINTS, len(delta))))
    first = np.argmax(ok, axis=0)
    found = ok[first, np.arange(len(delta))]
    high = grid[first]
    low = np.where(first > 0, grid[np.maximum(first - 1, 0)], high)
    for _ in range(_BISECTIONS):
        middle = 0.5 * (low + high)
        good = feasible(middle)
        high = np.where(good, middle, high)
        low = np.where(good, low, middle)
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
        deltas = np.concatenate([np.repeat(delta[[0]], g, axis=0), np.repeat(delta[[2]], g, axis=0), np.repeat(delta[[1]], g * g, axis=0)])
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
        raise PegbtError("no spline through the transfer waypoints respects the planner limits", field="planner")
    _, speed1, speed2, durations = best
    velocities = np.stack([np.zeros(6), speed1 * directions[0], speed2 * directions[1], np.zeros(6)])
    return HermitePath(np.concatenate([[0.0], np.cumsum(durations)]), q, velocities)
