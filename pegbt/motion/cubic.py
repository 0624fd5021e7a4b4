"""Rest-to-rest cubic trajectories: the paper's "unoptimised" baseline, and plain joint moves.

Each segment is a cubic that starts and ends at rest, as short as the per-joint planner limits allow:
a rest-to-rest cubic over displacement Δ in time T peaks at 1.5Δ/T in velocity and 6Δ/T² in
acceleration, so T = max over joints of max(1.5|Δ|/v_max, √(6|Δ|/a_max)).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.motion.limits import ArmSettings
from pegbt.motion.trajectory import HermitePath, Trajectory


def checked_waypoints(
    waypoints: ArrayLike, settings: ArmSettings, names: list[str] | None = None
) -> NDArray[np.float64]:
    """Joint `waypoints` as a (K, 6) array of at least two rows, each within the arm's limits (an error
    names the row by `names`, else by its index)."""
    q = np.asarray(waypoints, dtype=float)
    if q.ndim != 2 or q.shape[1] != 6 or len(q) < 2:
        raise PegbtError(
            f"expected at least two joint waypoints of shape (K, 6), got {q.shape}", field="waypoints"
        )
    for name, row in zip(names or [f"waypoint {i}" for i in range(len(q))], q):
        settings.require_within(row, name)
    return q


def rest_to_rest_path(
    waypoints: ArrayLike, settings: ArmSettings, names: list[str] | None = None
) -> HermitePath:
    """Cubic segments through joint `waypoints` (K, 6), stopping at each; `names` label them in errors."""
    q = checked_waypoints(waypoints, settings, names)
    delta = np.abs(np.diff(q, axis=0))
    durations = np.max(
        np.maximum(
            1.5 * delta / settings.planner_velocity, np.sqrt(6 * delta / settings.planner_acceleration)
        ),
        axis=1,
    )
    durations = np.maximum(durations, settings.control_period)  # coincident waypoints still take one period
    times = np.concatenate([[0.0], np.cumsum(durations)])
    return HermitePath(times, q, np.zeros_like(q))


def joint_move(q_from: ArrayLike, q_to: ArrayLike, settings: ArmSettings) -> Trajectory:
    """The fastest rest-to-rest cubic from `q_from` to `q_to`, sampled at the control period (approach
    and retreat moves)."""
    return rest_to_rest_path(np.stack([q_from, q_to]), settings, ["start", "goal"]).sample(
        settings.control_period
    )
