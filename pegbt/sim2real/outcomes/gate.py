"""Whether the fit runs, on which cells, and with which kinds: a hierarchical (gatekeeping) test.

The primary family is one test per fit cell, its placed rate against the default world's (Fisher's exact
test, Benjamini–Hochberg over the fit cells' placed rows alone): the fit runs if one rejects, on the cells
that reject. A benchmark sizes a campaign by this gate's own test (`pegbt.bench.outcomes_power`: a change
at α over the testable rows of its family, nine times in ten); judging the placed rate together with every phase row
(six rows a unilateral fit) asked for several times that evidence (chamfer capture at 1,104 real: placed
p = 0.014, sense p = 0.020, no fit). The phase rows of the cells that pass form the secondary family
(Benjamini–Hochberg over them alone), read only to say where the cell disagrees: which kinds the fit
profiles (`fit.PHASES_OF`); if none rejects, every kind is. Gatekeeping keeps the secondary family's
errors inside the primary's (Dmitrienko, Offen & Westfall 2003, Stat. Med. 22:2387), and a candidate is
still named only past the fit's own χ² test, its leave-one-out gain and the replication on fresh seeds.

A row that cannot disagree whatever the world (every transfer placed on both sides, as a calibrated
cell's are) is not counted among the many (Tarone's rule for discrete tests: Tarone 1990, Biometrics
46:515; Gilbert 2005 for the false discovery rate): with it, BH over two fit cells asked the one cell that
can differ for p ≤ 0.025, twice what the power analysis sized for (chamfer capture at 816: p = 0.043, shut).

A world can move failures from one phase to another and place as many (a depth bias: grasps that failed
now fail at the lift), which no placed rate shows. So when the primary family rejects nothing, every fit
cell's phase rows are a family of their own (Benjamini–Hochberg over them alone), and the fit runs on the
cells they flag, with the kinds of the phases they flag. On a world the simulator already has, that opens
a fit at most about 5 % more often; what it may then name still has to pass the three tests above.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from pegbt.sim2real.outcomes.cells import Cell
from pegbt.sim2real.outcomes.intervals import beyond_chance_testable, least_p
from pegbt.sim2real.outcomes.locate import Row, locate
from pegbt.sim2real.outcomes.simulate import Key, SimCounts


@dataclass(frozen=True)
class Gate:
    """The fit cells whose placed rate disagrees (`loud`, in the fit cells' order) and the phases that
    disagree in them (None: phases unknown, or none beyond chance, so every kind is profiled)."""

    loud: tuple[Key, ...]
    phases: frozenset[str] | None

    @property
    def opens(self) -> bool:
        return bool(self.loud)


def gate(fit_cells: Sequence[Cell], sims: dict[Key, SimCounts], phases: bool = True) -> Gate:
    """The gate of the fit cells' real counts against the default world's `sims` (the rows `locate`
    compares, judged here family by family)."""
    rows = locate(fit_cells, sims)
    placed = [r for r in rows if r.phase is None]
    loud = {(r.variant, r.condition) for r in _flagged(placed)}
    keys = [c.key for c in fit_cells]
    if not phases:
        return Gate(tuple(k for k in keys if k in loud), None)
    phase_rows = [r for r in rows if r.phase is not None and (not loud or (r.variant, r.condition) in loud)]
    flagged = _flagged(phase_rows)
    where = frozenset(r.phase for r in flagged if r.phase) or None
    if not loud:
        loud = {(r.variant, r.condition) for r in flagged}
    return Gate(tuple(k for k in keys if k in loud), where)


def _flagged(rows: list[Row]) -> list[Row]:
    """The rows beyond chance, Benjamini–Hochberg over those of `rows` that can reject."""
    flags = beyond_chance_testable([r.p_value for r in rows], [least_p(r.real, r.simulated) for r in rows])
    return [row for row, flag in zip(rows, flags) if flag]
