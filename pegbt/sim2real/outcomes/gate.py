"""Whether the fit runs, on which cells, and with which kinds: a hierarchical (gatekeeping) test.

The primary family is one test per fit cell, its placed rate against the default world's (Fisher's exact
test, Benjamini–Hochberg over the fit cells' placed rows alone): the fit runs if one rejects, on the cells
that reject. A benchmark sizes a campaign so that one 5 % test sees its largest change nine times in ten
(`pegbt.bench.sim2real_outcomes.detectable_at`); judging the placed rate together with every phase row
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

from pegbt.sim2real.outcomes.cells import PHASES, Cell
from pegbt.sim2real.outcomes.intervals import beyond_chance_testable, disagreement_p, least_p
from pegbt.sim2real.outcomes.likelihood import has_phases
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
    """The gate of the fit cells' real counts against the default world's `sims`."""
    pairs = [((c.succeeded, c.attempted), (sims[c.key].succeeded, sims[c.key].attempted)) for c in fit_cells]
    placed = [disagreement_p(*pair) for pair in pairs]
    least = [least_p(*pair) for pair in pairs]
    loud = [c for c, flag in zip(fit_cells, beyond_chance_testable(placed, least)) if flag]
    if not phases:
        return Gate(tuple(c.key for c in loud), None)
    if loud:
        rows = _phase_rows(loud, sims)
        flagged = _flagged(rows)
        return Gate(tuple(c.key for c in loud), frozenset(phase for _, phase in flagged) or None)
    flagged = _flagged(_phase_rows(fit_cells, sims))
    keys = {key for key, _ in flagged}
    return Gate(
        tuple(c.key for c in fit_cells if c.key in keys), frozenset(phase for _, phase in flagged) or None
    )


def _phase_rows(cells: Sequence[Cell], sims: dict[Key, SimCounts]) -> list[tuple[Key, str, float, float]]:
    """Each cell's phase rows (cells with phases; phases neither side failed in left out): its key, the
    phase, the p-value of its real failures there against the default world's and the least it could be."""
    rows: list[tuple[Key, str, float, float]] = []
    for cell in (c for c in cells if has_phases(c)):
        sim = sims[cell.key]
        for phase in PHASES:
            real, simulated = cell.failures.get(phase, 0), sim.counts[phase]
            if real or simulated:
                pair = ((real, cell.attempted), (simulated, sim.attempted))
                rows.append((cell.key, phase, disagreement_p(*pair), least_p(*pair)))
    return rows


def _flagged(rows: list[tuple[Key, str, float, float]]) -> list[tuple[Key, str]]:
    """The rows beyond chance, Benjamini–Hochberg over those of `rows` that can reject."""
    flags = beyond_chance_testable([r[2] for r in rows], [r[3] for r in rows])
    return [(key, phase) for (key, phase, _, _), flag in zip(rows, flags) if flag]
