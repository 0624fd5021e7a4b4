"""Collect a calibration recording from an arm: random smooth set-points, commanded against physical joints.

The motion imitates the dVRK recordings the models were designed on: every joint sweeps its whole range
back and forth along a smooth random path (a monotone cubic through random values a few set-points
apart), so each cable's hysteresis is driven through many loops of many sizes. The arm moves to each
set-point along a straight line in joint space (so every cable's input moves one way only, and the
sample depends on the set-points alone, as a set-point model assumes), settles, and then the set-point
and the physical joints (`fiducial_js`) are recorded, like the paper's camera after 0.3 s of settling.

`collect` runs it end to end over an `ArmClient` and writes the dataset layout with `RecordingWriter`;
its parts (`random_setpoints`, `straight_move`, `RecordingWriter.add`) are what a behaviour-tree leaf of
the `pegbt calibrate collect` tree does one tick at a time.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pegbt.errors import PegbtError
from pegbt.motion.limits import ArmSettings
from pegbt.physics.recording import RecordingWriter
from pegbt.transport import ArmClient, Clock
from pegbt.transport.codec import TrajectoryLike, TrajectoryPoints

Array = NDArray[np.float64]
KNOT_SPACING = (6, 16)  # set-points between the random values a joint's path passes through
SETTLE_S = 0.3  # as the dVRK recordings: the arm rests this long before a sample is taken
SPEED_SHARE = 0.5  # straight moves use this share of the planner's velocity limits
MOVE_TIMEOUT_S = 10.0
ESTIMATE_COUNT = 500  # set-points whose moves `setpoints_for_minutes` averages


def _box(lower: ArrayLike, upper: ArrayLike, count: int) -> tuple[Array, Array]:
    """The box as arrays, checked to hold `count` >= 2 set-points."""
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    if count < 2 or np.any(upper <= lower):
        raise PegbtError(
            f"need at least 2 set-points in a non-empty box, got {count} in {lower}..{upper}", field="count"
        )
    return lower, upper


def random_setpoints(lower: ArrayLike, upper: ArrayLike, count: int, rng: np.random.Generator) -> Array:
    """`count` smooth random set-points (count, 6) inside [lower, upper], each joint reversing often."""
    from scipy.interpolate import PchipInterpolator

    lower, upper = _box(lower, upper, count)
    points = np.empty((count, len(lower)))
    index = np.arange(count)
    for j in range(len(lower)):
        spacing = rng.uniform(*KNOT_SPACING)
        knots = np.arange(-spacing * rng.uniform(), count + 2 * spacing, spacing)
        values = rng.uniform(lower[j], upper[j], len(knots))
        points[:, j] = PchipInterpolator(knots, values)(index)  # monotone cubic: never outside the values
    return points


def spread_setpoints(lower: ArrayLike, upper: ArrayLike, count: int, rng: np.random.Generator) -> Array:
    """`count` set-points (count, 6) inside [lower, upper] that each span nearly all of every joint's range
    (a Latin hypercube: one set-point in each of `count` slices of every joint, in random order), for a
    refit: a few set-points along a smooth path often leave a joint in a corner of its range, where no
    gain can be identified (`pegbt.calibration.refit.MIN_SPAN`)."""
    from scipy.stats import qmc

    lower, upper = _box(lower, upper, count)
    unit = qmc.LatinHypercube(d=len(lower), rng=rng).random(count)
    return np.asarray(qmc.scale(unit, lower, upper), dtype=float)


DESIGNS = {"smooth": random_setpoints, "spread": spread_setpoints}  # how a collection picks its set-points


def move_seconds(start: ArrayLike, goal: ArrayLike, settings: ArmSettings) -> NDArray[np.float64]:
    """How long the straight move from `start` to `goal` takes (whole control periods; batches of rows too)."""
    start, goal = np.asarray(start, dtype=float), np.asarray(goal, dtype=float)
    period = settings.control_period
    seconds = np.max(np.abs(goal - start) / (SPEED_SHARE * settings.planner_velocity), axis=-1)
    return period * np.maximum(1, np.ceil(seconds / period))


def straight_move(start: ArrayLike, goal: ArrayLike, settings: ArmSettings) -> TrajectoryPoints:
    """A straight line in joint space from `start` to `goal`, at `SPEED_SHARE` of the planner velocity.

    The endpoint plays a trajectory linearly between its samples from the current set-point, so the goal
    alone at the end time is the whole line."""
    goal = np.asarray(goal, dtype=float)
    return TrajectoryPoints(np.array([float(move_seconds(start, goal, settings))]), goal[None])


def setpoints_for_minutes(minutes: float, arm: str, seed: int = 0) -> tuple[int, float]:
    """How many set-points a collection of `minutes` of arm time holds, and the seconds each takes on average.

    Each set-point costs its straight move plus `SETTLE_S`; the moves are measured on `ESTIMATE_COUNT`
    set-points drawn as the collection draws them (same arm box, same seed), so the count is an estimate
    of the arm's time, not of the wall clock (a lockstep simulator runs faster)."""
    from pegbt.calibration.task import task_box
    from pegbt.motion.limits import arm_settings

    points = random_setpoints(*task_box(arm), ESTIMATE_COUNT, np.random.default_rng(seed))
    step = float(np.mean(move_seconds(points[:-1], points[1:], arm_settings(arm)))) + SETTLE_S
    return max(2, int(minutes * 60.0 / step)), step


def move_and_settle(
    client: ArmClient, clock: Clock, trajectory: TrajectoryLike, settle_s: float = SETTLE_S
) -> None:
    """Send `trajectory`, let simulated or real time pass until it is done, then rest `settle_s`."""
    handle = client.move_jp(trajectory)
    clock.wait(float(np.asarray(trajectory.t)[-1]))
    deadline = clock.now() + MOVE_TIMEOUT_S
    while handle.busy and clock.now() < deadline:
        clock.wait(client.settings.control_period)
    if not handle.done:
        raise PegbtError(f"{client.name}: {handle.error or 'move did not finish'}", field="move_jp")
    clock.wait(settle_s)


def collect(
    client: ArmClient,
    clock: Clock,
    out: str | Path,
    count: int,
    seed: int = 0,
    box: tuple[ArrayLike, ArrayLike] | None = None,
) -> Path:
    """Drive `client`'s arm through `count` random smooth set-points and write the recording to `out`.

    `box` (lower, upper) bounds the set-points; by default the peg-transfer task's joints
    (`pegbt.calibration.task.task_box`)."""
    from pegbt.calibration.task import task_box

    lower, upper = box if box is not None else task_box(client.name)
    setpoints = random_setpoints(lower, upper, count, np.random.default_rng(seed))
    writer = RecordingWriter(out, client.name)
    current = client.setpoint_js.position
    for goal in setpoints:
        move_and_settle(client, clock, straight_move(current, goal, client.settings))
        current = client.setpoint_js.position
        writer.add(current, client.fiducial_js.position, clock.now())
    return writer.close()
