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
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from pegbt.sim2real.outcomes.cells import PHASES, Cell
from pegbt.sim2real.outcomes.intervals import beyond_chance, disagreement_p
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
    placed = [
        disagreement_p((c.succeeded, c.attempted), (sims[c.key].succeeded, sims[c.key].attempted))
        for c in fit_cells
    ]
    loud = [c for c, flag in zip(fit_cells, beyond_chance(placed)) if flag]
    if not phases:
        return Gate(tuple(c.key for c in loud), None)
    rows: list[tuple[str, float]] = []
    for cell in (c for c in loud if has_phases(c)):
        sim = sims[cell.key]
        for phase in PHASES:
            real, simulated = cell.failures.get(phase, 0), sim.counts[phase]
            if real or simulated:
                p = disagreement_p((real, cell.attempted), (simulated, sim.attempted))
                rows.append((phase, p))
    flagged = frozenset(phase for (phase, _), flag in zip(rows, beyond_chance([p for _, p in rows])) if flag)
    return Gate(tuple(c.key for c in loud), flagged or None)
