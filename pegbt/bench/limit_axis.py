"""The handover's rendezvous in `pegbt bench limit`'s bound, with the receiver's jaw entering the block's
hole only once the block is on its final axis.

A jaw in a block's hole can move only along the hole's axis (`pegbt.bench.limit_bound`): the receiver's open
jaw enters the hole as its tip passes the plane of the block's top, and a block still moving sideways would
strike it there. So at the moment τ the receiver's tip first reaches the block's top, the block is on the
axis it ends on, some height s above where it ends (s < 0: below, to come up the axis), and the receiver's
tip is there too: s above the block's final top over its grasp. From τ on the block moves only along that
axis, so the giver's tip does; the receiver's tip stays in the hole and comes to rest at its grasp no
sooner than its least time from passing that point to rest there (`pass_s`, every joint at its own best).
Before τ the giver has lifted the block clear of its peg. The giver's motion is relaxed joint by joint with
the times its joints share (`on_axis_s`): from rest at its grasp, each joint passes its lift value at a (at
a velocity it can reach from rest by then), its value on the axis a + b (at a velocity from which it can
stop at the meeting point within c, `least_between` for the time between) and is at rest at the meeting
point at a + b + c, with c no shorter than the receiver's descent from the axis point. Every handover
meets these conditions, so the least a + b + c is never above what a dVRK with these limits achieves; the
bound without them lets the receiver rest at its grasp when the giver comes to rest, its tip having passed
the block's top while the giver's block was still anywhere.

The height s is not known: the axis is split into `CELL` lengths, each joint of each arm bounded over a cell
by the least and greatest value it takes there (sampled `CELL_SAMPLES` times a cell; a joint is monotone
over a millimetre of the axis), and the bound is the least over the cells; beyond `SPAN` either way, the
giver still passes the axis at ±`SPAN` on its way along it to the meeting point, with no floor on c. The
times a and c are searched on a grid of cells refined where the least may lie, each cell's value taken at
its lower corner's times with the upper corner's sets of velocities (larger: a relaxation), so the result
is rounded down.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pegbt.bench.limit_joint import least_between, reach_s

CELL = 0.001  # m of the meeting axis per cell
CELL_SAMPLES = 10  # joints sampled per cell, its ends shared with its neighbours
SPAN = 0.02  # m above and below the meeting point covered by cells
GRID = (12, 6)  # cells of the times a (lift) and c (to rest) per axis cell in the first round
SPAN_S = (1.5, 1.0)  # seconds of a and of c past their least that the grid covers; beyond, their tails
SPLIT = 3  # each cell split again into SPLIT × SPLIT
KEEP = 128  # cells split again per round: those with the least lower bounds
ROUNDS = 8
BISECTIONS = 30

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Limits:
    """One arm's planner limits per joint."""

    vmax: Array
    amax: Array


def _interval(
    fn: Callable[[Array], Array], best: Array, times: Array, limits: Limits
) -> tuple[Array, Array, NDArray[np.bool_]]:
    """Per row's time t and per joint, the velocities x with fn(x) ≤ t: an interval round `best`, fn's least
    (fn falls to it and rises after), each end at the outer end of its bisection bracket (wider: a
    relaxation); and where it is empty (t below fn's least)."""
    column = times[:, None]
    shape = (len(times), len(limits.vmax))
    ends = []
    for limit in (-limits.vmax, limits.vmax):
        edge = np.broadcast_to(limit, shape)
        outside, inside = edge.copy(), np.broadcast_to(best, shape).copy()
        for _ in range(BISECTIONS):
            middle = (outside + inside) / 2
            reached = fn(middle) <= column
            inside, outside = np.where(reached, middle, inside), np.where(reached, outside, middle)
        ends.append(np.where(fn(edge) <= column, edge, outside))
    return ends[0], ends[1], fn(np.broadcast_to(best, shape)) > column


def _best(distance: Array, limits: Limits) -> Array:
    """The velocity of the quickest way from rest to `distance` away: its least `reach_s`."""
    return np.sign(distance) * np.minimum(np.sqrt(2 * limits.amax * np.abs(distance)), limits.vmax)


