"""Locate: per variant × condition (and per phase, where the real side says), the real rate beside the
simulator's on the same trees and conditions, each with its 95 % interval, and which disagree beyond
chance (Fisher's exact test per row, Benjamini–Hochberg over all rows)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from pegbt.sim2real.outcomes.cells import PHASES, Cell
from pegbt.sim2real.outcomes.intervals import beyond_chance, disagreement_p, rate_interval
from pegbt.sim2real.outcomes.likelihood import has_phases
from pegbt.sim2real.outcomes.simulate import Key, SimCounts


@dataclass(frozen=True)
class Row:
    """One comparison: a cell's success rate (`phase` None) or its rate of failing in `phase`."""

    variant: str
    condition: str
    phase: str | None
    real: tuple[int, int]  # (count, attempted)
    simulated: tuple[int, int]
    real_interval: tuple[float, float]
    simulated_interval: tuple[float, float]
    p_value: float
    disagrees: bool

    @property
    def what(self) -> str:
        return "placed" if self.phase is None else f"failed at {self.phase}"


def locate(cells: Sequence[Cell], sims: dict[Key, SimCounts]) -> list[Row]:
    """The comparison rows of every cell the simulator ran."""
    raw: list[tuple[Cell, str | None, tuple[int, int], tuple[int, int]]] = []
    for cell in cells:
        sim = sims[cell.key]
        raw.append((cell, None, (cell.succeeded, cell.attempted), (sim.succeeded, sim.attempted)))
        if has_phases(cell):
            for phase in PHASES:
                real = (cell.failures.get(phase, 0), cell.attempted)
                simulated = (sim.counts[phase], sim.attempted)
                if real[0] or simulated[0]:
                    raw.append((cell, phase, real, simulated))
    p_values = [disagreement_p(real, simulated) for _, _, real, simulated in raw]
    flags = beyond_chance(p_values)
    return [
        Row(
            cell.variant,
            cell.condition,
            phase,
            real,
            simulated,
            rate_interval(*real),
            rate_interval(*simulated),
            p,
            flag,
        )
        for (cell, phase, real, simulated), p, flag in zip(raw, p_values, flags)
    ]
