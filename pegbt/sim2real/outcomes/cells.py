"""One cell of outcomes: a task variant under one condition, its transfers attempted and placed, and
where the failed ones failed."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from pegbt.executive.phases import PHASES as PHASES  # the phases of a failure, as a tick log tells them


@dataclass(frozen=True)
class Cell:
    """Transfers of one variant × condition: `attempted`, `succeeded`, optionally their mean time (s)
    and the failures per phase (a phase absent was not reported, which differs from zero failures)."""

    variant: str
    condition: str
    attempted: int
    succeeded: int
    mean_transfer_s: float | None = None
    failures: Mapping[str, int] = field(default_factory=dict)

    @property
    def key(self) -> tuple[str, str]:
        return (self.variant, self.condition)

    @property
    def rate(self) -> float:
        return self.succeeded / self.attempted if self.attempted else float("nan")


@dataclass(frozen=True)
class Outcomes:
    """The cells of one source (a table, a folder of tick logs), where they came from, and whether a
    trial's attempts end at a block lost for good (the paper's counting)."""

    cells: tuple[Cell, ...]
    source: str
    attempts_end_at_lost_block: bool = False

    def cell(self, variant: str, condition: str) -> Cell | None:
        return next((c for c in self.cells if c.key == (variant, condition)), None)

    @property
    def has_phases(self) -> bool:
        return any(c.failures for c in self.cells)