class _Chain:
    """The giver's relaxed motion for given cells of the axis: rest at `start`, `lift` at a, within the
    cell's bounds (`low`, `high`, per cell and joint) at a + b, rest at `goal` at a + b + c."""

    def __init__(
        self, start: Array, lift: Array, low: Array, high: Array, goal: Array, limits: Limits
    ) -> None:
        self.lift, self.low, self.high, self.goal, self.limits = lift, low, high, goal, limits
        self.rise = lift - start
        self.at_lift = float(np.max(reach_s(self.rise, _best(self.rise, limits), limits.vmax, limits.amax)))
        nearest = np.clip(goal, low, high)
        self.best_end = _best(goal - nearest, limits)
        self.to_rest = np.max(self._stop_s(self.best_end, low, high), axis=1)

    def _stop_s(self, velocity: Array, low: Array, high: Array) -> Array:
        """The least time from passing the cell at `velocity` to rest at the goal: from where braking
        straight stops at the goal, clipped to the cell (the time rises either side of it)."""
        amax = self.limits.amax
        where = np.clip(self.goal - velocity * np.abs(velocity) / (2 * amax), low, high)
        return reach_s(where - self.goal, -velocity, self.limits.vmax, amax)

    def middle_s(self, a: Array, c: Array, cell: NDArray[np.intp]) -> Array:
        """Per row, the least b for all joints at lift time `a` and time to rest `c` in axis cell `cell`
        (infinite where a joint cannot reach its lift by a, or stop from the cell within c)."""
        limits = self.limits
        low, high = self.low[cell], self.high[cell]
        u_low, u_high, no_u = _interval(
            lambda u: reach_s(self.rise, u, limits.vmax, limits.amax), _best(self.rise, limits), a, limits
        )
        v_low, v_high, no_v = _interval(lambda v: self._stop_s(v, low, high), self.best_end[cell], c, limits)
        b = least_between(
            (u_low, u_high), (v_low, v_high), (low - self.lift, high - self.lift), limits.vmax, limits.amax
        )
        return np.max(np.where(no_u | no_v, np.inf, b), axis=1)


def on_axis_s(
    start: Array, lift: Array, low: Array, high: Array, goal: Array, after: Array, limits: Limits
) -> float:
    """The least time from rest at `start` (the giver's grasp), through `lift`, through the axis within one
    of the cells (`low`, `high`: each joint's bounds per cell) to rest at `goal` (the meeting point), at
    least `after` (per cell) after the axis; rounded down."""
    chain = _Chain(start, lift, low, high, goal, limits)
    cells = np.arange(len(low))
    c_least = np.maximum(after, chain.to_rest)
    a_least = np.full(len(low), chain.at_lift)
    # beyond the grid in a or in c, a cell's time is at least its grid's end in one and its least in the other
    settled = float(np.min(np.minimum(a_least + SPAN_S[0] + c_least, a_least + c_least + SPAN_S[1])))
    steps = np.array(SPAN_S) / np.array(GRID)
    a_index, c_index = np.meshgrid(np.arange(GRID[0]), np.arange(GRID[1]), indexing="ij")
    cell = np.repeat(cells, a_index.size)
    a = a_least[cell] + np.tile(a_index.ravel(), len(cells)) * steps[0]
    c = c_least[cell] + np.tile(c_index.ravel(), len(cells)) * steps[1]
    reached = np.inf
    for _ in range(ROUNDS):
        lows = a + c + chain.middle_s(a + steps[0], c + steps[1], cell)
        reached = min(reached, float(np.min(a + c + chain.middle_s(a, c, cell))))
        split = lows < min(reached, np.sort(lows)[min(KEEP, lows.size) - 1] + 1e-12)
        settled = min([settled, *lows[~split]])
        if not split.any():
            return settled
        steps = steps / SPLIT
        a_offset, c_offset = (
            offsets.ravel()
            for offsets in np.meshgrid(*[np.arange(SPLIT) * step for step in steps], indexing="ij")
        )
        a = (a[split][:, None] + a_offset).ravel()
        c = (c[split][:, None] + c_offset).ravel()
        cell = np.repeat(cell[split], SPLIT * SPLIT)
    return min(settled, float(np.min(a + c + chain.middle_s(a + steps[0], c + steps[1], cell))))
