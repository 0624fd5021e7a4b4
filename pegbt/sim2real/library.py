"""The library of candidate physical effects, as regressor columns built from the commands.

Every effect enters as a coefficient times a column computed from one joint's command, or, for the
effects that act on a joint's whole drive (backlash, lag, delay), from its *driver*: the static target
the simulator computes for it (scale, coupling and offset applied), so that play or lag acting after a
large coupling is modelled as the physics does it:

| candidate | column | becomes the effect |
|---|---|---|
| offset | 1 | `offset` {value} |
| scale | own command | `scale` {value} |
| coupling from s | command of s | `coupling` {source, k} |
| hysteresis from s | play(command of s, h) − command of s | `hysteresis` {source, half_width, k} |
| backlash | play(driver, h) − driver | `backlash` {half_width}, or own `hysteresis` if only part shows |
| lag | lag(driver, τ) − driver | `lag` {tau} (streams only) |
| delay | driver τ later − driver | `delay` {seconds} (streams only) |

Widths (h, τ, delay) are searched on a geometric grid, one column per grid value, so that every
candidate is linear given its width and one Gram matrix per data block serves all fits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pegbt.psm import JOINT_NAMES
from pegbt.physics.kernels import delay_series, lag_series, play_grid

Array = NDArray[np.float64]

GRID_SIZE = 12
PLAY_RANGE = (5e-4, 0.25)  # half-widths, as fractions of the source command's range
TIME_RANGE_S = 1.0  # longest lag and delay searched
WIDTH_KINDS = ("hysteresis", "backlash", "lag", "delay")
DRIVEN_KINDS = ("backlash", "lag", "delay")  # act on the joint's driver, not on a raw command


@dataclass(frozen=True)
class Candidate:
    """One effect that might be missing on `joint`, driven by `source`'s command, with its bank columns."""

    kind: str
    joint: int
    source: int
    columns: NDArray[np.int64]
    widths: Array
    signal: Array  # what a width column is computed from: the source's command, or the joint's driver

    @property
    def key(self) -> tuple[str, int, int]:
        return (self.kind, self.joint, self.source)

    @property
    def has_width(self) -> bool:
        return self.kind in WIDTH_KINDS

    @property
    def label(self) -> str:
        joint, source = JOINT_NAMES[self.joint], JOINT_NAMES[self.source]
        if self.kind in ("coupling", "hysteresis"):
            return f"{self.kind} {source}→{joint}"
        return f"{self.kind} on {joint}"


def play_widths(command: Array, size: int = GRID_SIZE) -> Array:
    """Half-widths to search for play driven by this command, scaled to how far it moves."""
    span = float(np.percentile(command, 99) - np.percentile(command, 1)) or float(np.ptp(command)) or 1.0
    return span * np.geomspace(*PLAY_RANGE, size)


def time_widths(t: Array, size: int = GRID_SIZE) -> Array:
    """Lags and delays to search, from a fifth of a sample interval to a second (or a tenth of the record)."""
    dt = float(np.median(np.diff(t)))
    longest = min(TIME_RANGE_S, 0.1 * float(t[-1] - t[0]))
    return np.geomspace(0.2 * dt, max(longest, dt), size)


def width_bounds(kind: str, signal: Array, t: Array | None) -> tuple[float, float]:
    """The widths a candidate may take: its grid's span (a play wider than a quarter of the motion acts
    like a scale change, not play)."""
    grid = play_widths(signal) if kind in ("hysteresis", "backlash") else time_widths(t)
    return float(grid[0]), float(grid[-1])


def play_column(command: Array, half_width: float) -> Array:
    return play_grid(command, half_width)[:, 0] - command


def lag_column(command: Array, t: Array, tau: float) -> Array:
    return lag_series(command, t, tau) - command


def delay_column(command: Array, t: Array, seconds: float) -> Array:
    return delay_series(command, t, seconds) - command


def width_column(kind: str, signal: Array, t: Array | None, width: float) -> Array:
    """The column of a width candidate at any width (used to refine between grid values)."""
    if kind in ("hysteresis", "backlash"):
        return play_column(signal, width)
    assert t is not None, f"{kind} needs sample times"
    return lag_column(signal, t, width) if kind == "lag" else delay_column(signal, t, width)


def build_columns(q_cmd: Array, t: Array | None, drivers: Array) -> tuple[Array, list[Candidate]]:
    """The regressor bank (N, m) and every candidate with its columns; lag and delay only for streams.

    `drivers` (N, J) are the joints' static targets; where one equals the joint's command, its
    backlash columns are the command's play columns (shared, not repeated).
    """
    n_joints = q_cmd.shape[1]
    blocks: list[Array] = [np.ones((len(q_cmd), 1)), q_cmd]
    groups: dict[tuple[str, int], tuple[NDArray[np.int64], Array, Array]] = {}
    start = 1 + n_joints

    def add(kind: str, joint: int, widths: Array, signal: Array) -> None:
        nonlocal start
        blocks.append(
            np.column_stack([width_column(kind, signal, t, w) for w in widths])
            if kind in ("lag", "delay")
            else play_grid(signal, widths) - signal[:, None]
        )
        groups[(kind, joint)] = (np.arange(start, start + len(widths)), widths, signal)
        start += len(widths)

    for s in range(n_joints):
        add("hysteresis", s, play_widths(q_cmd[:, s]), q_cmd[:, s])
    for j in range(n_joints):
        driver = drivers[:, j]
        if np.array_equal(driver, q_cmd[:, j]):
            groups[("backlash", j)] = groups[("hysteresis", j)]
        else:
            add("backlash", j, play_widths(driver), driver)
        if t is not None:
            add("lag", j, time_widths(t), driver)
            add("delay", j, time_widths(t), driver)
    none = np.array([np.nan])
    candidates: list[Candidate] = []
    for j in range(n_joints):
        candidates.append(Candidate("offset", j, j, np.array([0]), none, q_cmd[:, j]))
        candidates.append(Candidate("scale", j, j, np.array([1 + j]), none, q_cmd[:, j]))
        candidates += [
            Candidate("coupling", j, s, np.array([1 + s]), none, q_cmd[:, s])
            for s in range(n_joints)
            if s != j
        ]
        candidates += [
            Candidate("hysteresis", j, s, *groups[("hysteresis", s)]) for s in range(n_joints) if s != j
        ]
        kinds = ("backlash", "lag", "delay") if t is not None else ("backlash",)
        candidates += [Candidate(kind, j, j, *groups[(kind, j)]) for kind in kinds]
    return np.column_stack(blocks), candidates
