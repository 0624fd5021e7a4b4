"""The library of candidate physical effects, as regressor columns built from the commands.

Every registered effect kind (`pegbt.physics.effect_kinds()`) says how it enters: a coefficient times a
column computed from one joint's command (offset: a constant; scale: the joint's own command; coupling
and hysteresis: another joint's command), or, for the kinds that act on a joint's whole drive (backlash,
lag, delay), from its *driver*: the static target the simulator computes for it (scale, coupling and
offset applied), so that play or lag acting after a large coupling is modelled as the physics does it.
A kind with a width (play half-width, time constant, delay) gives one column per value of a geometric
grid, so that every candidate is linear given its width and one Gram matrix per data block serves all
fits. Kinds only streams can show (lag, delay) are left out on settled set-points.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pegbt.physics import EffectKind, effect_kinds, kind_of
from pegbt.psm import JOINT_NAMES

Array = NDArray[np.float64]

GRID_SIZE = 12
PLAY_RANGE = (5e-4, 0.25)  # half-widths, as fractions of the source command's range
TIME_RANGE_S = 1.0  # longest lag and delay searched


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
    def effect_kind(self) -> EffectKind:
        return kind_of(self.kind)

    @property
    def has_width(self) -> bool:
        return self.effect_kind.width is not None

    @property
    def label(self) -> str:
        joint, source = JOINT_NAMES[self.joint], JOINT_NAMES[self.source]
        if self.effect_kind.takes_source:
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
    grid = _grid(kind_of(kind), signal, t)
    return float(grid[0]), float(grid[-1])


def _grid(kind: EffectKind, signal: Array, t: Array | None) -> Array:
    if kind.grid == "time":
        assert t is not None, f"{kind.name} needs sample times"
        return time_widths(t)
    return play_widths(signal)


def width_column(kind: str, signal: Array, t: Array | None, width: float) -> Array:
    """The column of a width candidate at any width (used to refine between grid values)."""
    return kind_of(kind).column(signal, t, width)


class Bank:
    """The regressor bank (N, m) as what computes it: the constant, the commands, and each group of width
    columns (a kind on one signal over its grid). Its rows are given a chunk at a time (`blocks`), each
    kind's kernel state carried from one chunk to the next, so the bank is never held whole."""

    def __init__(
        self, q_cmd: Array, t: Array | None, groups: list[tuple[EffectKind, NDArray[np.int64], Array, Array]]
    ) -> None:
        self.q_cmd = q_cmd
        self.t = t
        self.groups = groups  # (kind, bank columns, widths, signal)
        self.shape = (len(q_cmd), 1 + q_cmd.shape[1] + sum(len(g[1]) for g in groups))

    def blocks(self, edges: Sequence[int]) -> Iterator[Array]:
        """The bank's rows edges[k]:edges[k+1], for each k in order."""
        n_joints = self.q_cmd.shape[1]
        kernels = [
            kind.column_blocks(signal, self.t, widths, edges) for kind, _, widths, signal in self.groups
        ]
        for a, b in zip(edges[:-1], edges[1:]):
            rows = np.empty((b - a, self.shape[1]))
            rows[:, 0] = 1.0
            rows[:, 1 : 1 + n_joints] = self.q_cmd[a:b]
            for (_, columns, _, _), kernel in zip(self.groups, kernels):
                rows[:, columns] = next(kernel)
            yield rows


def build_columns(q_cmd: Array, t: Array | None, drivers: Array) -> tuple[Bank, list[Candidate]]:
    """The regressor bank (N, m) and every candidate with its columns; stream-only kinds for streams only.

    `drivers` (N, J) are the joints' static targets; where one equals the joint's command, a driven
    kind's columns are those of a command-driven kind with the same kernel (shared, not repeated).
    """
    n_joints = q_cmd.shape[1]
    kinds = [kind for kind in effect_kinds() if t is not None or not kind.streams_only]
    groups: dict[tuple[str, int], tuple[NDArray[np.int64], Array, Array]] = {}
    computed: list[tuple[EffectKind, tuple[str, int]]] = []  # the groups with columns of their own
    start = 1 + n_joints

    def add(kind: EffectKind, joint: int, signal: Array) -> None:
        nonlocal start
        widths = _grid(kind, signal, t)
        groups[(kind.name, joint)] = (np.arange(start, start + len(widths)), widths, signal)
        computed.append((kind, (kind.name, joint)))
        start += len(widths)

    commanded = [k for k in kinds if k.width is not None and k.signal == "command"]
    for kind in commanded:
        for s in range(n_joints):
            add(kind, s, q_cmd[:, s])
    for j in range(n_joints):
        for kind in (k for k in kinds if k.width is not None and k.signal == "driver"):
            twin = next((c for c in commanded if type(c).column is type(kind).column), None)
            if twin is not None and np.array_equal(drivers[:, j], q_cmd[:, j]):
                groups[(kind.name, j)] = groups[(twin.name, j)]
            else:
                add(kind, j, drivers[:, j])
    bank = Bank(q_cmd, t, [(kind, *groups[key]) for kind, key in computed])
    none = np.array([np.nan])
    candidates: list[Candidate] = []
    for j in range(n_joints):
        for kind in kinds:
            sources = [s for s in range(n_joints) if s != j] if kind.takes_source else [j]
            for s in sources:
                if kind.width is not None:
                    group = groups[(kind.name, s if kind.signal == "command" else j)]
                    candidates.append(Candidate(kind.name, j, s, *group))
                elif kind.is_intercept:
                    candidates.append(Candidate(kind.name, j, s, np.array([0]), none, q_cmd[:, j]))
                else:
                    candidates.append(Candidate(kind.name, j, s, np.array([1 + s]), none, q_cmd[:, s]))
    return bank, candidates
