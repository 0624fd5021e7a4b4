"""How likely the real counts of a cell are under a simulated world, simulation noise included.

With failures per phase (tick logs, a table that gives them) a cell is a multinomial over `CATEGORIES`
(placed, or failed first in a phase) and the simulated counts give it a Dirichlet posterior (Jeffreys);
with only attempted and succeeded it is the beta-binomial of the same. Phases tell apart effects that act
on different phases (a bending peg on the lift, chamfers on the lowering); a bare count cannot.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.intervals import count_log_likelihood
from pegbt.sim2real.outcomes.simulate import CATEGORIES, SimCounts


def has_phases(cell: Cell) -> bool:
    """Whether `cell` says where every failed transfer failed (in phases the simulator tells apart)."""
    known = set(cell.failures) <= set(CATEGORIES[1:])
    return bool(cell.failures) and known and sum(cell.failures.values()) == cell.attempted - cell.succeeded


def real_vector(cell: Cell) -> np.ndarray:
    """The cell's counts per category (placed first)."""
    return np.array([cell.succeeded, *(cell.failures.get(c, 0) for c in CATEGORIES[1:])], dtype=float)


def log_likelihood(cell: Cell, sim: SimCounts, phases: bool = True) -> float:
    """log P(the cell's real counts | `sim`), by phase when the cell has them and `phases`. Failures at
    `sense` count as the others do: the phase simulator's way back finds a peg empty where the way out lost
    its block, as a trial does."""
    return vector_log_likelihood(cell, sim.vector(), phases)


def vector_log_likelihood(cell: Cell, simulated: np.ndarray, phases: bool = True) -> float:
    """`log_likelihood` from the simulated counts per category (placed first; fractional counts, as an
    interpolation between simulated worlds gives, are weighed as counts)."""
    if cell.attempted == 0:
        return 0.0
    if phases and has_phases(cell):
        alpha = simulated + 0.5
        return float(stats.dirichlet_multinomial.logpmf(real_vector(cell), alpha, np.array(cell.attempted)))
    return count_log_likelihood(cell.succeeded, cell.attempted, float(simulated[0]), float(simulated.sum()))
